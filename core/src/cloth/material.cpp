#include "kiji/material.h"

#include "kiji/error.h"

#include <cmath>
#include <sstream>

namespace kiji {

namespace {
void require(bool ok, const char* field, double value, const char* what) {
  if (ok) return;
  std::ostringstream msg;
  msg << "material field '" << field << "' is " << value << ": it must be " << what;
  throw InputError(msg.str());
}
}  // namespace

void Material::validate() const {
  auto finite = [](double x) { return std::isfinite(x); };
  require(finite(density) && density > 0, "density", density, "a positive areal density in kg/m^2");
  require(finite(stretch_stiffness) && stretch_stiffness > 0, "stretch_stiffness", stretch_stiffness,
          "a positive stiffness in N/m");
  require(finite(bending_stiffness) && bending_stiffness >= 0, "bending_stiffness",
          bending_stiffness, "zero or a positive rigidity in N*m");
  require(finite(damping) && damping >= 0, "damping", damping, "zero or a positive rate in 1/s");
  require(finite(friction) && friction >= 0, "friction", friction, "zero or a positive coefficient");
  require(finite(thickness) && thickness > 0 && thickness < 0.1, "thickness", thickness,
          "between 0 and 0.1 metres");
  require(finite(tear_ratio) && tear_ratio > 1.0, "tear_ratio", tear_ratio,
          "greater than 1 (a stretch factor of the rest length)");
}

Material Material::cotton() { return Material{}; }

Material Material::silk() {
  Material m;
  m.name = "silk";
  m.density = 0.08;
  m.stretch_stiffness = 1200;
  m.bending_stiffness = 4e-6;
  m.friction = 0.25;
  m.thickness = 0.003;
  m.tear_ratio = 1.4;
  return m;
}

Material Material::denim() {
  Material m;
  m.name = "denim";
  m.density = 0.4;
  m.stretch_stiffness = 6000;
  m.bending_stiffness = 2e-4;
  m.friction = 0.6;
  m.thickness = 0.005;
  m.tear_ratio = 1.8;
  return m;
}

Material Material::rubber() {
  Material m;
  m.name = "rubber";
  m.density = 0.5;
  m.stretch_stiffness = 300;
  m.bending_stiffness = 5e-5;
  m.friction = 0.9;
  m.thickness = 0.004;
  m.tear_ratio = 4.0;
  return m;
}

Material Material::tissue() {
  Material m;
  m.name = "tissue";
  m.density = 0.03;
  m.stretch_stiffness = 800;
  m.bending_stiffness = 1e-6;
  m.friction = 0.3;
  m.thickness = 0.002;
  m.tear_ratio = 1.1;
  return m;
}

std::vector<std::string> Material::preset_names() { return {"cotton", "silk", "denim", "rubber", "tissue"}; }

Material Material::preset(const std::string& name) {
  if (name == "cotton") return cotton();
  if (name == "silk") return silk();
  if (name == "denim") return denim();
  if (name == "rubber") return rubber();
  if (name == "tissue") return tissue();
  std::string list;
  for (const auto& n : preset_names()) list += (list.empty() ? "" : ", ") + n;
  throw InputError("unknown material '" + name + "': choose one of " + list);
}

}  // namespace kiji
