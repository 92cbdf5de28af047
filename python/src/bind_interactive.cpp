// Interactive use from Python: a tool driven event by event (begin, update, end, cancel) through
// Session::apply, the one path every tool event takes, and what comes back (Feedback).
#include "bindings.h"

#include <cmath>

namespace kiji::python {

namespace {

using SessionPtr = std::shared_ptr<Session>;

// One event through Session::apply, with the GIL released (the event may step the simulation to its
// time; a tool written in Python takes the GIL back for its own calls).
Feedback apply_event(Session& s, const std::string& tool, const ToolEvent& e, const ParamSet* params, UserId user) {
  py::gil_scoped_release nogil;
  return s.apply(tool, e, params, user);
}

const std::string& active_tool_or_throw(const Session& s, UserId user, const char* call) {
  const std::string& tool = s.stroke_tool(user);
  if (tool.empty())
    throw InputError(std::string(call) + ": user " + std::to_string(user) +
                     " has no stroke in progress: start one with session.begin(tool, event, **params)");
  return tool;
}

}  // namespace

void bind_interactive(py::module_& m) {
  py::class_<Feedback>(m, "Feedback", "What a tool gives back for an event: the force (N) and torque (N m) on the user's hand.")
      .def(py::init([](py::handle force, py::handle torque) {
             Feedback f;
             if (!force.is_none()) f.force = to_vec3(force, "force");
             if (!torque.is_none()) f.torque = to_vec3(torque, "torque");
             return f;
           }),
           py::arg("force") = py::none(), py::arg("torque") = py::none())
      .def_property(
          "force", [](const Feedback& f) { return vec3_array(f.force); },
          [](Feedback& f, py::handle v) { f.force = to_vec3(v, "force"); }, "(3,) newtons, on the hand")
      .def_property(
          "torque", [](const Feedback& f) { return vec3_array(f.torque); },
          [](Feedback& f, py::handle v) { f.torque = to_vec3(v, "torque"); }, "(3,) newton-metres")
      .def("__repr__", [](const Feedback& f) {
        auto v = [](const Vec3& x) {
          return "(" + std::to_string(x.x()) + ", " + std::to_string(x.y()) + ", " + std::to_string(x.z()) + ")";
        };
        return "Feedback(force=" + v(f.force) + ", torque=" + v(f.torque) + ")";
      });

  auto event = py::reinterpret_borrow<py::class_<ToolEvent>>(m.attr("ToolEvent"));
  event.def_property_readonly("hit", [](const ToolEvent& e) { return e.hit; },
                              "The cloth under the pointer (SurfaceHit), filled in by the session before a tool sees\n"
                              "the event; empty (hit False) in an event a device or script made.");
  auto hit = py::reinterpret_borrow<py::class_<SurfaceHit>>(m.attr("SurfaceHit"));
  hit.def_property_readonly("face_id", [](const SurfaceHit& h) { return h.hit ? long(h.face.idx()) : -1L; },
                            "The id of the face hit (-1 for no hit); equals its row in garment.faces until a\n"
                            "topology edit leaves holes.");
  hit.def("__repr__", [](const SurfaceHit& h) {
    if (!h.hit) return std::string("SurfaceHit(hit=False)");
    return "SurfaceHit(garment=" + std::to_string(h.garment) + ", vertex_id=" + std::to_string(h.nearest.idx()) +
           ", distance=" + std::to_string(h.distance) + ")";
  });

  auto s = py::reinterpret_borrow<py::class_<Session, SessionPtr>>(m.attr("Session"));
  s.def("_begin", [](Session& self, const std::string& tool, py::handle ev, const py::dict& params, UserId user) {
    SessionGuard lock(self);
    if (!self.tools().has(tool)) self.tools().info(tool);  // throws naming the known tools
    const ParamSet ps = params_from_python(self, tool, params);
    const ToolEvent e = event_arg(ev, Phase::Begin, self.time());
    return apply_event(self, tool, e, &ps, user);
  });
  s.def("update", [](Session& self, py::handle ev, UserId user) {
    SessionGuard lock(self);
    const std::string tool = active_tool_or_throw(self, user, "update");
    return apply_event(self, tool, event_arg(ev, Phase::Move, self.time()), nullptr, user);
  }, py::arg("event"), py::kw_only(), py::arg("user") = 0,
     "The pointer moved with the button held: a kiji.ToolEvent('move', ...) or a pointer position (3,)\n"
     "at the session's clock. An event later than the clock first steps the simulation to its time.\n"
     "Returns the tool's Feedback.");
  s.def("end", [](Session& self, py::handle ev, UserId user) {
    SessionGuard lock(self);
    const std::string tool = active_tool_or_throw(self, user, "end");
    return apply_event(self, tool, event_arg(ev, Phase::End, self.time()), nullptr, user);
  }, py::arg("event"), py::kw_only(), py::arg("user") = 0,
     "The button was released: the stroke is finished and becomes one step of the undo history.");
  s.def("cancel", [](Session& self, UserId user) {
    SessionGuard lock(self);
    const std::string tool = self.stroke_tool(user);
    if (tool.empty()) return false;
    apply_event(self, tool, cancel_event(self.time()), nullptr, user);
    return true;
  }, py::kw_only(), py::arg("user") = 0,
     "Abandons the user's stroke: the garments go back to where it began. False if there was none.");
  s.def("active_tool", [](const Session& self, UserId user) -> py::object {
    SessionGuard lock(self);
    const std::string& t = self.stroke_tool(user);
    return t.empty() ? py::object(py::none()) : py::object(py::str(t));
  }, py::kw_only(), py::arg("user") = 0,
     "The tool of the user's stroke in progress, or None (in a shared session, from its begin, before\n"
     "its turn to be applied comes).");
  s.def_property_readonly("active_users", [](const Session& self) {
    SessionGuard lock(self);
    return self.active_users();
  }, "The users (ids) with a stroke in progress.");
  s.def("advance_to", [](Session& self, double t) {
    SessionGuard lock(self);
    py::gil_scoped_release nogil;
    self.advance_to(t);
  }, py::arg("time"),
     "Steps the simulation until the clock reaches `time` (nothing if it has); at most\n"
     "Session.MAX_ADVANCE_SECONDS ahead at once.");
  s.attr("MAX_ADVANCE_SECONDS") = Session::max_advance_seconds;
  s.def("set_garment", [](Session& self, std::size_t i, const std::shared_ptr<GarmentRef>& g) {
    if (!g) throw py::type_error("set_garment: expected a kiji.Garment");
    Garment copy;
    {
      auto other = g->guard();
      copy = g->get();
    }
    SessionGuard lock(self);
    self.set_garment(i, copy);
  }, py::arg("index"), py::arg("garment"),
     "Replaces the garment at an index by (a copy of) another, validated: one set_garment operation, an\n"
     "undo step. (Assignments through a garment view do this for you.)");
  s.def("_params_for", [](const Session& self, const std::string& tool, const py::dict& values) {
    SessionGuard lock(self);
    return param_map_to_python(params_from_python(self, tool, values).values());
  });
  s.def_property_readonly("registry", [](const Session& self) {
    // The registry is shared: a Session holds it by shared_ptr, and ToolRegistry is bound with that holder.
    SessionGuard lock(self);
    return py::cast(&const_cast<Session&>(self).tools(), py::return_value_policy::reference_internal, py::cast(&self));
  }, "The ToolRegistry this session takes its tools from (kiji.register_tool(cls, registry=...)).");
}

}  // namespace kiji::python
