#include "mouse_device.h"

namespace kiji::studio {

void MouseDevice::push(const ToolEvent& state) {
  std::lock_guard<std::mutex> lock(mutex_);
  // Moves between button changes merge only when the loop falls well behind (the knife follows every
  // move it gets); a button change is never dropped.
  if (queue_.size() > 16 && queue_.back().buttons == state.buttons) queue_.back() = state;
  else queue_.push_back(state);
  if (queue_.size() > 256) queue_.pop_front();
  current_ = state;
}

ToolEvent MouseDevice::sample() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (queue_.empty()) return current_;
  ToolEvent e = queue_.front();
  queue_.pop_front();
  return e;
}

ToolEvent MouseDevice::current() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return current_;
}

}  // namespace kiji::studio
