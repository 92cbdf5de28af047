// A tool written in Python, as the core sees it: a kiji::Tool whose begin / update / end / cancel
// call the Python object's methods (taking the GIL for each call: the core calls tools with it
// released), and whose haptic force is one of the core's force models, declared from Python and
// computed in C++ on the haptic thread (Python cannot answer a thousand times a second).
#pragma once

#include "bindings.h"

#include "kiji/haptic_force.h"
#include "kiji/tool.h"

#include <memory>
#include <mutex>

namespace kiji::python {

// The haptic force a tool written in Python declares (its `haptic` attribute): read by the haptic
// thread without the GIL or a lock (an atomic shared pointer), written by the tool's calls.
class HapticDeclaration {
 public:
  explicit HapticDeclaration(std::shared_ptr<ToolScope> scope) : scope_(std::move(scope)) {}
  std::shared_ptr<const HapticModel> model() const { return std::atomic_load(&model_); }
  void set(HapticModel model) { std::atomic_store(&model_, std::make_shared<const HapticModel>(std::move(model))); }
  const std::shared_ptr<ToolScope>& scope() const { return scope_; }

 private:
  std::shared_ptr<ToolScope> scope_;
  std::shared_ptr<const HapticModel> model_ = std::make_shared<const HapticModel>();
};

// The session as a tool written in Python sees it during its calls (kiji.ToolSession): the
// ToolContext of the call in progress.
struct ToolSessionHandle {
  std::shared_ptr<ToolScope> scope;
};

class PythonTool : public Tool {
 public:
  // With the GIL held: makes an instance of `cls` and reads its info().
  explicit PythonTool(const py::object& cls);
  ~PythonTool() override;

  ToolInfo info() const override { return info_; }
  Feedback begin(ToolContext& context, const ParamSet& params, const ToolEvent& event) override;
  Feedback update(ToolContext& context, const ToolEvent& event) override;
  void end(ToolContext& context, const ToolEvent& event) override;
  void cancel(ToolContext& context) override;
  Feedback haptic_force(const HapticSnapshot& snapshot, const ToolEvent& event) const override;

  const py::object& instance() const { return instance_.get(); }

 private:
  // Calls a method of the instance with the GIL and the scope held; converts what begin and update
  // return (None, a Feedback, or a force (3,)).
  Feedback call(ToolContext& context, const ToolEvent* event, const char* method, const std::function<py::object()>& fn);

  PyHandle instance_;
  ToolInfo info_;
  std::shared_ptr<ToolScope> scope_ = std::make_shared<ToolScope>();
  std::shared_ptr<HapticDeclaration> haptic_;
};

// The ToolInfo a Python tool declares (its info(), a kiji.ToolInfo), checked as the loader checks a
// plugin's: an id that is a Python identifier, parameters with identifier names and defaults in range.
ToolInfo python_tool_info(const py::object& instance, const std::string& where);

}  // namespace kiji::python
