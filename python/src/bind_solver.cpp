// The solver from Python: a solver of one's own on a garment of one's own (the whole API), a
// session's solver to read, and the C++ drape on a garment.
#include "bindings.h"

#include "kiji/drape.h"
#include "kiji/solver.h"

#include <cmath>

namespace kiji::python {

namespace {

// A solver as Python sees it. Its own: it steps a garment of its own (not in a session), with the
// whole API. A session's garment's: read-only from a script (its attachments and forces belong to
// the tools, whose strokes are the journal's operations; a script's hand on the cloth would change
// the session outside its journal), and for a tool written in Python during its calls what its
// ToolContext allows, as a C++ tool has it: hands on the cloth, forces and the local region.

// Whether two sets of parameters are the same but for the local region (local_radius, local_center).
bool same_but_local_region(const SolverParams& a, const SolverParams& b) {
  return a.model == b.model && a.gravity == b.gravity && a.substeps == b.substeps &&
         a.held_substeps == b.held_substeps && a.iterations == b.iterations && a.floor == b.floor &&
         a.body_collision == b.body_collision && a.self_collision == b.self_collision &&
         a.strain_limit == b.strain_limit && a.spring_k == b.spring_k && a.spring_damping == b.spring_damping &&
         a.sleep_after == b.sleep_after && a.sleep_distance == b.sleep_distance;
}

class SolverRef {
 public:
  SolverRef(std::shared_ptr<GarmentRef> garment, const SolverParams& params)
      : own_(std::make_shared<Solver>(params)), garment_(std::move(garment)) {}
  SolverRef(std::shared_ptr<Session> session, std::size_t index) : session_(std::move(session)), index_(index) {}
  SolverRef(std::shared_ptr<ToolScope> scope, std::size_t index) : scope_(std::move(scope)), index_(index) {}

  bool own() const { return own_ != nullptr; }
  bool writable() const { return own_ || scope_; }

  // The solver, for reading; hold guard() while using a session's.
  const Solver& read() {
    if (own_) return *own_;
    if (scope_) return scope_->get("a solver").solver(index_);
    return session_->solver(index_);
  }
  // The solver of one's own, for a change; nullptr for a tool's, whose changes go through its
  // context(); refused on a session's solver outside a tool's calls.
  Solver* write(const char* what) {
    if (own_) return own_.get();
    if (scope_) return nullptr;
    throw Error(std::string("Solver.") + what + ": this is the solver of a session's garment, which a script can "
                "only read: its attachments and forces belong to the tools, whose strokes the journal records "
                "(a change here would not be undone, replayed or seen by peers). Use a tool (session.pinch, "
                "or your own with kiji.register_tool), or kiji.Solver(garment) on a garment of your own");
  }
  // What a tool written in Python changes the solver through during its calls, as a C++ tool does.
  ToolContext& context() const { return scope_->get("a solver"); }
  std::size_t index() const { return index_; }
  // New parameters: all of them on one's own solver; on a tool's, the local region only (the rest are
  // the session's, the same for every stroke).
  void set_params(const SolverParams& p) {
    if (Solver* solver = write("params")) return solver->set_params(p);
    ToolContext& c = context();
    if (!same_but_local_region(p, c.solver(index_).params()))
      throw InputError("Solver.params: a tool may change only the local region (local_radius, local_center) of a "
                       "session's solver during its stroke; its other parameters are the session's "
                       "(session.solver_params, set between strokes)");
    const SolverParams& session = c.solver_params();
    if (p.local_radius == session.local_radius && p.local_center == session.local_center) c.end_local_region(index_);
    else c.set_local_region(index_, p.local_center, p.local_radius);
  }
  std::optional<SessionGuard> guard() const {
    if (!session_) return std::nullopt;
    return std::optional<SessionGuard>(std::in_place, *session_);
  }
  // The garment it steps.
  const Garment& garment() {
    if (own_) {
      check_own_garment();
      return garment_->get();
    }
    if (scope_) return scope_->get("a solver").garment(index_);
    return session_->garment(index_);
  }
  std::shared_ptr<GarmentRef> garment_ref() {
    if (own_) return garment_;
    if (scope_) return std::make_shared<GarmentRef>(scope_, index_);
    return std::make_shared<GarmentRef>(session_, index_);
  }
  void check_own_garment() const {
    if (garment_->in_session())
      throw Error("the garment of this kiji.Solver was added to a session, which steps it now: use the session "
                  "(session.step, session.simulate), or a copy (garment.copy()) for a solver of your own");
  }
  void set_body(std::shared_ptr<Body> body) {
    if (!own_) {
      write("body");
      throw Error("Solver.body: a session's solvers collide with the session's body");
    }
    body_ = std::move(body);
    own_->set_body(body_.get());
  }
  std::shared_ptr<Body> body() {
    if (own_) return body_;
    const Body* b = scope_ ? context().body() : session_->body();
    return b ? std::make_shared<Body>(*b) : nullptr;
  }
  void step(double dt, int n, const py::object& progress) {
    if (!own_)
      throw Error("Solver.step: a session steps its own garments on its clock (session.step, session.simulate, "
                  "or events with later times); kiji.Solver(garment) steps a garment of your own");
    check_own_garment();
    if (n < 0) throw InputError("Solver.step: n must be 0 or more");
    const ProgressHook hook(progress);
    garment_->edit([&](Garment& g) {
      py::gil_scoped_release nogil;
      for (int i = 0; i < n; ++i) {
        own_->step(g, dt);
        if (!hook(double(i + 1) / double(n))) break;
      }
    });
  }

 private:
  std::shared_ptr<Solver> own_;
  std::shared_ptr<GarmentRef> garment_;
  std::shared_ptr<Body> body_;
  std::shared_ptr<Session> session_;
  std::shared_ptr<ToolScope> scope_;
  std::size_t index_ = 0;
};

// Rows of the per-vertex arrays as the garment's vertices, checked.
std::vector<Vertex> vertex_rows(const Garment& g, py::handle rows, const char* what) {
  const VertexRows vr(g);
  py::array a = py::module_::import("numpy").attr("asarray")(rows);
  if (a.dtype().kind() != 'i' && a.dtype().kind() != 'u')
    throw py::type_error(std::string(what) + " must be vertex rows (int or an array of ints)");
  if (a.ndim() > 1) throw InputError(std::string(what) + " must be one vertex row or a 1-D array of rows");
  auto r = py::array_t<long long, py::array::c_style | py::array::forcecast>::ensure(a.attr("reshape")(-1));
  std::vector<Vertex> out;
  for (py::ssize_t i = 0; i < r.size(); ++i) {
    const long long x = r.data()[i];
    if (x < 0 || x >= static_cast<long long>(vr.vertices.size()))
      throw InputError(std::string(what) + ": vertex row " + std::to_string(x) + " does not exist (the garment has " +
                       std::to_string(vr.vertices.size()) + " vertices)");
    out.push_back(vr.vertices[x]);
  }
  return out;
}

py::array_t<double> rows_of_vectors(const Garment& g, const std::vector<Vec3>& by_index) {
  const VertexRows rows(g);
  py::array_t<double> a({static_cast<py::ssize_t>(rows.vertices.size()), py::ssize_t(3)});
  for (std::size_t i = 0; i < rows.vertices.size(); ++i)
    for (int k = 0; k < 3; ++k) a.mutable_at(i, k) = by_index[rows.vertices[i].idx()][k];
  return a;
}

}  // namespace

py::object tool_solver(std::shared_ptr<ToolScope> scope, std::size_t index) {
  return py::cast(std::make_shared<SolverRef>(std::move(scope), index));
}

void bind_solver(py::module_& m) {
  py::class_<SolverRef, std::shared_ptr<SolverRef>> c(m, "Solver",
      "The cloth solver of one garment (the paper's mass-spring model or XPBD; see SolverParams).\n"
      "kiji.Solver(garment) steps a garment of your own (not in a session) with the whole API: forces,\n"
      "attachments (a hand on the cloth), step, spring_forces, measure. session.solver(i) is the solver of\n"
      "a session's garment: a script reads it (params, last_step, measure, spring_forces); its attachments\n"
      "and forces belong to the tools, so that every change to a session is an operation of its journal.\n"
      "A tool written in Python gets hands on the session's solvers during its calls: attachments, forces\n"
      "and the local region (params with another local_radius and local_center), as a C++ tool has them.");
  c.def(py::init([](std::shared_ptr<GarmentRef> g, std::optional<SolverParams> params, std::shared_ptr<Body> body) {
          if (!g) throw py::type_error("Solver: expected a kiji.Garment");
          if (g->in_session())
            throw Error("Solver: this garment is in a session, which steps it with its own solver: use "
                        "session.solver(i) to read that one, or kiji.Solver(garment.copy()) for one of your own");
          auto s = std::make_shared<SolverRef>(g, params ? *params : SolverParams{});
          if (body) s->set_body(std::move(body));
          return s;
        }),
        py::arg("garment"), py::arg("params") = py::none(), py::kw_only(), py::arg("body") = nullptr,
        "A solver of your own for a garment of your own, with parameters (default SolverParams()) and a body\n"
        "to collide with (None for none).");
  c.def_property(
      "params",
      [](SolverRef& s) {
        auto lock = s.guard();
        return s.read().params();
      },
      [](SolverRef& s, const SolverParams& p) { s.set_params(p); },
      "The solver's parameters (a copy; assign to change them: a solver of your own; a tool's local region).");
  c.def_property(
      "body", [](SolverRef& s) {
        auto lock = s.guard();
        return s.body();
      },
      [](SolverRef& s, std::shared_ptr<Body> b) { s.set_body(std::move(b)); },
      "The body the garment collides with (None for none). A session's solvers use the session's body.");
  c.def_property_readonly("garment", [](SolverRef& s) { return s.garment_ref(); }, "The garment this solver steps.");
  c.def_property_readonly("owned", &SolverRef::own, "Whether this is a solver of your own (kiji.Solver(garment)).");
  c.def_property_readonly("writable", &SolverRef::writable,
                          "Whether forces and attachments can be changed here (your own solver, or a tool's during "
                          "its calls).");
  c.def("add_external_force", [](SolverRef& s, py::handle vertices, py::handle forces) {
    Solver* solver = s.write("add_external_force");
    const auto vs = vertex_rows(s.garment(), vertices, "add_external_force");
    auto f = py::module_::import("numpy").attr("asarray")(forces);
    auto a = real_array(f.attr("reshape")(-1, 3), "forces", static_cast<long>(vs.size()), 3);
    for (std::size_t i = 0; i < vs.size(); ++i) {
      const Vec3 force(a.at(i, 0), a.at(i, 1), a.at(i, 2));
      if (solver) solver->add_external_force(vs[i], force);
      else s.context().add_force(s.index(), vs[i], force);
    }
  }, py::arg("vertices"), py::arg("forces"),
     "Forces in newtons on vertices (a row and a (3,) force, or (K,) rows and (K, 3) forces) for the\n"
     "next step only (the paper's f_i of eq. 2).");
  c.def("add_attachment", [](SolverRef& s, long vertex, py::handle target, double stiffness, bool firm) {
    Solver* solver = s.write("add_attachment");
    const auto v = vertex_rows(s.garment(), py::int_(vertex), "add_attachment");
    const Vec3 at = to_vec3(target, "target");
    return solver ? solver->add_attachment(v[0], at, stiffness, firm) : s.context().attach(s.index(), v[0], at, stiffness, firm);
  }, py::arg("vertex"), py::arg("target"), py::arg("stiffness"), py::arg("firm") = false,
     "A hand on the cloth: a zero-length spring of `stiffness` N/m from the point `target` to a vertex\n"
     "(a row), kept until removed; returns its id. A firm one wins over the cloth's strain limit (it can\n"
     "stretch the cloth until it tears). Dropped when an edit removes its vertex.");
  c.def("move_attachment", [](SolverRef& s, int id, py::handle target) {
    Solver* solver = s.write("move_attachment");
    const Vec3 at = to_vec3(target, "target");
    if (solver) solver->move_attachment(id, at);
    else s.context().move(s.index(), id, at);
  }, py::arg("id"), py::arg("target"), "Moves an attachment's point (an id no longer held is ignored).");
  c.def("remove_attachment", [](SolverRef& s, int id) {
    if (Solver* solver = s.write("remove_attachment")) solver->remove_attachment(id);
    else s.context().release(s.index(), id);
  },
        py::arg("id"), "Removes an attachment (an id no longer held is ignored).");
  c.def_property_readonly("attachment_count", [](SolverRef& s) {
    auto lock = s.guard();
    return s.read().attachment_count();
  }, "Attachments held (hands on the cloth).");
  c.def("prepare", [](SolverRef& s) {
    auto lock = s.guard();
    Solver& solver = s.own() ? *s.write("prepare") : const_cast<Solver&>(s.read());
    const Garment& g = s.garment();
    py::gil_scoped_release nogil;
    solver.prepare(g);
  }, "Builds the solver's arrays for the garment now (what the first step after an edit would do).");
  c.def("step", [](SolverRef& s, std::optional<double> dt, int n, const py::object& progress) {
    s.step(dt ? *dt : 1.0 / 60.0, n, progress);
  }, py::arg("dt") = py::none(), py::arg("n") = 1, py::kw_only(), py::arg("progress") = py::none(),
     "Advances your own garment n steps of dt seconds (default 1/60), with the GIL released;\n"
     "progress(fraction) after each step may return False to stop.");
  c.def("spring_forces", [](SolverRef& s) {
    auto lock = s.guard();
    const Garment& g = s.garment();
    return rows_of_vectors(g, s.read().spring_forces(g));
  }, "(V, 3): the total spring force on every vertex by the paper's eq. 3, g_ij = k (1 - l_ij / l'_ij) d_ij,\n"
     "with k = params.spring_k (rows of the garment's arrays).");
  c.def("measure", [](SolverRef& s) {
    auto lock = s.guard();
    return s.read().measure(s.garment());
  }, "Penetration, strain, energy, contacts and sleeping vertices of the garment now.");
  c.def("last_step", [](SolverRef& s) {
    auto lock = s.guard();
    return s.read().last_step();
  }, "What the last step did (zeros before the first).");
  c.def("__repr__", [](SolverRef& s) {
    auto lock = s.guard();
    return "<kiji.Solver " + solver_model_name(s.read().params().model) +
           (s.own() ? ", of its own" : ", of a session's garment") + ">";
  });

  auto session = py::reinterpret_borrow<py::class_<Session, std::shared_ptr<Session>>>(m.attr("Session"));
  session.def("solver", [](const std::shared_ptr<Session>& self, std::size_t i) {
    SessionGuard lock(*self);
    check_garment_index(*self, i);
    return std::make_shared<SolverRef>(self, i);
  }, py::arg("garment") = 0,
     "The solver of a garment, to read (params, last_step, measure, spring_forces): its attachments and\n"
     "forces belong to the tools (see kiji.Solver).");

  py::class_<DrapeResult>(m, "DrapeResult", "What kiji.drape() did: time simulated, wall time, steps, measures at the end.")
      .def_readonly("seconds_simulated", &DrapeResult::seconds_simulated)
      .def_readonly("wall_seconds", &DrapeResult::wall_seconds)
      .def_readonly("steps", &DrapeResult::steps)
      .def_readonly("measures", &DrapeResult::measures)
      .def_readonly("coarse_vertices", &DrapeResult::coarse_vertices)
      .def_readonly("coarse_steps", &DrapeResult::coarse_steps)
      .def_readonly("coarse_wall_seconds", &DrapeResult::coarse_wall_seconds)
      .def("__repr__", [](const DrapeResult& r) {
        return "DrapeResult(seconds_simulated=" + std::to_string(r.seconds_simulated) + ", steps=" +
               std::to_string(r.steps) + ", coarse_vertices=" + std::to_string(r.coarse_vertices) +
               ", coarse_steps=" + std::to_string(r.coarse_steps) + ", wall_seconds=" + std::to_string(r.wall_seconds) +
               ")";
      });
  m.def("drapes_coarse",
        [](std::shared_ptr<GarmentRef> g, double seconds, double frame_rate, double coarse_ratio, double fine_seconds) {
          if (!g) throw py::type_error("drapes_coarse: expected a kiji.Garment");
          DrapeOptions o;
          o.seconds = seconds;
          o.frame_rate = frame_rate;
          o.coarse_ratio = coarse_ratio;
          o.fine_seconds = fine_seconds;
          const auto guard = g->guard();
          return drapes_coarse(g->get(), o);
        },
        py::arg("garment"), py::kw_only(), py::arg("seconds") = 3.0, py::arg("frame_rate") = 60.0,
        py::arg("coarse_ratio") = DrapeOptions{}.coarse_ratio, py::arg("fine_seconds") = DrapeOptions{}.fine_seconds,
        "Whether kiji.drape (and Session.drape) lets this garment fall as a coarse copy first with these\n"
        "options: a flat garment at rest, unpinned, of 2,000 vertices or more, draped longer than fine_seconds.");
  m.def("drape",
        [](std::shared_ptr<GarmentRef> g, std::shared_ptr<Body> body, double seconds, double frame_rate,
           std::optional<SolverParams> solver, double coarse_ratio, int coarse_substeps, double fine_seconds,
           double fine_damping, const py::object& progress) {
          if (!g) throw py::type_error("drape: expected a kiji.Garment");
          if (!body) throw py::type_error("drape: expected a kiji.Body");
          DrapeOptions o;
          o.seconds = seconds;
          o.frame_rate = frame_rate;
          if (solver) o.solver = *solver;
          o.coarse_ratio = coarse_ratio;
          o.coarse_substeps = coarse_substeps;
          o.fine_seconds = fine_seconds;
          o.fine_damping = fine_damping;
          o.validate();
          const ProgressHook hook(progress);
          DrapeResult result;
          g->edit([&](Garment& garment) {
            py::gil_scoped_release nogil;
            result = drape(garment, *body, o, [&](double f) { return hook(f); });
          });
          return result;
        },
        py::arg("garment"), py::arg("body"), py::kw_only(), py::arg("seconds") = 3.0, py::arg("frame_rate") = 60.0,
        py::arg("solver") = py::none(), py::arg("coarse_ratio") = DrapeOptions{}.coarse_ratio,
        py::arg("coarse_substeps") = DrapeOptions{}.coarse_substeps, py::arg("fine_seconds") = DrapeOptions{}.fine_seconds,
        py::arg("fine_damping") = DrapeOptions{}.fine_damping, py::arg("progress") = py::none(),
        "The C++ drape: simulates the garment on the body for `seconds` (the drape's solver by default: 40\n"
        "substeps a step) with the GIL released. Place it first with kiji.place_over_body. A flat garment of\n"
        "2,000 vertices or more falls first as a copy remeshed with edges coarse_ratio times as long (at\n"
        "coarse_substeps), then settles itself for the last fine_seconds with its damping raised to\n"
        "fine_damping; coarse_ratio=1 drapes the garment itself throughout. On a garment of a session the\n"
        "draped garment is one set_garment operation. progress(fraction) may return False.");
}

}  // namespace kiji::python
