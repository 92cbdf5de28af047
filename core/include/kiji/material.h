// A fabric's physical properties, in SI units. Presets cover the cloths a designer reaches for.
#pragma once

#include <string>
#include <vector>

namespace kiji {

struct Material {
  std::string name = "cotton";
  double density = 0.15;            // areal density, kg/m^2
  double stretch_stiffness = 2000;  // membrane stiffness, N/m (force per unit width per unit strain)
  double bending_stiffness = 2e-5;  // bending rigidity, N*m
  double damping = 0.5;             // velocity damping, 1/s
  double friction = 0.4;            // Coulomb friction against the body
  double thickness = 0.004;         // collision thickness, m (cloth keeps this far from the body)
  double tear_ratio = 1.6;          // an edge tears when its length exceeds tear_ratio * rest length

  // Throws InputError naming the first field that is out of range (non-finite, negative, ...).
  void validate() const;

  static Material cotton();
  static Material silk();
  static Material denim();
  static Material rubber();   // stretches far before it tears
  static Material tissue();   // fragile: tears under a small pull
  // A preset by name ("cotton", "silk", "denim", "rubber", "tissue"); throws InputError listing them.
  static Material preset(const std::string& name);
  static std::vector<std::string> preset_names();
};

}  // namespace kiji
