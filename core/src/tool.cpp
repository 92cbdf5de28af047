#include "kiji/tool.h"

#include "kiji/error.h"
#include "kiji/session.h"

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

void Tool::run(Session& session, const ParamSet& params, const Stroke& stroke) {
  session.run(*this, params, stroke);
}

}  // namespace kiji
