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
  // Ranges wide around real fabrics (the presets' values are well inside), so that a value from a
  // slip of the keyboard or damaged bytes (a stiffness of 1e-315) is refused, not simulated.
  auto within = [](double x, double lo, double hi) { return std::isfinite(x) && x >= lo && x <= hi; };
  require(within(density, 1e-3, 10), "density", density,
          "an areal density from 0.001 to 10 kg/m^2 (fabrics weigh 0.03 to 0.5)");
  require(within(stretch_stiffness, 1, 1e7), "stretch_stiffness", stretch_stiffness,
          "a stiffness from 1 to 10^7 N/m (fabrics are 300 to 6,000)");
  require(bending_stiffness == 0 || within(bending_stiffness, 1e-10, 1), "bending_stiffness", bending_stiffness,
          "0 or a rigidity from 1e-10 to 1 N*m (fabrics are 1e-6 to 2e-4)");
  require(within(damping, 0, 1000), "damping", damping, "a rate from 0 to 1000 per second");
  require(within(friction, 0, 10), "friction", friction, "a coefficient from 0 to 10");
  require(within(thickness, 1e-5, 0.1) && thickness < 0.1, "thickness", thickness,
          "from 0.00001 to under 0.1 metres");
  require(within(tear_ratio, 1, 1000) && tear_ratio > 1.0, "tear_ratio", tear_ratio,
          "greater than 1 and at most 1000 (a stretch factor of the rest length)");
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
