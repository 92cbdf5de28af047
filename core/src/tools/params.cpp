#include "kiji/params.h"

#include "kiji/error.h"
#include "tools/identifier.h"

#include <cctype>
#include <cmath>
#include <sstream>

namespace kiji {

const char* param_type_name(ParamType type) {
  switch (type) {
    case ParamType::Bool: return "bool";
    case ParamType::Int: return "int";
    case ParamType::Float: return "float";
    case ParamType::String: return "str";
    case ParamType::Choice: return "choice";
    case ParamType::Color: return "color";
  }
  return "?";
}

namespace {

ParamSpec base(std::string name, ParamType type, ParamValue value, std::string label, std::string help) {
  if (!detail::is_identifier(name))
    throw InputError("parameter name '" + name + "' is not an identifier: use letters, digits and _");
  ParamSpec s;
  s.name = std::move(name);
  s.type = type;
  s.default_value = std::move(value);
  s.label = std::move(label);
  s.help = std::move(help);
  return s;
}

}  // namespace

std::string param_value_text(const ParamValue& v) {
  std::ostringstream o;
  std::visit(
      [&](const auto& x) {
        using T = std::decay_t<decltype(x)>;
        if constexpr (std::is_same_v<T, Vec3>) o << "(" << x.x() << ", " << x.y() << ", " << x.z() << ")";
        else if constexpr (std::is_same_v<T, bool>) o << (x ? "true" : "false");
        else if constexpr (std::is_same_v<T, std::string>) o << "'" << x << "'";
        else o << x;
      },
      v);
  return o.str();
}

namespace {
std::string value_text(const ParamValue& v) { return param_value_text(v); }  // short, for messages
}  // namespace

ParamSpec ParamSpec::boolean(std::string name, bool value, std::string label, std::string help) {
  return base(std::move(name), ParamType::Bool, value, std::move(label), std::move(help));
}

ParamSpec ParamSpec::integer(std::string name, long long value, long long min, long long max, std::string label,
                             std::string help) {
  ParamSpec s = base(std::move(name), ParamType::Int, value, std::move(label), std::move(help));
  s.min = double(min);
  s.max = double(max);
  s.check(s.default_value);
  return s;
}

ParamSpec ParamSpec::real(std::string name, double value, double min, double max, std::string unit,
                          std::string label, std::string help) {
  ParamSpec s = base(std::move(name), ParamType::Float, value, std::move(label), std::move(help));
  s.min = min;
  s.max = max;
  s.unit = std::move(unit);
  s.check(s.default_value);
  return s;
}

ParamSpec ParamSpec::text(std::string name, std::string value, std::string label, std::string help) {
  return base(std::move(name), ParamType::String, std::move(value), std::move(label), std::move(help));
}

ParamSpec ParamSpec::choice(std::string name, std::string value, std::vector<std::string> choices,
                            std::string label, std::string help) {
  ParamSpec s = base(std::move(name), ParamType::Choice, std::move(value), std::move(label), std::move(help));
  s.choices = std::move(choices);
  s.check(s.default_value);
  return s;
}

ParamSpec ParamSpec::color(std::string name, Vec3 value, std::string label, std::string help) {
  ParamSpec s = base(std::move(name), ParamType::Color, value, std::move(label), std::move(help));
  s.check(s.default_value);
  return s;
}

void ParamSpec::check(const ParamValue& value) const {
  auto fail = [&](const std::string& why) {
    throw InputError("parameter '" + name + "' " + why);
  };
  switch (type) {
    case ParamType::Bool:
      if (!std::holds_alternative<bool>(value)) fail("must be true or false, not " + value_text(value));
      return;
    case ParamType::Int: {
      if (!std::holds_alternative<long long>(value)) fail("must be an integer, not " + value_text(value));
      const double x = double(std::get<long long>(value));
      if (min != max && (x < min || x > max))
        fail("is " + value_text(value) + ": it must be between " + value_text((long long)min) + " and " +
             value_text((long long)max));
      return;
    }
    case ParamType::Float: {
      double x = 0;  // set below, or fail() throws
      if (std::holds_alternative<double>(value)) x = std::get<double>(value);
      else if (std::holds_alternative<long long>(value)) x = double(std::get<long long>(value));
      else fail("must be a number, not " + value_text(value));
      if (!std::isfinite(x)) fail("is " + value_text(value) + ": it must be a finite number");
      if (min != max && (x < min || x > max)) {
        std::ostringstream o;
        o << "is " << x << (unit.empty() ? "" : " " + unit) << ": it must be between " << min << " and " << max
          << (unit.empty() ? "" : " " + unit);
        fail(o.str());
      }
      return;
    }
    case ParamType::String:
      if (!std::holds_alternative<std::string>(value)) fail("must be a string, not " + value_text(value));
      return;
    case ParamType::Choice: {
      if (!std::holds_alternative<std::string>(value)) fail("must be a string, not " + value_text(value));
      for (const auto& c : choices)
        if (c == std::get<std::string>(value)) return;
      std::string list;
      for (const auto& c : choices) list += (list.empty() ? "'" : ", '") + c + "'";
      fail("is " + value_text(value) + ": choose one of " + list);
      return;
    }
    case ParamType::Color: {
      if (!std::holds_alternative<Vec3>(value)) fail("must be a colour (r, g, b), not " + value_text(value));
      const Vec3& c = std::get<Vec3>(value);
      if (!c.allFinite() || c.minCoeff() < 0 || c.maxCoeff() > 1)
        fail("is " + value_text(value) + ": each of r, g, b must be between 0 and 1");
      return;
    }
  }
}

ParamSet::ParamSet(std::vector<ParamSpec> specs) : specs_(std::move(specs)) {
  for (const auto& s : specs_) {
    if (values_.count(s.name)) throw InputError("parameter '" + s.name + "' is declared twice");
    values_[s.name] = s.default_value;
  }
}

const ParamSpec& ParamSet::spec(const std::string& name) const {
  for (const auto& s : specs_)
    if (s.name == name) return s;
  std::string list;
  for (const auto& s : specs_) list += (list.empty() ? "" : ", ") + s.name;
  throw InputError("unknown parameter '" + name + "'" + (list.empty() ? ": this tool takes none" : "; known: " + list));
}

void ParamSet::set(const std::string& name, const ParamValue& value) {
  const ParamSpec& s = spec(name);
  s.check(value);
  if (s.type == ParamType::Float && std::holds_alternative<long long>(value))
    values_[name] = double(std::get<long long>(value));
  else
    values_[name] = value;
}

const ParamValue& ParamSet::get(const std::string& name) const {
  spec(name);
  return values_.at(name);
}

}  // namespace kiji
