// kiji-studio --benchmark: the 2006 paper's tables 1-2 in the app. For each garment size and each
// tool, strokes are played with the mouse through the viewport (press, drag, release, as a user
// would) while the viewport redraws as fast as it can, with the garment's edges and vertices drawn
// everywhere, around the pointer, and not at all; it prints frames a second, the simulation's
// steps a second, and the haptic loop's rate and force-callback times.
#pragma once

class QApplication;

namespace kiji::studio {

class MainWindow;
class Studio;
struct StudioOptions;

int run_benchmark(QApplication& app, Studio& studio, MainWindow& window, const StudioOptions& options);

}  // namespace kiji::studio
