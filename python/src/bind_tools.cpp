// Tools written in Python: declaring parameters and tools (ParamSpec, ToolInfo), registering a class
// as a tool of a registry, the session a tool sees during its calls, and its declared haptic force.
#include "py_tool.h"

#include "kiji/plugin_loader.h"

#include <algorithm>

namespace kiji::python {

namespace {

std::string label_or(const std::string& label, const std::string& name) { return label.empty() ? name : label; }

ToolContext& scope_context(const ToolSessionHandle& h) { return h.scope->get("the session"); }

// A session's tool instance, with the session kept alive.
struct ToolInstance {
  std::shared_ptr<Session> session;
  const Tool* tool;
};

}  // namespace

void bind_tools(py::module_& m) {
  // --- declarations ---
  auto spec = py::reinterpret_borrow<py::class_<ParamSpec>>(m.attr("ParamSpec"));
  spec.def_static("boolean", [](const std::string& name, bool value, const std::string& label, const std::string& help) {
    return ParamSpec::boolean(name, value, label_or(label, name), help);
  }, py::arg("name"), py::arg("default"), py::kw_only(), py::arg("label") = "", py::arg("help") = "",
     "A bool parameter.");
  spec.def_static("integer", [](const std::string& name, long long value, long long min, long long max,
                                const std::string& label, const std::string& help) {
    return ParamSpec::integer(name, value, min, max, label_or(label, name), help);
  }, py::arg("name"), py::arg("default"), py::arg("min"), py::arg("max"), py::kw_only(), py::arg("label") = "",
     py::arg("help") = "", "An int parameter in [min, max] (min == max: any).");
  spec.def_static("real", [](const std::string& name, double value, double min, double max, const std::string& unit,
                             const std::string& label, const std::string& help) {
    return ParamSpec::real(name, value, min, max, unit, label_or(label, name), help);
  }, py::arg("name"), py::arg("default"), py::arg("min"), py::arg("max"), py::kw_only(), py::arg("unit") = "",
     py::arg("label") = "", py::arg("help") = "", "A float parameter in [min, max] (min == max: any), with its unit.");
  spec.def_static("text", [](const std::string& name, const std::string& value, const std::string& label,
                             const std::string& help) { return ParamSpec::text(name, value, label_or(label, name), help); },
                  py::arg("name"), py::arg("default"), py::kw_only(), py::arg("label") = "", py::arg("help") = "",
                  "A str parameter.");
  spec.def_static("choice", [](const std::string& name, const std::string& value, const std::vector<std::string>& choices,
                               const std::string& label, const std::string& help) {
    return ParamSpec::choice(name, value, choices, label_or(label, name), help);
  }, py::arg("name"), py::arg("default"), py::arg("choices"), py::kw_only(), py::arg("label") = "", py::arg("help") = "",
     "One of a list of words.");
  spec.def_static("color", [](const std::string& name, py::handle value, const std::string& label, const std::string& help) {
    return ParamSpec::color(name, to_vec3(value, "color"), label_or(label, name), help);
  }, py::arg("name"), py::arg("default"), py::kw_only(), py::arg("label") = "", py::arg("help") = "",
     "A colour (r, g, b), linear, each in [0, 1].");
  spec.def("check", [](const ParamSpec& s, py::handle value) {
    py::dict d;
    d[py::str(s.name)] = value;
    const auto map = param_map_from_python(d);
    s.check(map.at(s.name));
  }, py::arg("value"), "Raises InputError if the value has the wrong type or is out of range.");

  auto info = py::reinterpret_borrow<py::class_<ToolInfo>>(m.attr("ToolInfo"));
  info.def(py::init([](const std::string& id, const std::string& label, const std::string& description,
                       const std::vector<ParamSpec>& parameters) {
             return ToolInfo{id, label, description, parameters};
           }),
           py::arg("id"), py::arg("label"), py::arg("description"), py::arg("parameters") = std::vector<ParamSpec>{},
           "What a tool declares, as a C++ tool's info() does: its id (the verb, a Python identifier: the\n"
           "Session method's name), a label for menus, a description (the method's doc), and its parameters\n"
           "(ParamSpec.real(...), .integer, .boolean, .choice, .text, .color).");
  m.def("tool_metadata_json", [](const ToolInfo& i, const std::string& library) { return tool_metadata_json(i, library); },
        py::arg("info"), py::arg("library_file"),
        "The JSON metadata a C++ tool plugin carries beside its library (what the loader reads first).");

  // --- the registry ---
  auto reg = py::reinterpret_borrow<py::class_<ToolRegistry, std::shared_ptr<ToolRegistry>>>(m.attr("ToolRegistry"));
  reg.def("remove", &ToolRegistry::remove, py::arg("id"),
          "Forgets a tool (sessions keep the instances they made); False if there was none.");
  reg.def("_add_python_tool", [](ToolRegistry& r, py::object cls, const std::string& origin) {
    // One instance to read the declaration (and find a broken class now, not at the first stroke).
    const std::string id = PythonTool(cls).info().id;
    PyHandle handle(cls);
    r.add(id, [handle]() -> std::unique_ptr<Tool> {
      py::gil_scoped_acquire gil;
      return std::make_unique<PythonTool>(handle.get());
    }, origin);
    return id;
  }, py::arg("cls"), py::arg("origin"));

  // --- a session's tool instances ---
  py::class_<ToolInstance>(m, "ToolInstance",
      "The instance of a tool that a session's strokes use for one user (each user has their own): its\n"
      "declaration, the force it renders on the haptic thread, and for a tool written in Python the Python\n"
      "object itself.")
      .def("info", [](const ToolInstance& t) { return t.tool->info(); }, "The tool's declaration (ToolInfo).")
      .def("haptic_force", [](const ToolInstance& t, const HapticSnapshot& snapshot, const ToolEvent& e) {
        return t.tool->haptic_force(snapshot, e);
      }, py::arg("snapshot"), py::arg("event"),
         "The force the haptic loop would send for a pointer on a snapshot (what HapticLoop asks at 1 kHz).")
      .def_property_readonly("python", [](const ToolInstance& t) -> py::object {
        if (auto* p = dynamic_cast<const PythonTool*>(t.tool)) return p->instance();
        return py::none();
      }, "The Python object of a tool written in Python (None for a C++ tool).");
  auto session = py::reinterpret_borrow<py::class_<Session, std::shared_ptr<Session>>>(m.attr("Session"));
  session.def("tool", [](const std::shared_ptr<Session>& s, const std::string& id, UserId user) {
    SessionGuard lock(*s);
    return ToolInstance{s, &s->tool(id, user)};
  }, py::arg("id"), py::kw_only(), py::arg("user") = 0,
     "The instance of a tool a user's strokes use (made on first use).");

  // --- what a tool written in Python works with ---
  py::class_<ToolSessionHandle>(m, "ToolSession",
      "The session as a tool written in Python sees it during begin, update, end and cancel (the C++\n"
      "tools' kiji::ToolContext): its garments (views that change them in place: the stroke is the\n"
      "operation that the journal records), their solvers (hands on the cloth, forces, the local region),\n"
      "the body, the clock and picking. It refuses to be used outside the tool's calls, and offers no\n"
      "other operation (adding garments, undo, settings), which a stroke cannot contain.")
      .def("garment", [](const ToolSessionHandle& h, std::size_t i) {
        scope_context(h).garment(i);  // an index out of range is an InputError naming the garments there are
        return std::make_shared<GarmentRef>(h.scope, i);
      }, py::arg("index") = 0, "The garment at an index, as a view that edits it in place.")
      .def_property_readonly("garments", [](const ToolSessionHandle& h) {
        py::list out;
        for (std::size_t i = 0; i < scope_context(h).garment_count(); ++i) out.append(std::make_shared<GarmentRef>(h.scope, i));
        return out;
      })
      .def_property_readonly("garment_count", [](const ToolSessionHandle& h) { return scope_context(h).garment_count(); })
      .def("solver", [](const ToolSessionHandle& h, std::size_t i) {
        scope_context(h).garment(i);
        return tool_solver(h.scope, i);
      }, py::arg("garment") = 0,
         "The solver of a garment: hands on the cloth, forces and the local region for this stroke.")
      .def_property_readonly("body", [](const ToolSessionHandle& h) -> std::shared_ptr<Body> {
        const ToolContext& c = scope_context(h);
        return c.body() ? std::make_shared<Body>(*c.body()) : nullptr;
      })
      .def_property_readonly("time", [](const ToolSessionHandle& h) { return scope_context(h).time(); })
      .def_property_readonly("steps", [](const ToolSessionHandle& h) { return scope_context(h).steps(); })
      .def_property_readonly("frame_rate", [](const ToolSessionHandle& h) { return scope_context(h).frame_rate(); })
      .def_property_readonly("solver_params", [](const ToolSessionHandle& h) { return scope_context(h).solver_params(); })
      .def_property_readonly("pick_radius", [](const ToolSessionHandle& h) { return scope_context(h).pick_radius(); })
      .def("pick", [](const ToolSessionHandle& h, py::handle position, py::handle ray) {
        const Vec3 p = to_vec3(position, "position");
        const Vec3 r = ray.is_none() ? Vec3::Zero() : to_vec3(ray, "ray");
        return scope_context(h).pick(p, r);
      }, py::arg("position"), py::arg("ray") = py::none(), "The cloth under a pointer, as Session.pick.")
      .def_property_readonly("active", [](const ToolSessionHandle& h) { return h.scope->active(); },
                             "Whether the tool's call is in progress (the only time this can be used).")
      .def("__repr__", [](const ToolSessionHandle& h) {
        return std::string("<kiji.ToolSession") + (h.scope->active() ? "" : ", outside the tool's calls") + ">";
      });

  py::class_<HapticDeclaration, std::shared_ptr<HapticDeclaration>>(m, "ToolHaptics",
      "The force a tool written in Python gives the hand on a haptic device (its `haptic` attribute). The\n"
      "haptic loop runs at 1 kHz on its own thread, where Python cannot be called (the interpreter's lock\n"
      "would stall it, and a call takes tens of microseconds at best), so a Python tool declares one of the\n"
      "core's force models, which the loop computes in C++ on the latest snapshot of the cloth:\n"
      "spring() to the cloth it grabbed (as pinch), push() out of the cloth along its normal (as paint),\n"
      "or clear() for none (the default). A spring is let go at the end of the stroke.")
      .def("spring", [](HapticDeclaration& d, py::handle vertices, double stiffness, std::optional<std::size_t> garment) {
        const ToolContext& s = d.scope()->get("tool.haptic.spring()");
        const ToolEvent& e = d.scope()->event;
        const std::size_t gi = garment ? *garment : e.hit.garment;
        const Garment& g = s.garment(gi);
        if (!std::isfinite(stiffness) || stiffness <= 0)
          throw InputError("haptic.spring: stiffness must be a positive number of N/m");
        const VertexRows rows(g);
        py::array a = py::module_::import("numpy").attr("asarray")(vertices);
        if (a.dtype().kind() != 'i' && a.dtype().kind() != 'u')
          throw py::type_error("haptic.spring: vertices must be vertex rows (an int or an array of ints)");
        auto r = py::array_t<long long, py::array::c_style | py::array::forcecast>::ensure(a.attr("reshape")(-1));
        std::vector<Vertex> vs;
        for (py::ssize_t i = 0; i < r.size(); ++i) {
          const long long x = r.data()[i];
          if (x < 0 || x >= static_cast<long long>(rows.vertices.size()))
            throw InputError("haptic.spring: vertex row " + std::to_string(x) + " does not exist");
          vs.push_back(rows.vertices[x]);
        }
        std::sort(vs.begin(), vs.end());
        vs.erase(std::unique(vs.begin(), vs.end()), vs.end());
        HapticSpring spring;
        spring.garment = gi;
        spring.vertices = vs;
        spring.stiffness = stiffness;
        for (Vertex v : vs) spring.offsets.push_back(g.position(v) - e.position);
        d.set(std::move(spring));
      }, py::arg("vertices"), py::arg("stiffness"), py::arg("garment") = py::none(),
         "Declares a spring of `stiffness` N/m in all (shared among the vertices) from the pen to the cloth\n"
         "it holds: vertex rows of a garment (default: the one under the pointer), each held at its offset\n"
         "from the pointer now. Call it during begin or update.")
      .def("push", [](HapticDeclaration& d, double touch, double stiffness) {
        if (!(touch > 0 && touch < 1) || !(stiffness > 0 && std::isfinite(stiffness)))
          throw InputError("haptic.push: touch must be in (0, 1) m and stiffness a positive number of N/m");
        d.set(HapticPush{touch, stiffness});
      }, py::arg("touch") = 0.005, py::arg("stiffness") = 300.0,
         "Declares a push out of the cloth along its normal, stiffness (touch - distance), within `touch` metres.")
      .def("clear", [](HapticDeclaration& d) { d.set(std::monostate{}); }, "No force.")
      .def_property_readonly("model", [](const HapticDeclaration& d) {
        const auto m = d.model();
        return std::string(std::holds_alternative<HapticSpring>(*m) ? "spring"
                           : std::holds_alternative<HapticPush>(*m) ? "push" : "none");
      }, "'spring', 'push' or 'none'.")
      .def("force", [](const HapticDeclaration& d, const HapticSnapshot& snapshot, const ToolEvent& e) {
        return haptic_model_force(*d.model(), snapshot, e);
      }, py::arg("snapshot"), py::arg("event"), "The force the haptic loop would send for a pointer (Feedback).")
      .def("__repr__", [](const HapticDeclaration& d) {
        const auto m = d.model();
        return std::string("<kiji.ToolHaptics ") +
               (std::holds_alternative<HapticSpring>(*m) ? "spring" : std::holds_alternative<HapticPush>(*m) ? "push" : "none") + ">";
      });
}

}  // namespace kiji::python
