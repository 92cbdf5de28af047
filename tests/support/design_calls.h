// The calls of a design session used where a session must be busy for a while: a repeating mix of
// strokes, steps, pausing and direct edits on garment 0 (a flat 0.6 x 0.4 m rectangle). Shared by
// the session-file tests and the child process they kill.
#pragma once

#include "kiji/session.h"
#include "support/test_strokes.h"

namespace kiji::test {

// The k-th call.
inline void design_call(Session& s, int k) {
  switch (k % 5) {
    case 0:
      s.run("pinch", s.params_for("pinch"),
            line(Vec3(0.1 * (k % 7), 0, 0), Vec3(0.1 * (k % 7), 0, 0.05), 4, s.time()));
      break;
    case 1: s.step(); break;
    case 2: s.set_simulating(k % 2 == 0); break;
    case 3:
      s.run("pin", s.params_for("pin"), line(Vec3(0.5, 0.05 * (k % 9), 0), Vec3(0.5, 0.05 * (k % 9), 0), 1, s.time()));
      break;
    case 4: {
      Garment g = s.garment(0);
      g.transform(Eigen::Affine3d(Eigen::Translation3d(0, 0, 0.001)));
      s.set_garment(0, g);
      break;
    }
  }
}

}  // namespace kiji::test
