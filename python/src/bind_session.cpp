// Sessions, tools and their parameters, tool events, the journal and replay.
#include "bindings.h"

#include "kiji/drape.h"
#include "kiji/journal_file.h"
#include "kiji/session_file.h"
#include "kiji/plugin_loader.h"
#include "kiji/render.h"

#include <cmath>

namespace kiji::python {

namespace {

using SessionPtr = std::shared_ptr<Session>;

// An autosave with the session it writes for: the autosave goes first, while its session is alive.
struct PyAutosave {
  SessionPtr session;
  std::unique_ptr<Autosave> autosave;
  PyAutosave(SessionPtr s, const std::string& path, bool append)
      : session(std::move(s)), autosave(std::make_unique<Autosave>(*session, path, append)) {}
  PyAutosave(SessionPtr s, std::unique_ptr<Autosave> a) : session(std::move(s)), autosave(std::move(a)) {}
  ~PyAutosave() { autosave.reset(); }
};

py::object param_default(const ParamSpec& s) { return param_value_to_python(s.default_value); }

py::dict report_dict(const PluginReport& r) {
  py::dict d;
  d["path"] = r.path;
  d["id"] = r.id;
  d["loaded"] = r.loaded;
  d["message"] = r.message;
  return d;
}

// A column of per-event values: None (the default for every event), one value for all, or N values.
template <typename T>
std::vector<T> column(py::handle obj, std::size_t n, T fallback, const char* what) {
  if (obj.is_none()) return std::vector<T>(n, fallback);
  py::array a = py::module_::import("numpy").attr("asarray")(obj);
  if (a.ndim() == 0) {
    auto v = real_array(a.attr("reshape")(1), what, 1, 0);
    return std::vector<T>(n, static_cast<T>(v.data()[0]));
  }
  auto v = real_array(a, what, static_cast<long>(n), 0);
  return std::vector<T>(v.data(), v.data() + n);
}

// The events of a stroke from arrays. Phases default to begin, move ..., end (one point: begin, end);
// times to the session's clock, one step (1 / frame rate) apart, or `dt` apart.
Stroke make_stroke(const Session& s, py::handle positions, py::handle phases, py::handle times, double dt,
                   py::handle buttons, py::handle pressures, py::handle rays, py::handle orientations) {
  auto p = real_array(positions, "stroke", -1, 3);
  std::size_t n = static_cast<std::size_t>(p.shape(0));
  if (n == 0) throw InputError("the stroke has no points: give at least one pointer position");
  std::vector<Phase> ph;
  if (!phases.is_none()) {
    for (auto x : phases) ph.push_back(parse_phase(py::str(x).cast<std::string>()));
    if (ph.size() != n) throw InputError("phases has " + std::to_string(ph.size()) + " entries for " + std::to_string(n) + " points");
  }
  const bool single = n == 1 && ph.empty();
  const std::size_t count = single ? 2 : n;  // one point: press and release there
  auto row = [&](std::size_t i) { return single ? 0 : i; };
  if (!std::isfinite(dt) || dt < 0) throw InputError("dt must be a finite number of seconds, 0 or more");
  std::vector<double> t;
  if (times.is_none()) {
    for (std::size_t i = 0; i < count; ++i) t.push_back(s.time() + dt * double(i));
  } else {
    t = column<double>(times, n, 0.0, "times");
    if (single) t.push_back(t[0]);
  }
  auto b = column<double>(buttons, n, kButtonPrimary, "buttons");
  auto pr = column<double>(pressures, n, 1.0, "pressure");
  std::vector<Vec3> ray(n, Vec3::Zero());
  if (!rays.is_none()) {
    py::array ra = py::module_::import("numpy").attr("asarray")(rays);
    if (ra.ndim() == 1) {
      const Vec3 r = to_vec3(ra, "rays");
      std::fill(ray.begin(), ray.end(), r);
    } else {
      auto r = real_array(ra, "rays", static_cast<long>(n), 3);
      for (std::size_t i = 0; i < n; ++i) ray[i] = Vec3(r.at(i, 0), r.at(i, 1), r.at(i, 2));
    }
  }
  std::vector<Eigen::Quaterniond> q(n, Eigen::Quaterniond::Identity());
  if (!orientations.is_none()) {
    auto o = real_array(orientations, "orientations (w, x, y, z)", static_cast<long>(n), 4);
    for (std::size_t i = 0; i < n; ++i) q[i] = Eigen::Quaterniond(o.at(i, 0), o.at(i, 1), o.at(i, 2), o.at(i, 3)).normalized();
  }
  Stroke stroke(count);
  for (std::size_t i = 0; i < count; ++i) {
    ToolEvent& e = stroke[i];
    const std::size_t k = row(i);
    e.phase = !ph.empty() ? ph[i] : (i == 0 ? Phase::Begin : (i + 1 == count ? Phase::End : Phase::Move));
    e.time = t[i];
    e.position = Vec3(p.at(k, 0), p.at(k, 1), p.at(k, 2));
    if (b[k] < 0 || b[k] != std::floor(b[k])) throw InputError("buttons must be whole numbers 0 or more (1 primary, 2 secondary)");
    e.buttons = static_cast<std::uint32_t>(b[k]);
    if (pr[k] < 0 || pr[k] > 1) throw InputError("pressure must be in [0, 1]");
    e.pressure = pr[k];
    e.ray = ray[k];
    e.orientation = q[k];
  }
  if (stroke.front().phase != Phase::Begin) throw InputError("a stroke must start with a 'begin' event");
  return stroke;
}

// Runs a stroke with the GIL released; returns the feedback force of every event, (N, 3).
py::array_t<double> run_stroke(Session& s, const std::string& tool_id, const ParamSet& params, const Stroke& stroke,
                               const py::object& progress) {
  Tool& tool = s.tool(tool_id);
  std::vector<Vec3> forces(stroke.size(), Vec3::Zero());
  const ProgressHook hook(progress);
  {
    py::gil_scoped_release nogil;
    try {
      for (std::size_t i = 0; i < stroke.size(); ++i) {
        if (i > 0 && s.stroke_tool().empty()) break;  // an End or Cancel closed it (stroke_tool: shared too)
        forces[i] = s.apply(tool, at_the_clock(stroke[i], s.time()), &params).force;
        if (!hook(double(i + 1) / double(stroke.size()))) {
          if (!s.stroke_tool().empty()) s.apply(tool, ToolEvent{Phase::Cancel, s.time()});
          break;
        }
      }
      if (!s.stroke_tool().empty()) {  // a stroke without End ends where it stops, as a released button
        ToolEvent end = at_the_clock(stroke.back(), s.time());
        end.phase = Phase::End;
        s.apply(tool, end, &params);
      }
    } catch (...) {
      // An interrupt or an error between events: cancel, so nothing is half-applied.
      if (!s.stroke_tool().empty()) {
        try {
          s.apply(tool, ToolEvent{Phase::Cancel, s.time()});
        } catch (...) {
        }
      }
      throw;
    }
  }
  py::array_t<double> out({static_cast<py::ssize_t>(forces.size()), py::ssize_t(3)});
  for (std::size_t i = 0; i < forces.size(); ++i)
    for (int k = 0; k < 3; ++k) out.mutable_at(i, k) = forces[i][k];
  return out;
}

void simulate(Session& s, double seconds, const py::object& progress) {
  if (!std::isfinite(seconds) || seconds < 0 || seconds > 3600)
    throw InputError("simulate: seconds must be between 0 and 3600");
  const auto steps = static_cast<std::size_t>(std::llround(seconds * s.frame_rate()));
  const ProgressHook hook(progress);
  py::gil_scoped_release nogil;
  for (std::size_t i = 0; i < steps; ++i) {
    s.step();
    if (!hook(double(i + 1) / double(steps))) break;
  }
}

py::list garment_list(const SessionPtr& s) {
  SessionGuard lock(*s);
  py::list out;
  for (std::size_t i = 0; i < s->garment_count(); ++i) out.append(std::make_shared<GarmentRef>(s, i));
  return out;
}

}  // namespace

void bind_session(py::module_& m) {
  // --- parameters and tools ---
  py::class_<ParamSpec>(m, "ParamSpec", "A tool parameter as the tool declares it.")
      .def_readonly("name", &ParamSpec::name)
      .def_property_readonly("type", [](const ParamSpec& s) { return std::string(param_type_name(s.type)); })
      .def_property_readonly("default", &param_default)
      .def_property_readonly("min", [](const ParamSpec& s) -> py::object {
        if ((s.type != ParamType::Int && s.type != ParamType::Float) || s.min == s.max) return py::none();
        return py::float_(s.min);
      })
      .def_property_readonly("max", [](const ParamSpec& s) -> py::object {
        if ((s.type != ParamType::Int && s.type != ParamType::Float) || s.min == s.max) return py::none();
        return py::float_(s.max);
      })
      .def_readonly("unit", &ParamSpec::unit)
      .def_readonly("label", &ParamSpec::label)
      .def_readonly("help", &ParamSpec::help)
      .def_readonly("choices", &ParamSpec::choices)
      .def("__repr__", [](const ParamSpec& s) {
        return "<kiji.ParamSpec " + s.name + ": " + param_type_name(s.type) + " = " +
               py::repr(param_default(s)).cast<std::string>() + ">";
      });
  py::class_<ToolInfo>(m, "ToolInfo", "What a tool declares: id, label, description, parameters.")
      .def_readonly("id", &ToolInfo::id)
      .def_readonly("label", &ToolInfo::label)
      .def_readonly("description", &ToolInfo::description)
      .def_readonly("parameters", &ToolInfo::parameters)
      .def("__repr__", [](const ToolInfo& i) { return "<kiji.ToolInfo '" + i.id + "'>"; });

  py::class_<ToolRegistry, std::shared_ptr<ToolRegistry>>(m, "ToolRegistry", "The tools known to a session: plugins.")
      .def(py::init<>())
      .def_static("default_search_path", &ToolRegistry::default_search_path)
      .def("load_plugins", [](ToolRegistry& r, const std::vector<std::string>& folders) {
        py::list out;
        for (const auto& rep : r.load_plugins(folders)) out.append(report_dict(rep));
        return out;
      }, py::arg("folders"), "Loads every plugin in the folders; one report dict per candidate.")
      .def("load_plugin", [](ToolRegistry& r, const std::string& path) { return report_dict(r.load_plugin(path)); },
           py::arg("path"), "Loads one plugin (its .json or library); a report dict saying whether and why not.")
      .def("ids", &ToolRegistry::ids, "The ids of every tool, sorted.")
      .def("has", &ToolRegistry::has, py::arg("id"), "Whether there is a tool of that id.")
      .def("info", &ToolRegistry::info, py::arg("id"), "A tool's declaration (ToolInfo); InputError naming the known ids.")
      .def("origin", &ToolRegistry::origin, py::arg("id"),
           "Where a tool came from: a plugin library's path, 'built in', or the Python class.");

  // --- events ---
  py::class_<ToolEvent>(m, "ToolEvent", "One pointer sample of a stroke, as a tool receives it.")
      .def(py::init([](const std::string& phase, py::handle position, std::optional<double> time,
                       std::uint32_t buttons, double pressure, py::handle ray, py::handle orientation) {
             ToolEvent e;
             e.phase = parse_phase(phase);
             e.position = to_vec3(position, "position");
             if (time && !std::isfinite(*time)) throw InputError("event time is not a finite number");
             e.time = time ? *time : kAtTheClock;
             e.buttons = buttons;
             if (!(pressure >= 0 && pressure <= 1)) throw InputError("pressure must be in [0, 1]");
             e.pressure = pressure;
             if (!ray.is_none()) e.ray = to_vec3(ray, "ray");
             if (!orientation.is_none()) {
               auto q = real_array(orientation, "orientation (w, x, y, z)", 4, 0);
               e.orientation = Eigen::Quaterniond(q.data()[0], q.data()[1], q.data()[2], q.data()[3]).normalized();
             }
             return e;
           }),
           py::arg("phase"), py::arg("position"), py::arg("time") = py::none(), py::arg("buttons") = 1,
           py::arg("pressure") = 1.0, py::arg("ray") = py::none(), py::arg("orientation") = py::none(),
           "time: seconds on the session's clock, not before it; None (the default): the clock's time when\n"
           "the session applies the event.")
      .def_property_readonly("phase", [](const ToolEvent& e) { return std::string(phase_name(e.phase)); })
      .def_property_readonly("time", [](const ToolEvent& e) -> py::object {
        if (std::isnan(e.time)) return py::none();
        return py::float_(e.time);
      }, "Seconds on the session's clock; None: when the session applies it.")
      .def_property_readonly("position", [](const ToolEvent& e) { return vec3_array(e.position); })
      .def_readonly("buttons", &ToolEvent::buttons)
      .def_readonly("pressure", &ToolEvent::pressure)
      .def_property_readonly("ray", [](const ToolEvent& e) { return vec3_array(e.ray); })
      .def_property_readonly("orientation", [](const ToolEvent& e) {
        const auto& q = e.orientation;
        return py::make_tuple(q.w(), q.x(), q.y(), q.z());
      })
      .def("__repr__", [](const ToolEvent& e) {
        return "ToolEvent('" + std::string(phase_name(e.phase)) +
               "', time=" + (std::isnan(e.time) ? std::string("None") : std::to_string(e.time)) + ")";
      });

  py::class_<SurfaceHit>(m, "SurfaceHit", "The cloth under a pointer.")
      .def_readonly("hit", &SurfaceHit::hit)
      .def_readonly("garment", &SurfaceHit::garment)
      .def_property_readonly("vertex_id", [](const SurfaceHit& h) { return h.hit ? long(h.nearest.idx()) : -1L; })
      .def_property_readonly("point", [](const SurfaceHit& h) { return vec3_array(h.point); })
      .def_property_readonly("normal", [](const SurfaceHit& h) { return vec3_array(h.normal); })
      .def_property_readonly("barycentric", [](const SurfaceHit& h) { return vec3_array(h.barycentric); })
      .def_property_readonly("uv", [](const SurfaceHit& h) { return py::make_tuple(h.uv.x(), h.uv.y()); })
      .def_readonly("distance", &SurfaceHit::distance)
      .def("__bool__", [](const SurfaceHit& h) { return h.hit; });

  py::class_<JournalStroke>(m, "JournalStroke", "One stroke of a journal: tool, parameters, events.")
      .def(py::init([](const std::string& tool, const py::dict& params, const std::vector<ToolEvent>& events) {
             for (const ToolEvent& e : events)
               if (std::isnan(e.time))
                 throw InputError("a journal stroke's events need their times: make them with kiji.ToolEvent(phase, "
                                  "position, time=seconds)");
             return JournalStroke{tool, param_map_from_python(params), events};
           }),
           py::arg("tool"), py::arg("params"), py::arg("events"))
      .def_readonly("tool", &JournalStroke::tool)
      .def_property_readonly("params", [](const JournalStroke& s) { return param_map_to_python(s.params); })
      .def_readonly("events", &JournalStroke::events)
      .def_property_readonly("positions", [](const JournalStroke& s) {
        py::array_t<double> a({static_cast<py::ssize_t>(s.events.size()), py::ssize_t(3)});
        for (std::size_t i = 0; i < s.events.size(); ++i)
          for (int k = 0; k < 3; ++k) a.mutable_at(i, k) = s.events[i].position[k];
        return a;
      })
      .def("__repr__", [](const JournalStroke& s) {
        return "<kiji.JournalStroke '" + s.tool + "', " + std::to_string(s.events.size()) + " events>";
      });
  m.def("load_journal", &load_journal, py::arg("path"),
        "Reads a journal file (format kiji-journal, version 1) as a list of JournalStroke.");
  m.def("save_journal", py::overload_cast<const std::vector<JournalStroke>&, const std::string&>(&save_journal),
        py::arg("strokes"), py::arg("path"), "Writes strokes as a journal file.");
  m.attr("JOURNAL_FILE_VERSION") = kJournalFileVersion;

  // --- the session ---
  // Every binding below holds the session's guard (SessionGuard): one thread at a time.
  py::class_<Session, SessionPtr> s(m, "Session");
  s.def(py::init([](std::shared_ptr<ToolRegistry> registry) { return std::make_shared<Session>(std::move(registry)); }),
        py::arg("registry") = nullptr);
  s.def(py::init([](const SessionPtr& existing) {
          if (!existing) throw py::type_error("Session: expected a kiji Session to wrap");
          return existing;
        }),
        py::arg("session"), "A second handle on an existing session (the same session, not a copy).");
  s.def("add_garment", [](const SessionPtr& self, std::shared_ptr<GarmentRef> g) {
    if (!g) throw py::type_error("add_garment: expected a kiji.Garment");
    SessionGuard lock(*self);
    std::size_t i;
    {
      auto other = g->guard();
      i = self->add_garment(g->get());
    }
    if (!g->in_session()) g->adopt(self, i);
    return std::make_shared<GarmentRef>(self, i);
  }, py::arg("garment"),
     "Adds a garment (validated) and returns it as a view of the session's garment. A garment that was\n"
     "in no session becomes that view itself, so it shows what the tools do to it.");
  s.def("remove_garment", [](Session& self, std::size_t i) {
    SessionGuard lock(self);
    self.remove_garment(i);
  }, py::arg("index"), "Removes a garment; the ones after it move down one index (views of them too).");
  s.def("garment", [](const SessionPtr& self, std::size_t i) {
    SessionGuard lock(*self);
    self->garment(i);
    return std::make_shared<GarmentRef>(self, i);
  }, py::arg("index") = 0, "The garment at an index, as a view.");
  s.def_property_readonly("garments", &garment_list);
  s.def_property_readonly("garment_count", [](const Session& self) {
    SessionGuard lock(self);
    return self.garment_count();
  });
  s.def_property("body",
                 [](const Session& self) -> std::shared_ptr<Body> {
                   SessionGuard lock(self);
                   return self.body() ? std::make_shared<Body>(*self.body()) : nullptr;
                 },
                 [](Session& self, std::shared_ptr<Body> b) {
                   SessionGuard lock(self);
                   if (b) self.set_body(*b);
                   else self.set_body(std::nullopt);
                 },
                 "The body the garments collide with (None for none). Setting it copies the body.");
  s.def_property("solver_params",
                 [](const Session& self) {
                   SessionGuard lock(self);
                   return self.solver_params();
                 },
                 [](Session& self, const SolverParams& p) {
                   SessionGuard lock(self);
                   self.set_solver_params(p);
                 },
                 "The solver's parameters (a copy; assign a SolverParams to change them).");
  s.def_property_readonly("time", [](const Session& self) {
    SessionGuard lock(self);
    return self.time();
  }, "The session's clock, seconds.");
  s.def_property_readonly("steps", [](const Session& self) {
    SessionGuard lock(self);
    return self.steps();
  }, "Simulation steps taken since the session began.");
  s.def_property("frame_rate",
                 [](const Session& self) {
                   SessionGuard lock(self);
                   return self.frame_rate();
                 },
                 [](Session& self, double r) {
                   SessionGuard lock(self);
                   self.set_frame_rate(r);
                 },
                 "Simulation steps a second.");
  s.def_property("simulating",
                 [](const Session& self) {
                   SessionGuard lock(self);
                   return self.simulating();
                 },
                 [](Session& self, bool on) {
                   SessionGuard lock(self);
                   self.set_simulating(on);
                 },
                 "Whether time steps the cloth (False: tools still edit, nothing falls). Journaled.");
  s.def_property("pick_radius",
                 [](const Session& self) {
                   SessionGuard lock(self);
                   return self.pick_radius();
                 },
                 [](Session& self, double r) {
                   SessionGuard lock(self);
                   self.set_pick_radius(r);
                 },
                 "How near the cloth a pointer must be to touch it, metres. Journaled.");
  s.def_property_readonly("stroke_active", [](const Session& self) {
    SessionGuard lock(self);
    return self.stroke_active();
  });
  s.def("step", [](Session& self, int n) {
    if (n < 0) throw InputError("step: n must be 0 or more");
    SessionGuard lock(self);
    py::gil_scoped_release nogil;
    for (int i = 0; i < n; ++i) self.step();
  }, py::arg("n") = 1, "n simulation steps of every garment.");
  s.def("simulate", [](Session& self, double seconds, const py::object& progress) {
    SessionGuard lock(self);
    simulate(self, seconds, progress);
  }, py::arg("seconds"), py::kw_only(), py::arg("progress") = py::none(),
        "Simulates `seconds` of time with the GIL released. progress(fraction) is called after every step\n"
        "and may return False to stop; Ctrl-C raises KeyboardInterrupt (the steps done are kept).");
  s.def("drape", [](Session& self, double seconds, bool place, double clearance, const py::object& progress,
                    bool coarse) {
    SessionGuard lock(self);
    const ProgressHook hook(progress);
    py::gil_scoped_release nogil;
    return self.drape(seconds, [&](double fraction) { return hook(fraction); }, place, clearance, coarse);
  }, py::arg("seconds") = 3.0, py::kw_only(), py::arg("place") = true, py::arg("clearance") = 0.02,
     py::arg("progress") = py::none(), py::arg("coarse") = true,
     "Lays every garment over the body (place=True) and lets it fall and settle for `seconds`, with the\n"
     "session's solver settings at the drape's substeps (as `kiji drape`: 40 a step, where interactive\n"
     "work uses 10). Returns a kiji.DrapeResult for each garment.\n"
     "Where every garment is one kiji.drape lets fall as a coarse copy first (flat, at rest, unpinned,\n"
     "2,000 vertices or more) and coarse=True, each is draped so and set back as one journaled change:\n"
     "the clock and the pause are left as they were. Otherwise the session steps for it (a paused\n"
     "session runs, then pauses again) and its clock moves by `seconds`. Each change is journaled.");
  s.def("measure", [](Session& self, std::size_t i) {
    SessionGuard lock(self);
    return self.solver(i).measure(self.garment(i));
  }, py::arg("garment") = 0, "Penetration, strain, energy and contacts of a garment.");
  s.def("last_step", [](Session& self, std::size_t i) {
    SessionGuard lock(self);
    return self.solver(i).last_step();
  }, py::arg("garment") = 0, "What the last step did for a garment: self-collision searches and pairs.");
  s.def("pick", [](const Session& self, py::handle position, py::handle ray) {
    const Vec3 p = to_vec3(position, "position");
    const Vec3 r = ray.is_none() ? Vec3::Zero() : to_vec3(ray, "ray");
    SessionGuard lock(self);
    return self.pick(p, r);
  }, py::arg("position"), py::arg("ray") = py::none(), "The cloth under a pointer (nearest within pick_radius, or along a ray).");

  // tools
  s.def("_tool_ids", [](const Session& self) {
    SessionGuard lock(self);
    return self.tools().ids();
  });
  s.def("tool_info", [](const Session& self, const std::string& id) {
    SessionGuard lock(self);
    return self.tools().info(id);
  }, py::arg("tool"));
  s.def("_run_stroke",
        [](Session& self, const std::string& tool, const py::dict& params, py::handle positions, py::handle phases,
           py::handle times, double dt, py::handle buttons, py::handle pressure, py::handle rays,
           py::handle orientations, const py::object& progress) {
          SessionGuard lock(self);
          if (!self.tools().has(tool)) self.tools().info(tool);  // throws naming the known tools
          const ParamSet ps = params_from_python(self, tool, params);
          const Stroke stroke = make_stroke(self, positions, phases, times, dt, buttons, pressure, rays, orientations);
          return run_stroke(self, tool, ps, stroke, progress);
        });
  s.def("_run_events", [](Session& self, const std::string& tool, const py::dict& params,
                          const std::vector<ToolEvent>& events, const py::object& progress) {
    if (events.empty() || events.front().phase != Phase::Begin)
      throw InputError("a stroke must start with a 'begin' event");
    SessionGuard lock(self);
    const ParamSet ps = params_from_python(self, tool, params);
    return run_stroke(self, tool, ps, events, progress);
  });

  // journal
  s.def("undo", [](Session& self) {
    SessionGuard lock(self);
    return self.undo();
  }, "Restores the garments as they were before the last change to them (a stroke, a garment added,\n"
     "removed or edited); False if none.");
  s.def("redo", [](Session& self) {
    SessionGuard lock(self);
    return self.redo();
  }, "Redoes the last undone change; False if none.");
  s.def_property_readonly("can_undo", [](const Session& self) {
    SessionGuard lock(self);
    return self.journal().can_undo();
  });
  s.def_property_readonly("can_redo", [](const Session& self) {
    SessionGuard lock(self);
    return self.journal().can_redo();
  });
  s.def_property("history_limit",
                 [](const Session& self) {
                   SessionGuard lock(self);
                   return self.journal().history_limit();
                 },
                 [](Session& self, std::size_t bytes) {
                   SessionGuard lock(self);
                   self.set_history_limit(bytes);
                 },
                 "Bytes the undo history may hold (at least 1 MB); the oldest steps are dropped first.");
  s.def_property_readonly("history_bytes", [](const Session& self) {
    SessionGuard lock(self);
    return self.journal().history_bytes();
  }, "Bytes of garments and textures the undo history holds now.");
  s.def_property_readonly("journal", [](const Session& self) {
    SessionGuard lock(self);
    return journal_strokes(self.journal());
  }, "The strokes done so far (undone ones left out), as JournalStroke objects.");
  s.def_property_readonly("operation_count", [](const Session& self) {
    SessionGuard lock(self);
    return self.journal().operations().size();
  }, "How many operations the session has applied (its log: tool events, edits, settings, undo).");
  s.def_property_readonly("operation_kinds", [](const Session& self) {
    SessionGuard lock(self);
    std::vector<std::string> kinds;
    for (const Operation& op : self.journal().operations()) kinds.push_back(operation_kind(op.data));
    return kinds;
  }, "The kind of each operation of the log, in order ('tool', 'add_garment', 'set_simulating', ...).");
  s.def("save_journal", [](const Session& self, py::handle path) {
    SessionGuard lock(self);
    save_journal(self, path_arg(path));
  }, py::arg("path"),
        "Writes every operation of the session as a JSON journal (version 2), which replay() on a new\n"
        "session turns into the same garments.");
  s.def("save", [](const Session& self, py::handle path) {
    SessionGuard lock(self);
    save_session(self, path_arg(path));
  }, py::arg("path"), "Writes the session file (an LCM log of its operations; see kiji.recover, kiji.load).");
  s.def("replay", [](Session& self, py::object journal, const py::object& progress) {
    const ProgressHook hook(progress);
    auto report = [&](std::size_t done, std::size_t total) { return hook(double(done) / double(total)); };
    SessionGuard lock(self);
    if (py::isinstance<py::str>(journal) || py::hasattr(journal, "__fspath__")) {
      const std::string path = path_arg(journal);
      py::gil_scoped_release nogil;
      return replay_file(self, path, report);
    }
    const auto list = journal.cast<std::vector<JournalStroke>>();
    py::gil_scoped_release nogil;
    return replay(self, list, report);
  }, py::arg("journal"), py::kw_only(), py::arg("progress") = py::none(),
     "Replays a journal (a path to a journal file, or a list of JournalStroke) on this session, with\n"
     "the GIL released. A version 2 file holds every operation (garments, body, settings): replay it on\n"
     "a new session. Strokes (version 1, a list) need a session set up the same way. Returns the\n"
     "operations or strokes done.");
  s.def("_start_autosave", [](const SessionPtr& self, const std::string& path) {
    SessionGuard lock(*self);
    return std::make_shared<PyAutosave>(self, path, false);
  }, py::arg("path"));

  py::class_<PyAutosave, std::shared_ptr<PyAutosave>>(m, "Autosave",
      "Appends every operation of a session to a session file as it is applied (see Session(autosave=)).")
      .def_property_readonly("path", [](const PyAutosave& a) { return a.autosave->path(); })
      .def_property_readonly("written", [](const PyAutosave& a) { return a.autosave->written(); });
  m.def("_recover", [](const std::string& path, std::shared_ptr<ToolRegistry> registry, bool keep_saving) {
    Recovered r;
    {
      py::gil_scoped_release nogil;
      r = recover(path, std::move(registry), keep_saving);
    }
    SessionPtr session(r.session.release());
    std::shared_ptr<PyAutosave> autosave;
    if (r.autosave) autosave = std::make_shared<PyAutosave>(session, std::move(r.autosave));
    py::dict report;
    report["operations"] = r.report.operations;
    report["damage"] = r.report.damage;
    report["cancelled_strokes"] = r.cancelled_strokes;
    return py::make_tuple(session, autosave, report);
  }, py::arg("path"), py::arg("registry"), py::arg("keep_saving") = true);
  m.def("_load_session", [](const std::string& path, std::shared_ptr<ToolRegistry> registry) {
    auto session = std::make_shared<Session>(std::move(registry));
    {
      py::gil_scoped_release nogil;
      // From the state the file carries, if it has one: its steps are not replayed.
      SavedState state;
      const std::vector<Operation> ops = load_session(path, nullptr, &state);
      open_operations(*session, ops, state);
    }
    return session;
  }, py::arg("path"), py::arg("registry"));

  s.def("render", [](const SessionPtr& self, std::optional<Camera> camera, int width, int height) {
    SessionGuard lock(*self);
    py::object render = py::module_::import("kiji._kiji").attr("render");
    return render(garment_list(self), self->body() ? py::cast(std::make_shared<Body>(*self->body())) : py::none(),
                  py::arg("camera") = camera ? py::cast(*camera) : py::none(), py::arg("width") = width,
                  py::arg("height") = height);
  }, py::kw_only(), py::arg("camera") = py::none(), py::arg("width") = 1024, py::arg("height") = 768,
     "A picture of the scene (body and garments) without a window: (H, W, 4) uint8.");
}

}  // namespace kiji::python
