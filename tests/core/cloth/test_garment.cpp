#include "kiji/garment.h"
#include "kiji/error.h"

#include <gtest/gtest.h>

#include <limits>
#include <vector>

using namespace kiji;

namespace {
Garment single_triangle() {
  Mesh m;
  auto a = m.add_vertex(Point3(0, 0, 0)), b = m.add_vertex(Point3(1, 0, 0)), c = m.add_vertex(Point3(0, 1, 0));
  m.add_face(a, b, c);
  return Garment(std::move(m));
}
}  // namespace

TEST(Garment, AdoptsMeshWithRestLengthsUvAndMasses) {
  Garment g = single_triangle();
  EXPECT_TRUE(g.is_valid());
  for (Edge e : g.mesh().edges()) EXPECT_DOUBLE_EQ(g.rest_length(e), g.length(e));
  // Area 0.5 m^2 at the default 0.15 kg/m^2: a third each.
  for (Vertex v : g.mesh().vertices()) EXPECT_NEAR(g.mass(v), 0.5 * 0.15 / 3.0, 1e-12);
  for (Vertex v : g.mesh().vertices()) EXPECT_NEAR(1.0 / g.inverse_mass(v), 0.5 * 0.15 / 3.0, 1e-12);
}

TEST(Garment, PinAndUnpinRestoresMass) {
  Garment g = single_triangle();
  Vertex v = *g.mesh().vertices().begin();
  const double m = g.mass(v);
  g.set_pinned(v, true);
  EXPECT_TRUE(g.pinned(v));
  EXPECT_EQ(g.inverse_mass(v), 0.0);
  g.recompute_masses();
  EXPECT_TRUE(g.pinned(v)) << "recomputing masses must keep pins";
  g.set_pinned(v, false);
  EXPECT_NEAR(1.0 / g.inverse_mass(v), m, 1e-12);
}

TEST(Garment, CopyIsIndependent) {
  Garment g = single_triangle();
  Garment c = g;
  Vertex v = *g.mesh().vertices().begin();
  c.velocity(v) = Vec3(1, 2, 3);
  c.set_position(v, Vec3(5, 5, 5));
  EXPECT_EQ(g.velocity(v), Vec3::Zero());
  EXPECT_EQ(g.position(v), Vec3(0, 0, 0));
  EXPECT_EQ(c.velocity(v), Vec3(1, 2, 3));
}

TEST(Garment, ValidateRejectsNaN) {
  Garment g = single_triangle();
  g.set_position(*g.mesh().vertices().begin(), Vec3(std::nan(""), 0, 0));
  EXPECT_THROW(g.validate(), InputError);
}

TEST(Garment, MaterialOutOfRangeIsRefusedAndKeepsTheOldOne) {
  Garment g = single_triangle();
  Material bad;
  bad.density = -1;
  try {
    g.set_material(bad);
    FAIL() << "a negative density was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("density"), std::string::npos) << e.what();
  }
  EXPECT_EQ(g.material().density, Material{}.density);
  EXPECT_THROW(Material::preset("velvet"), InputError);
  EXPECT_EQ(Material::preset("rubber").name, "rubber");
}

TEST(Garment, EveryMaterialFieldOutsideItsRangeIsRefusedByName) {
  // Each field out of range, below and above, with a denormal where a field must be positive: a
  // stiffness of 7.5e-315 passed a "positive" check and made the solver's compliance infinite.
  const double nan = std::numeric_limits<double>::quiet_NaN();
  struct Case {
    const char* field;
    double Material::*member;
    std::vector<double> bad;
  };
  const std::vector<Case> cases = {
      {"density", &Material::density, {0, 7.5e-315, 1e-4, 11, nan}},
      {"stretch_stiffness", &Material::stretch_stiffness, {0, 7.5e-315, 0.5, 2e7, nan}},
      {"bending_stiffness", &Material::bending_stiffness, {-1e-6, 7.5e-315, 2, nan}},
      {"damping", &Material::damping, {-0.1, 1001, nan}},
      {"friction", &Material::friction, {-0.1, 11, nan}},
      {"thickness", &Material::thickness, {0, 7.5e-315, 0.1, nan}},
      {"tear_ratio", &Material::tear_ratio, {1.0, 1001, nan}},
  };
  for (const Case& c : cases)
    for (double value : c.bad) {
      Material m;
      m.*c.member = value;
      try {
        m.validate();
        ADD_FAILURE() << c.field << " = " << value << " was accepted";
      } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find(c.field), std::string::npos) << e.what();
      }
    }
  for (const std::string& name : Material::preset_names()) EXPECT_NO_THROW(Material::preset(name).validate()) << name;
  Material still;
  still.bending_stiffness = 0;  // no bending at all is a choice
  EXPECT_NO_THROW(still.validate());
}
