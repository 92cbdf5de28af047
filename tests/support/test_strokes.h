// Strokes and tools for the tests: the tool plugins of plugins/ loaded from the build tree, and
// straight strokes from one point to another.
#pragma once

#include "kiji/plugin_loader.h"
#include "kiji/tool_event.h"

#include <memory>

namespace kiji::test {

#ifdef KIJI_PLUGIN_DIR
// The tools of plugins/, loaded once from the build tree.
inline std::shared_ptr<ToolRegistry> plugins() {
  static std::shared_ptr<ToolRegistry> registry = [] {
    auto r = std::make_shared<ToolRegistry>();
    r->load_plugins({KIJI_PLUGIN_DIR});
    return r;
  }();
  return registry;
}
#endif

// A straight stroke of n + 1 events from a to b, starting at time t0, dt apart.
inline Stroke line(const Vec3& a, const Vec3& b, int n, double t0 = 0, double dt = 1.0 / 60,
                   std::uint32_t buttons = kButtonPrimary) {
  Stroke s;
  for (int i = 0; i <= n; ++i) {
    ToolEvent e;
    e.phase = i == 0 ? Phase::Begin : (i == n ? Phase::End : Phase::Move);
    e.time = t0 + i * dt;
    e.position = a + (b - a) * (double(i) / n);
    e.buttons = buttons;
    s.push_back(e);
  }
  return s;
}

}  // namespace kiji::test
