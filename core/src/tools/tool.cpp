#include "kiji/tool.h"

#include "kiji/error.h"

namespace kiji {

const char* phase_name(Phase phase) {
  switch (phase) {
    case Phase::Begin: return "begin";
    case Phase::Move: return "move";
    case Phase::End: return "end";
    case Phase::Cancel: return "cancel";
  }
  return "?";
}

}  // namespace kiji
