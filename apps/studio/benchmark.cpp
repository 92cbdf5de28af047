#include "benchmark.h"

#include "main_window.h"
#include "studio_options.h"
#include "tool_panel.h"

#include "kiji/session.h"

#include <QApplication>
#include <QDir>
#include <QFile>
#include <QElapsedTimer>
#include <QEventLoop>
#include <QMouseEvent>
#include <QTimer>

#include <cmath>
#include <cstdio>
#include <map>

namespace kiji::studio {

namespace {

// Waits, letting the app run.
void spin(double seconds) {
  QEventLoop loop;
  QTimer::singleShot(int(seconds * 1000), &loop, &QEventLoop::quit);
  loop.exec();
}

// A stroke over the hanging cloth (x in [-0.5, 0.5], y in [0.7, 1.7], the plane z = 0 before it
// sags) as the cursor would make it: where it presses, and the cursor at a fraction of the stroke.
struct StrokePath {
  Vec3 (*at)(double u);
};

Vec3 pinch_path(double u) { return Vec3(0.12 * std::sin(2 * M_PI * u), 1.25 + 0.12 * std::cos(2 * M_PI * u) - 0.12, 0.0); }
Vec3 across_path(double u) { return Vec3(-0.7 + 1.4 * u, 1.2 - 0.05 * std::sin(M_PI * u), 0.0); }
Vec3 paint_path(double u) { return Vec3(-0.35 + 0.7 * u, 1.3 + 0.15 * std::sin(4 * M_PI * u), 0.0); }
Vec3 tear_path(double u) { return Vec3(0.0, 0.8 - 0.6 * u, 0.0); }
Vec3 sew_path(double u) { return Vec3(-0.48 + 0.9 * u, 0.72, 0.0); }

StrokePath path_for(const std::string& id) {
  if (id == "pinch") return {pinch_path};
  if (id == "cut") return {across_path};
  if (id == "paint") return {paint_path};
  if (id == "tear") return {tear_path};
  if (id == "sew") return {sew_path};
  return {paint_path};  // a tool the benchmark does not know: a sweep over the cloth
}

void send(Viewport& v, QEvent::Type type, const QPointF& at, Qt::MouseButtons buttons) {
  const Qt::MouseButton button = type == QEvent::MouseMove ? Qt::NoButton : Qt::LeftButton;
  QMouseEvent e(type, at, v.mapToGlobal(at), button, buttons, Qt::NoModifier);
  QApplication::sendEvent(&v, &e);
}

// CPU time of this process's threads, in seconds, from /proc (nanoseconds on the CPU): the
// drawing's (the UI thread and Mesa's llvmpipe threads, which rasterise) and the rest's. On a
// machine shared with other work, frames a second fall with the share of the cores the process
// gets; CPU time a frame does not.
struct CpuTimes {
  double drawing = 0, other = 0;
};

CpuTimes cpu_times() {
  CpuTimes t;
  QDir tasks("/proc/self/task");
  const QString self = QString::number(QCoreApplication::applicationPid());
  for (const QString& tid : tasks.entryList(QDir::Dirs | QDir::NoDotAndDotDot)) {
    QFile stat(tasks.filePath(tid + "/schedstat")), comm(tasks.filePath(tid + "/comm"));
    if (!stat.open(QIODevice::ReadOnly) || !comm.open(QIODevice::ReadOnly)) continue;
    const double seconds = QString(stat.readAll()).split(' ').value(0).toDouble() / 1e9;
    const QString name = QString(comm.readAll()).trimmed();
    if (tid == self || name.startsWith("llvmpipe")) t.drawing += seconds;
    else t.other += seconds;
  }
  return t;
}

struct Result {
  double fps = 0, steps = 0, step_ms = 0, publish_ms = 0, haptic_hz = 0, force_p99 = 0, force_median = 0, edges = 0;
  double draw_cpu_ms = 0;  // CPU time a frame of the UI thread and llvmpipe's threads
};

}  // namespace

int run_benchmark(QApplication&, Studio& studio, MainWindow& window, const StudioOptions& o) {
  std::vector<std::string> tools = o.bench_tools;
  if (tools.empty()) tools = studio.tools().ids();
  for (const std::string& t : tools)
    if (!studio.tools().has(t)) {
      std::fprintf(stderr, "kiji-studio: --bench-tools: there is no tool '%s'\n", t.c_str());
      return 2;
    }
  Viewport& view = window.viewport();
  const std::pair<const char*, EdgeDisplay> modes[] = {
      {"none", EdgeDisplay::None}, {"local", EdgeDisplay::Local}, {"all", EdgeDisplay::All}};
  std::printf("Kiji Studio benchmark: viewport frames a second while each tool is used (the viewport redrawing as "
              "fast as it can),\nwith the garment's edges and vertices drawn not at all, around the pointer (%.2f m) "
              "and everywhere; [simulation steps a second].\nA 1 m square hanging from its top edge; strokes played "
              "with the mouse through the viewport; %.1f s a measurement; viewport %dx%d.\n",
              view.draw_options().local_radius, o.bench_seconds, view.width(), view.height());
  std::fflush(stdout);
  std::map<std::string, std::vector<Result>> all;
  double worst_p99 = 0, least_hz = 1e9;
  for (int size : o.bench_sizes) {
    const int n = std::max(2, int(std::lround(std::sqrt(double(size)))));
    GarmentSpec spec;
    spec.width = spec.height = 1.0;
    spec.spacing = 1.0 / (n - 1);
    studio.new_scene();
    studio.add_garment(spec);
    // Held along its whole top edge, the cloth hangs at rest (and its blocks fall asleep) where no
    // tool works: what is measured is the tools' work and the drawing, not a cloth swinging.
    studio.loop().call([](Session& s) {
      Garment g = s.garment(0);
      const double top = g.bounds().max().y();
      for (Vertex v : g.mesh().vertices())
        if (g.position(v).y() > top - 1e-9) g.set_pinned(v, true);
      s.set_garment(0, g);
    });
    studio.use_device(DeviceKind::Mouse);
    spin(0.3);
    const auto first = studio.frame();
    std::printf("\nV=%zu P=%zu\n%-8s %42s %42s %42s\n", first->vertices, first->faces, "tool", "none", "local", "all");
    for (const std::string& tool : tools) {
      std::printf("%-8s", tool.c_str());
      for (const auto& [mode_name, mode] : modes) {
        studio.reset();
        studio.use_device(DeviceKind::Mouse);
        window.tool_panel().choose(tool);
        if (tool == "pinch") {
          // The paper's local-region mode: only the cloth near the hand is simulated.
          ParamSet p = window.tool_panel().params_of("pinch");
          p.set("local_radius", 0.15);
          studio.set_tool(kButtonPrimary, "pinch", p);
        }
        window.set_edge_display(mode);
        view.frame_all();
        spin(0.3);
        const StrokePath path = path_for(tool);
        view.set_continuous(true);
        const std::uint64_t frames0 = view.frames_drawn();
        const std::uint64_t steps0 = studio.loop().stats().steps;
        const HapticStats h0 = studio.haptics()->stats();
        const CpuTimes cpu0 = cpu_times();
        QElapsedTimer clock;
        clock.start();
        bool down = false;
        double edges = 0;
        int samples = 0;
        QTimer driver;
        QEventLoop wait;
        QObject::connect(&driver, &QTimer::timeout, &wait, [&] {
          const double t = clock.elapsed() / 1000.0;
          if (t >= o.bench_seconds) {
            if (down) send(view, QEvent::MouseButtonRelease, view.project(path.at(1.0)), Qt::NoButton);
            wait.quit();
            return;
          }
          const double cycle = 1.5, u = std::fmod(t, cycle) / cycle;
          const QPointF px = view.project(path.at(std::min(u / 0.9, 1.0)));
          if (!down && u < 0.9) {
            send(view, QEvent::MouseButtonPress, px, Qt::LeftButton);
            down = true;
          } else if (down && u >= 0.9) {
            send(view, QEvent::MouseButtonRelease, px, Qt::NoButton);
            down = false;
          } else {
            send(view, QEvent::MouseMove, px, down ? Qt::LeftButton : Qt::NoButton);
          }
          edges += double(view.edges_drawn());
          ++samples;
        });
        driver.start(16);
        wait.exec();
        const double seconds = clock.elapsed() / 1000.0;
        const CpuTimes cpu1 = cpu_times();
        view.set_continuous(false);
        Result r;
        const double frames = double(view.frames_drawn() - frames0);
        r.fps = frames / seconds;
        r.draw_cpu_ms = frames > 0 ? 1000 * (cpu1.drawing - cpu0.drawing) / frames : 0;
        const SimulationStats sim = studio.loop().stats();
        r.steps = double(sim.steps - steps0) / seconds;
        r.step_ms = sim.step_ms;
        r.publish_ms = sim.publish_ms;
        const HapticStats h = studio.haptics()->stats();
        r.haptic_hz = seconds > 0 ? double(h.ticks - h0.ticks) / seconds : 0;
        r.force_p99 = h.force_p99_us;
        r.force_median = h.force_median_us;
        r.edges = samples ? edges / samples : 0;
        worst_p99 = std::max(worst_p99, r.force_p99);
        least_hz = std::min(least_hz, r.haptic_hz);
        all[tool].push_back(r);
        char cell[128];
        std::snprintf(cell, sizeof cell, "%5.1f (%5.1f ms) [%3.0f %5.1f/%4.1f ms] %5.0fe", r.fps, r.draw_cpu_ms, r.steps,
                      r.step_ms, r.publish_ms, r.edges);
        std::printf(" %42s", cell);
        std::fflush(stdout);
        spin(0.2);
      }
      std::printf("\n");
    }
  }
  std::printf("\nCells: frames/s (CPU ms a frame: the UI thread and llvmpipe's) [simulation steps/s, ms a tick / of "
              "which publishing the frame and snapshot] edges drawn a frame (mean).\n");
  std::printf("Haptic loop (mouse device, the tool's force on the snapshot at 1 kHz): lowest rate %.0f Hz over the "
              "runs; force callback p99 at most %.2f us.\n",
              least_hz, worst_p99);
  std::fflush(stdout);
  return 0;
}

}  // namespace kiji::studio
