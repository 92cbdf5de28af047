// Queries against a body (kiji/collision.h), picking on garments (kiji/pick.h), and what remains of
// the body's header: triangle normals and its geometry id.
#include "bindings.h"

#include "kiji/collision.h"
#include "kiji/operation.h"
#include "kiji/pick.h"

#include <cmath>

namespace kiji::python {

namespace {

// A collider with its body kept alive (BodyCollider keeps the body by reference).
struct PyCollider {
  std::shared_ptr<Body> body;
  std::unique_ptr<BodyCollider> collider;
};

}  // namespace

void bind_collision(py::module_& m) {
  py::class_<BodyContact>(m, "BodyContact", "The body point a query found: where, its outward normal, the signed distance.")
      .def_readonly("hit", &BodyContact::hit)
      .def_readonly("triangle", &BodyContact::triangle, "the body triangle (a row of Body.triangles)")
      .def_property_readonly("point", [](const BodyContact& c) { return vec3_array(c.point); })
      .def_property_readonly("normal", [](const BodyContact& c) { return vec3_array(c.normal); })
      .def_readonly("distance", &BodyContact::distance, "signed distance along the normal, metres (negative: inside)")
      .def("__bool__", [](const BodyContact& c) { return c.hit; })
      .def("__repr__", [](const BodyContact& c) {
        return c.hit ? "BodyContact(triangle=" + std::to_string(c.triangle) + ", distance=" + std::to_string(c.distance) + ")"
                     : std::string("BodyContact(hit=False)");
      });
  py::class_<PyCollider, std::shared_ptr<PyCollider>>(m, "BodyCollider",
      "Collision queries against a body: Bullet's tree for the broadphase, exact point-triangle tests.")
      .def(py::init([](std::shared_ptr<Body> body) {
             if (!body) throw py::type_error("BodyCollider: expected a kiji.Body");
             auto c = std::make_shared<PyCollider>();
             c->body = std::move(body);
             py::gil_scoped_release nogil;
             c->collider = std::make_unique<BodyCollider>(*c->body);
             return c;
           }),
           py::arg("body"))
      .def_property_readonly("body", [](const PyCollider& c) { return c.body; })
      .def("triangles_in_box", [](const PyCollider& c, py::handle box) {
        auto b = real_array(box, "box", 2, 3);
        std::vector<int> out;
        c.collider->triangles_in_box(Box3(Vec3(b.at(0, 0), b.at(0, 1), b.at(0, 2)), Vec3(b.at(1, 0), b.at(1, 1), b.at(1, 2))), out);
        py::array_t<std::int64_t> a(static_cast<py::ssize_t>(out.size()));
        for (std::size_t i = 0; i < out.size(); ++i) a.mutable_data()[i] = out[i];
        return a;
      }, py::arg("box"), "Rows of the triangles whose bounding boxes overlap a [[min], [max]] box.")
      .def("closest", [](const PyCollider& c, py::handle p, double radius) {
        if (!std::isfinite(radius) || radius < 0) throw InputError("closest: radius must be a finite number of metres, 0 or more");
        return c.collider->closest(to_vec3(p, "point"), radius);
      }, py::arg("point"), py::arg("radius"), "The body point closest to a point within radius (hit False if none).")
      .def("first_crossing", [](const PyCollider& c, py::handle a, py::handle b) {
        return c.collider->first_crossing(to_vec3(a, "a"), to_vec3(b, "b"));
      }, py::arg("a"), py::arg("b"), "The first body triangle the segment a -> b crosses (hit False if none).")
      .def("inside", [](const PyCollider& c, py::handle p) { return c.collider->inside(to_vec3(p, "point")); },
           py::arg("point"),
           "Whether a point is inside the body's volume (by rays, right on fins of no thickness and inverted faces).");

  auto body = py::reinterpret_borrow<py::class_<Body, std::shared_ptr<Body>>>(m.attr("Body"));
  body.def_property_readonly("triangle_normals", [](const Body& b) {
    py::array_t<double> a({static_cast<py::ssize_t>(b.triangles().size()), py::ssize_t(3)});
    for (std::size_t t = 0; t < b.triangles().size(); ++t) {
      const Vec3 n = b.triangle_normal(t);
      for (int k = 0; k < 3; ++k) a.mutable_at(t, k) = n[k];
    }
    return a;
  }, "(T, 3) the outward unit normal of each triangle.");
  body.def_property_readonly("geometry_id", &Body::geometry_id,
                             "A number naming the body's geometry: a copy has the same, any other body its own.");
  body.def("to_bytes", [](const Body& b) { return py::bytes(encode_body(b)); },
           "The body in Kiji's binary form (what a set_body operation carries).");
  body.def_static("from_bytes", [](const py::bytes& data) {
    const std::string bytes = data;
    return std::make_shared<Body>(decode_body(bytes));
  }, py::arg("data"), "A body from its binary form; InputError for malformed bytes.");
  m.def("axis_names", []() {
    std::vector<std::string> out;
    for (Axis a : {Axis::PosX, Axis::NegX, Axis::PosY, Axis::NegY, Axis::PosZ, Axis::NegZ}) out.push_back(axis_name(a));
    return out;
  }, "The up axes Body.load(up=...) accepts.");

  m.def("pick", [](const std::vector<std::shared_ptr<GarmentRef>>& garments, py::handle position, py::handle ray,
                   double radius) {
    std::vector<Garment> gs;
    for (const auto& g : garments) {
      if (!g) throw py::type_error("pick: garments must be kiji.Garment objects");
      auto lock = g->guard();
      gs.push_back(g->get());
    }
    if (!std::isfinite(radius) || radius <= 0) throw InputError("pick: radius must be a positive number of metres");
    return pick(gs, to_vec3(position, "position"), ray.is_none() ? Vec3::Zero() : to_vec3(ray, "ray"), radius);
  }, py::arg("garments"), py::arg("position"), py::arg("ray") = py::none(), py::arg("radius") = 0.05,
     "The cloth point nearest `position` within radius (or where a ray from it first meets the cloth) among\n"
     "garments; SurfaceHit.garment is the index in the list.");
}

}  // namespace kiji::python
