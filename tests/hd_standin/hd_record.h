// What the stand-in HD library recorded in its KIJI_HD_STANDIN_LOG file: the calls in order, each
// servo frame's force, the errors it raised (see hd_standin.cpp).
#pragma once

#include "kiji/types.h"

#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

namespace kiji::test {

struct HdRecord {
  std::vector<std::string> calls;
  std::vector<std::string> lines;                  // every line, in order
  std::vector<std::pair<double, Vec3>> forces;     // (seconds since the scheduler started, newtons)
  std::vector<unsigned> errors;
};

inline HdRecord read_hd_record(const std::string& path) {
  HdRecord r;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream s(line);
    std::string kind;
    s >> kind;
    r.lines.push_back(line);
    if (kind == "call") {
      std::string name;
      s >> name;
      r.calls.push_back(name);
    } else if (kind == "force") {
      double t, x, y, z;
      s >> t >> x >> y >> z;
      r.forces.emplace_back(t, Vec3(x, y, z));
    } else if (kind == "error") {
      double t;
      std::string code;
      s >> t >> code;
      r.errors.push_back(static_cast<unsigned>(std::stoul(code, nullptr, 16)));
    }
  }
  return r;
}

}  // namespace kiji::test
