// Materials, solver parameters and measures, bodies, the camera and pictures.
#include "bindings.h"

#include "kiji/body.h"
#include "kiji/material.h"
#include "kiji/render.h"
#include "kiji/solver.h"

namespace kiji::python {

namespace {

py::array_t<std::uint8_t> image_array(const Image& image) {
  py::array_t<std::uint8_t> a({image.height, image.width, 4});
  std::copy(image.rgba.begin(), image.rgba.end(), a.mutable_data());
  return a;
}

Image array_image(py::handle obj) {
  py::array a = py::module_::import("numpy").attr("asarray")(obj);
  if (a.dtype().kind() != 'u' || a.dtype().itemsize() != 1)
    throw py::type_error("an image must be a uint8 array of shape (height, width, 4)");
  if (a.ndim() != 3 || a.shape(2) != 4 || a.shape(0) < 1 || a.shape(1) < 1)
    throw InputError("an image must have shape (height, width, 4)");
  auto c = py::array_t<std::uint8_t, py::array::c_style | py::array::forcecast>::ensure(a);
  Image image;
  image.height = static_cast<int>(c.shape(0));
  image.width = static_cast<int>(c.shape(1));
  image.rgba.assign(c.data(), c.data() + c.size());
  return image;
}

py::array_t<double> box_array(const Box3& b) {
  py::array_t<double> a({2, 3});
  auto r = a.mutable_unchecked<2>();
  for (int i = 0; i < 3; ++i) r(0, i) = b.min()[i], r(1, i) = b.max()[i];
  return a;
}

}  // namespace

void bind_scene(py::module_& m) {
  // --- Material ---
  py::class_<Material>(m, "Material", "A fabric's physical properties, in SI units.")
      .def(py::init([](const std::string& preset, py::kwargs kw) {
             Material mat = Material::preset(preset);
             py::object self = py::cast(mat);
             for (auto item : kw) {
               const std::string name = py::str(item.first).cast<std::string>();
               if (name == "name" || !py::hasattr(self, name.c_str()))
                 throw py::type_error("Material() got an unexpected keyword argument '" + name + "'");
               self.attr(name.c_str()) = item.second;
             }
             Material out = self.cast<Material>();
             out.validate();
             return out;
           }),
           py::arg("preset") = "cotton",
           "A preset (cotton, silk, denim, rubber, tissue) with any field overridden by keyword, e.g.\n"
           "Material('silk', thickness=0.003). Raises InputError naming a field out of range.")
      .def_readwrite("name", &Material::name)
      .def_readwrite("density", &Material::density, "areal density, kg/m^2")
      .def_readwrite("stretch_stiffness", &Material::stretch_stiffness, "membrane stiffness, N/m")
      .def_readwrite("bending_stiffness", &Material::bending_stiffness, "bending rigidity, N m")
      .def_readwrite("damping", &Material::damping, "velocity damping, 1/s")
      .def_readwrite("friction", &Material::friction, "Coulomb friction against the body")
      .def_readwrite("thickness", &Material::thickness, "collision thickness, m")
      .def_readwrite("tear_ratio", &Material::tear_ratio, "an edge tears past this times its rest length")
      .def("validate", &Material::validate, "Raises InputError naming the first field out of range.")
      .def_static("preset", &Material::preset, py::arg("name"), "A preset by name.")
      .def_static("preset_names", &Material::preset_names)
      .def("__repr__", [](const Material& mat) {
        return "Material('" + mat.name + "', density=" + std::to_string(mat.density) +
               ", thickness=" + std::to_string(mat.thickness) + ")";
      });

  // --- Solver ---
  py::class_<SolverParams>(m, "SolverParams",
                           "The solver's parameters. Set them on a session with session.solver_params = p.")
      .def(py::init([](py::kwargs kw) {
             SolverParams p;
             py::object self = py::cast(p);
             for (auto item : kw) {
               const std::string name = py::str(item.first).cast<std::string>();
               if (!py::hasattr(self, name.c_str()))
                 throw py::type_error("SolverParams() got an unexpected keyword argument '" + name + "'");
               self.attr(name.c_str()) = item.second;
             }
             SolverParams out = self.cast<SolverParams>();
             out.validate();
             return out;
           }),
           "SolverParams(model='xpbd', substeps=10, ...): any field by keyword.")
      .def_property(
          "model", [](const SolverParams& p) { return solver_model_name(p.model); },
          [](SolverParams& p, const std::string& name) { p.model = parse_solver_model(name); },
          "'xpbd' (default) or 'mass_spring' (the 2006 paper's model)")
      .def_property(
          "gravity", [](const SolverParams& p) { return vec3_array(p.gravity); },
          [](SolverParams& p, py::handle v) { p.gravity = to_vec3(v, "gravity"); }, "m/s^2")
      .def_readwrite("substeps", &SolverParams::substeps)
      .def_readwrite("held_substeps", &SolverParams::held_substeps,
                     "Xpbd: substeps a step while a plain hand (a pinch) holds the garment, where more than "
                     "substeps: the hand's pull reaches further into the cloth (0: substeps)")
      .def_readwrite("iterations", &SolverParams::iterations)
      .def_readwrite("body_collision", &SolverParams::body_collision)
      .def_readwrite("self_collision", &SolverParams::self_collision)
      .def_readwrite("strain_limit", &SolverParams::strain_limit,
                     "Xpbd: edges stretched or compressed by more than this fraction of their rest length are "
                     "brought back to it after each substep (Provot's strain limiting); 0 turns it off")
      .def_readwrite("spring_k", &SolverParams::spring_k, "MassSpring: the spring constant k of the paper's eq. 3, N/m")
      .def_readwrite("spring_damping", &SolverParams::spring_damping,
                     "MassSpring: the damping gamma of the paper's eq. 1, 1/s (the paper uses 0)")
      .def_readwrite("local_radius", &SolverParams::local_radius,
                     "the paper's local region: only vertices within this many metres of local_center are "
                     "computed (0: all)")
      .def_readwrite("sleep_after", &SolverParams::sleep_after,
                     "seconds a patch of cloth stays within sleep_distance before it sleeps (0: never)")
      .def_readwrite("sleep_distance", &SolverParams::sleep_distance, "m")
      .def_readwrite("floor", &SolverParams::floor,
                     "with a body, the cloth rests on the ground through the body's lowest point (its feet)")
      .def_property(
          "local_center", [](const SolverParams& p) { return vec3_array(p.local_center); },
          [](SolverParams& p, py::handle v) { p.local_center = to_vec3(v, "local_center"); })
      .def("validate", &SolverParams::validate, "Raises InputError naming the first parameter out of range.")
      .def("__repr__", [](const SolverParams& p) {
        return "SolverParams(model='" + solver_model_name(p.model) + "', substeps=" + std::to_string(p.substeps) +
               ", held_substeps=" + std::to_string(p.held_substeps) + ", iterations=" + std::to_string(p.iterations) +
               ")";
      });

  py::class_<ClothMeasures>(m, "ClothMeasures", "Is the cloth at rest, on the body, not inside it, not torn?")
      .def_readonly("max_penetration", &ClothMeasures::max_penetration, "deepest vertex inside the body, m")
      .def_readonly("max_strain", &ClothMeasures::max_strain)
      .def_readonly("mean_strain", &ClothMeasures::mean_strain)
      .def_readonly("kinetic_energy", &ClothMeasures::kinetic_energy, "J")
      .def_readonly("contacts", &ClothMeasures::contacts, "vertices within 1.5 thicknesses of the body")
      .def_readonly("vertices", &ClothMeasures::vertices)
      .def_readonly("sleeping", &ClothMeasures::sleeping, "vertices at rest and not computed (see SolverParams.sleep_after)")
      .def("__repr__", [](const ClothMeasures& c) {
        return "ClothMeasures(max_penetration=" + std::to_string(c.max_penetration) +
               ", max_strain=" + std::to_string(c.max_strain) + ", contacts=" + std::to_string(c.contacts) + ")";
      });

  py::class_<StepReport>(m, "StepReport",
                         "What the last step did: self-collision searches and pairs, and the strain limit's work.")
      .def_readonly("substeps", &StepReport::substeps,
                    "substeps the step took (SolverParams.held_substeps while a plain hand held the garment)")
      .def_readonly("self_gathers", &StepReport::self_gathers, "searches for self-collision pairs in the step")
      .def_readonly("self_pairs", &StepReport::self_pairs, "vertex-triangle pairs found, summed over the searches")
      .def_readonly("self_overloaded", &StepReport::self_overloaded,
                    "a search met more pairs than its budget (about 256 a vertex): the garment is in a knot, "
                    "and some pairs were left out; undo, or let go of what pulls it through itself")
      .def_readonly("strain_limited", &StepReport::strain_limited,
                    "edges found beyond the strain limit, summed over the substeps: a large share of the edges "
                    "every substep means the cloth is held by the limit, not by its own stiffness (more substeps "
                    "or iterations, or a stiffer cloth)")
      .def_property_readonly(
          "ms",
          [](const StepReport& r) {
            return py::dict(py::arg("total") = r.ms.total, py::arg("solve") = r.ms.solve,
                            py::arg("strain_limit") = r.ms.strain_limit, py::arg("self_search") = r.ms.self_search,
                            py::arg("self_resolve") = r.ms.self_resolve, py::arg("body") = r.ms.body,
                            py::arg("rebuild") = r.ms.rebuild, py::arg("shared") = r.ms.shared);
          },
          "where the step's time went, in milliseconds of wall clock: total, by phase (solve, strain_limit, "
          "self_search, self_resolve, body), rebuild (the solver's arrays built again after a topology edit, "
          "in the first step after it), and shared (in loops shared between threads; total - shared is what "
          "more cores cannot shorten)")
      .def("__repr__", [](const StepReport& r) {
        return "StepReport(substeps=" + std::to_string(r.substeps) + ", self_gathers=" + std::to_string(r.self_gathers) + ", self_pairs=" +
               std::to_string(r.self_pairs) + ", self_overloaded=" + (r.self_overloaded ? "True" : "False") +
               ", strain_limited=" + std::to_string(r.strain_limited) + ")";
      });

  // --- Body ---
  py::class_<Body, std::shared_ptr<Body>>(m, "Body", "A body (avatar) to drape on: metres, +Y up.")
      .def_static(
          "load",
          [](const std::string& path, std::optional<std::string> up, std::optional<std::string> front,
             std::optional<double> scale, std::optional<double> height, bool smooth, bool recenter,
             std::size_t memory_limit_mb, double timeout) {
            BodyImportOptions o;
            o.limits.memory_mb = memory_limit_mb;
            o.limits.seconds = timeout;
            if (up) o.up = parse_axis(*up);
            // "auto": from the file, else the feet; None: as the file has it.
            if (front && *front == "auto") o.find_front = true;
            else if (front) o.front = parse_axis(*front);
            o.scale = scale;
            o.height = height;
            o.smooth = smooth;
            o.recenter = recenter;
            py::gil_scoped_release nogil;
            return std::make_shared<Body>(Body::load(path, o));
          },
          py::arg("path"), py::kw_only(), py::arg("up") = py::none(), py::arg("front") = "auto",
          py::arg("scale") = py::none(), py::arg("height") = py::none(), py::arg("smooth") = true,
          py::arg("recenter") = true, py::arg("memory_limit_mb") = ImportLimits{}.memory_mb,
          py::arg("timeout") = ImportLimits{}.seconds,
          "Imports a body with assimp (OBJ, Collada/zae, FBX, glTF, ...): all meshes merged and welded,\n"
          "brought to metres and +Y up, and turned to face +Z. up ('x', '-z', ...), front (the file's axis\n"
          "the body faces; 'auto': what the file says, else the way its feet point; None: as the file has\n"
          "it) and scale (metres per file unit) correct a file whose metadata is missing or wrong; height\n"
          "scales it to that many metres; smooth rounds a low-poly body (Loop subdivision to 1 cm triangles)\n"
          "so that its points do not spike the cloth. body.report says where each came from. assimp reads\n"
          "the file in a child process: a file that crashes it, or needs more than memory_limit_mb MiB or\n"
          "timeout seconds, raises ValueError and leaves this process as it was.")
      .def_static(
          "default", [](std::optional<double> height) {
            BodyImportOptions o;
            o.height = height;
            py::gil_scoped_release nogil;
            return std::make_shared<Body>(Body::load(Body::default_path(), o));
          },
          py::arg("height") = py::none(), "The default body: human.zae from assimp-testmodels (1.66 m).")
      .def_static("default_path", &Body::default_path)
      .def_static(
          "from_triangles",
          [](py::handle vertices, py::handle triangles, const std::string& name) {
            auto v = real_array(vertices, "body vertices", -1, 3);
            py::array t = py::module_::import("numpy").attr("asarray")(triangles);
            if (t.dtype().kind() != 'i' && t.dtype().kind() != 'u')
              throw py::type_error("body triangles must be an integer array of shape (T, 3)");
            if (t.ndim() != 2 || t.shape(1) != 3) throw InputError("body triangles must have shape (T, 3)");
            auto ti = py::array_t<long long, py::array::c_style | py::array::forcecast>::ensure(t);
            std::vector<Vec3> vs(v.shape(0));
            for (py::ssize_t i = 0; i < v.shape(0); ++i) vs[i] = Vec3(v.at(i, 0), v.at(i, 1), v.at(i, 2));
            std::vector<std::array<int, 3>> ts(ti.shape(0));
            for (py::ssize_t i = 0; i < ti.shape(0); ++i)
              for (int k = 0; k < 3; ++k) {
                const long long x = ti.at(i, k);
                if (x < 0 || x >= v.shape(0))
                  throw InputError("body triangle " + std::to_string(i) + " names vertex " + std::to_string(x) +
                                   ", which does not exist");
                ts[i][k] = static_cast<int>(x);
              }
            return std::make_shared<Body>(Body::from_triangles(std::move(vs), std::move(ts), name));
          },
          py::arg("vertices"), py::arg("triangles"), py::arg("name") = "body",
          "A body from an (N, 3) array of vertices in metres (+Y up) and a (T, 3) array of triangles.")
      .def_property_readonly("name", &Body::name)
      .def_property_readonly("vertices", [](const Body& b) {
        py::array_t<double> a({static_cast<py::ssize_t>(b.vertices().size()), py::ssize_t(3)});
        auto r = a.mutable_unchecked<2>();
        for (std::size_t i = 0; i < b.vertices().size(); ++i)
          for (int k = 0; k < 3; ++k) r(i, k) = b.vertices()[i][k];
        return a;
      }, "(N, 3) float64, metres (a copy)")
      .def_property_readonly("triangles", [](const Body& b) {
        py::array_t<std::int64_t> a({static_cast<py::ssize_t>(b.triangles().size()), py::ssize_t(3)});
        auto r = a.mutable_unchecked<2>();
        for (std::size_t i = 0; i < b.triangles().size(); ++i)
          for (int k = 0; k < 3; ++k) r(i, k) = b.triangles()[i][k];
        return a;
      }, "(T, 3) int64 (a copy)")
      .def_property_readonly("height", &Body::height, "metres")
      .def_property_readonly("bounds", [](const Body& b) { return box_array(b.bounds()); }, "[[min xyz], [max xyz]]")
      .def_property_readonly("report", [](const Body& b) {
        const BodyImportReport& r = b.report();
        py::dict d;
        d["format"] = r.format;
        d["up_source"] = r.up_source;
        d["scale_source"] = r.scale_source;
        d["up"] = axis_name(r.up);
        d["front_source"] = r.front_source;
        d["front"] = axis_name(r.front);
        d["smoothing"] = r.smoothing;
        d["scale"] = r.scale;
        d["meshes_merged"] = r.meshes_merged;
        d["vertices_before_weld"] = r.vertices_before_weld;
        return d;
      }, "How the import read the file.")
      .def("__repr__", [](const Body& b) {
        return "<kiji.Body '" + b.name() + "', " + std::to_string(b.vertices().size()) + " vertices, " +
               std::to_string(b.height()) + " m tall>";
      });

  // --- Camera and pictures ---
  py::class_<Camera>(m, "Camera", "A pinhole camera for render().")
      .def(py::init([](py::handle eye, py::handle target, py::handle up, double fov) {
             Camera c;
             if (!eye.is_none()) c.eye = to_vec3(eye, "eye");
             if (!target.is_none()) c.target = to_vec3(target, "target");
             if (!up.is_none()) c.up = to_vec3(up, "up");
             c.fov_degrees = fov;
             return c;
           }),
           py::arg("eye") = py::none(), py::arg("target") = py::none(), py::arg("up") = py::none(),
           py::arg("fov_degrees") = 35.0)
      .def_property("eye", [](const Camera& c) { return vec3_array(c.eye); },
                    [](Camera& c, py::handle v) { c.eye = to_vec3(v, "eye"); })
      .def_property("target", [](const Camera& c) { return vec3_array(c.target); },
                    [](Camera& c, py::handle v) { c.target = to_vec3(v, "target"); })
      .def_property("up", [](const Camera& c) { return vec3_array(c.up); },
                    [](Camera& c, py::handle v) { c.up = to_vec3(v, "up"); })
      .def_readwrite("fov_degrees", &Camera::fov_degrees)
      .def_static("framing", [](py::handle box) {
        auto b = real_array(box, "box", 2, 3);
        return Camera::framing(Box3(Vec3(b.at(0, 0), b.at(0, 1), b.at(0, 2)), Vec3(b.at(1, 0), b.at(1, 1), b.at(1, 2))));
      }, py::arg("box"), "A camera in front (+Z) of a [[min], [max]] box, framing all of it.");

  m.def("write_png", [](py::handle image, const std::string& path) { write_png(array_image(image), path); },
        py::arg("image"), py::arg("path"), "Writes an (H, W, 4) uint8 array as a PNG file.");
  m.def("read_png", [](const std::string& path) { return image_array(read_png(path)); }, py::arg("path"),
        "Reads a PNG file as an (H, W, 4) uint8 array.");
}

}  // namespace kiji::python
