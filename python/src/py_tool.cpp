// A tool written in Python behind the core's Tool interface (see py_tool.h).
#include "py_tool.h"

#include <set>

namespace kiji::python {

namespace {

bool is_identifier(const std::string& s) { return py::str(s).attr("isidentifier")().cast<bool>(); }

// What begin and update may return: None, a kiji.Feedback, or a force (3,).
Feedback feedback_from(const py::object& r, const std::string& where) {
  if (r.is_none()) return {};
  if (py::isinstance<Feedback>(r)) return r.cast<Feedback>();
  try {
    Feedback f;
    f.force = to_vec3(r, (where + " returned a force that").c_str());
    return f;
  } catch (const py::type_error&) {
    throw py::type_error(where + " must return None, a kiji.Feedback or a force (3,), not " +
                         py::str(py::type::of(r).attr("__name__")).cast<std::string>());
  }
}

}  // namespace

ToolInfo python_tool_info(const py::object& instance, const std::string& where) {
  if (!py::hasattr(instance, "info")) throw py::type_error(where + " has no info() declaring the tool");
  py::object r = instance.attr("info")();
  if (!py::isinstance<ToolInfo>(r))
    throw py::type_error(where + ".info() must return a kiji.ToolInfo, not " +
                         py::str(py::type::of(r).attr("__name__")).cast<std::string>());
  ToolInfo info = r.cast<ToolInfo>();
  if (!is_identifier(info.id))
    throw InputError(where + ": tool id '" + info.id + "' is not a Python identifier (it names the Session method)");
  std::set<std::string> names;
  for (const auto& p : info.parameters)
    if (!names.insert(p.name).second) throw InputError(where + ": parameter '" + p.name + "' is declared twice");
  return info;
}

PythonTool::PythonTool(const py::object& cls) {
  py::object instance = cls();
  const std::string where = py::str(cls.attr("__qualname__")).cast<std::string>();
  info_ = python_tool_info(instance, where);
  haptic_ = std::make_shared<HapticDeclaration>(scope_);
  instance.attr("haptic") = py::cast(haptic_);
  instance_ = PyHandle(std::move(instance));
}

PythonTool::~PythonTool() { scope_->context = nullptr; }

Feedback PythonTool::call(ToolContext& context, const ToolEvent* event, const char* method,
                          const std::function<py::object()>& fn) {
  py::gil_scoped_acquire gil;
  // The context lives for this call only: the one before it comes back when the call returns.
  struct Leave {
    ToolScope& scope;
    ToolContext* before;
    ~Leave() {
      --scope.depth;
      scope.context = before;
    }
  } leave{*scope_, scope_->context};
  scope_->context = &context;
  if (event) scope_->event = *event;
  ++scope_->depth;
  return feedback_from(fn(), info_.id + "." + method + "()");
}

namespace {
py::object tool_session(const std::shared_ptr<ToolScope>& scope) { return py::cast(ToolSessionHandle{scope}); }
}  // namespace

Feedback PythonTool::begin(ToolContext& context, const ParamSet& params, const ToolEvent& event) {
  return call(context, &event, "begin", [&] {
    return instance().attr("begin")(tool_session(scope_), param_map_to_python(params.values()), event);
  });
}

Feedback PythonTool::update(ToolContext& context, const ToolEvent& event) {
  return call(context, &event, "update", [&] { return instance().attr("update")(tool_session(scope_), event); });
}

void PythonTool::end(ToolContext& context, const ToolEvent& event) {
  call(context, &event, "end", [&] {
    instance().attr("end")(tool_session(scope_), event);
    return py::object(py::none());
  });
  // The hand lets go: a spring to the cloth it held has nothing to pull.
  if (std::holds_alternative<HapticSpring>(*haptic_->model())) haptic_->set(std::monostate{});
}

void PythonTool::cancel(ToolContext& context) {
  if (std::holds_alternative<HapticSpring>(*haptic_->model())) haptic_->set(std::monostate{});
  call(context, nullptr, "cancel", [&] {
    instance().attr("cancel")(tool_session(scope_));
    return py::object(py::none());
  });
}

Feedback PythonTool::haptic_force(const HapticSnapshot& snapshot, const ToolEvent& event) const {
  return haptic_model_force(*haptic_->model(), snapshot, event);
}

}  // namespace kiji::python
