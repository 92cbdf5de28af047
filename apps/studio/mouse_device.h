// The mouse as a pointing device, behind the same InputDevice interface as a Phantom: the viewport
// turns the 2D cursor into a 3D pointer (and a pick ray) and pushes it here; the haptic loop takes
// the states in order, so a click quicker than a loop tick is still a press and a release.
#pragma once

#include "kiji/haptics.h"

#include <deque>
#include <mutex>

namespace kiji::studio {

class MouseDevice : public InputDevice {
 public:
  std::string name() const override { return "mouse"; }
  // The pointer's new state (UI thread).
  void push(const ToolEvent& state);
  // The oldest state not yet taken, or the latest one (haptic loop).
  ToolEvent sample() override;
  // A mouse renders no force: the viewport draws the force the loop sent as an arrow instead.
  void set_force(const Vec3&) override {}
  ToolEvent current() const;

 private:
  mutable std::mutex mutex_;
  std::deque<ToolEvent> queue_;
  ToolEvent current_ = [] {
    ToolEvent e;
    e.buttons = 0;
    return e;
  }();
};

}  // namespace kiji::studio
