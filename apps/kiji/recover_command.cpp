// kiji recover: rebuilds a design session from its session file (an autosave) after a crash, says
// what it found, and writes what was asked.
#include "args.h"
#include "commands.h"
#include "kiji/error.h"
#include "kiji/io.h"
#include "kiji/journal_file.h"
#include "kiji/session.h"
#include "kiji/session_file.h"

#include <nlohmann/json.hpp>

#include <cstdio>

namespace kiji::cli {

int recover_command(const std::vector<std::string>& argv) {
  std::vector<std::string> rest;
  std::string path;
  for (const std::string& a : argv) {
    if (path.empty() && !a.empty() && a[0] != '-') path = a;
    else rest.push_back(a);
  }
  const Args args(rest, {"--export", "--save-journal"}, {"--repair", "--json", "--help", "-h"});
  if (args.has("--help") || args.has("-h")) {
    std::puts(
        "usage: kiji recover SESSION_FILE [--export GARMENT.glb|.obj] [--save-journal FILE.json] [--repair] [--json]\n\n"
        "Rebuilds the session of a session file (an autosave): every operation whose call had returned, strokes\n"
        "the crash left unfinished cancelled. Says how many operations it read and any damage at the end of the\n"
        "file (a crash while writing). --export writes garment 0, --save-journal the operations as JSON,\n"
        "--repair cuts a damaged end off the file so that saving into it can go on.");
    return 0;
  }
  if (path.empty()) throw UsageError("give the session file to recover");
  Recovered r = recover(path, nullptr, args.has("--repair"));
  r.autosave.reset();  // nothing more is written to the file
  const Session& s = *r.session;
  if (args.has("--export")) {
    if (s.garment_count() == 0) throw InputError("the recovered session has no garment to export");
    export_garment(s.garment(0), args.get("--export", ""));
  }
  if (args.has("--save-journal")) save_journal(s, args.get("--save-journal", ""));
  if (args.has("--json")) {
    nlohmann::json j = {{"operations", r.report.operations},
                        {"damage", r.report.damage},
                        {"cancelled_strokes", r.cancelled_strokes},
                        {"garments", s.garment_count()},
                        {"time", s.time()},
                        {"steps", s.steps()}};
    std::printf("%s\n", j.dump().c_str());
  } else {
    std::printf("%s: %zu operations recovered, %zu garment(s), clock at %.3f s\n", path.c_str(), r.report.operations,
                s.garment_count(), s.time());
    if (r.cancelled_strokes) std::printf("  %zu stroke(s) left unfinished by the crash were cancelled\n", r.cancelled_strokes);
    if (!r.report.damage.empty())
      std::printf("  the file's end was damaged (%s)%s\n", r.report.damage.c_str(),
                  args.has("--repair") ? ": cut off" : "; --repair cuts it off");
  }
  return 0;
}

}  // namespace kiji::cli
