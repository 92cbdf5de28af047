// Tool parameters, declared once (name, type, default, range, unit, label, help) and used
// everywhere: the command line, the Python bindings, the app's panels and the docs.
#pragma once

#include "kiji/types.h"

#include <map>
#include <string>
#include <variant>
#include <vector>

namespace kiji {

enum class ParamType { Bool, Int, Float, String, Choice, Color };
const char* param_type_name(ParamType type);

// Bool -> bool, Int -> long long, Float -> double, String and Choice -> std::string,
// Color -> Vec3 (linear RGB, each in [0,1]).
using ParamValue = std::variant<bool, long long, double, std::string, Vec3>;

// A value as a user would type it: true, 3, 0.5, 'cotton', (0.1, 0.2, 0.8).
std::string param_value_text(const ParamValue& value);

struct ParamSpec {
  std::string name;                  // a Python identifier: the keyword argument's name
  ParamType type = ParamType::Float;
  ParamValue default_value = 0.0;
  double min = 0, max = 0;           // Int and Float: the allowed range, inclusive (min == max: any)
  std::string unit;                  // "m", "N/m", "", ...
  std::string label;                 // for panels
  std::string help;                  // one or two sentences
  std::vector<std::string> choices;  // Choice: the allowed values

  // Builders, so that a tool's parameter list reads as a table.
  static ParamSpec boolean(std::string name, bool value, std::string label, std::string help);
  static ParamSpec integer(std::string name, long long value, long long min, long long max, std::string label,
                           std::string help);
  static ParamSpec real(std::string name, double value, double min, double max, std::string unit,
                        std::string label, std::string help);
  static ParamSpec text(std::string name, std::string value, std::string label, std::string help);
  static ParamSpec choice(std::string name, std::string value, std::vector<std::string> choices,
                          std::string label, std::string help);
  static ParamSpec color(std::string name, Vec3 value, std::string label, std::string help);

  // Throws InputError if `value` has the wrong type or is out of range, naming the parameter.
  // An Int given for a Float is accepted (and converted by ParamSet::set).
  void check(const ParamValue& value) const;
};

// Values for a tool's parameters: every declared parameter has a value (its default until set).
class ParamSet {
 public:
  ParamSet() = default;
  explicit ParamSet(std::vector<ParamSpec> specs);

  const std::vector<ParamSpec>& specs() const { return specs_; }
  // Throws InputError for an unknown name (listing the known ones) or a bad value.
  void set(const std::string& name, const ParamValue& value);
  const ParamValue& get(const std::string& name) const;
  bool get_bool(const std::string& name) const { return std::get<bool>(get(name)); }
  long long get_int(const std::string& name) const { return std::get<long long>(get(name)); }
  double get_float(const std::string& name) const { return std::get<double>(get(name)); }
  const std::string& get_string(const std::string& name) const { return std::get<std::string>(get(name)); }
  Vec3 get_color(const std::string& name) const { return std::get<Vec3>(get(name)); }
  const std::map<std::string, ParamValue>& values() const { return values_; }

 private:
  const ParamSpec& spec(const std::string& name) const;
  std::vector<ParamSpec> specs_;
  std::map<std::string, ParamValue> values_;
};

}  // namespace kiji
