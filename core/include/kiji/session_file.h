// Session files: a design session kept as an LCM log of its operations, in the order they were
// applied (channel KIJI_OPS, one kiji_lcm::op_record_t an operation), so that a session can be
// saved, loaded, recovered after a crash, and played to a running peer with `lcm-logplayer`.
// A saved file also carries the session's whole state when it was saved (a Checkpoint operation on
// channel KIJI_STATE, after the operations): Kiji opens the file from it, without replaying every
// step. Readers of the operations alone (an earlier Kiji, a peer listening to lcm-logplayer) skip
// that channel and replay the operations, which give the same state.
//
// Autosave appends each operation as the session applies it and hands it to the operating system
// before the call that made it returns (a process killed at any moment loses nothing whose call had
// returned); the end of every stroke and every other operation is also flushed to the disk itself.
// recover() rebuilds the session from the file: every complete operation, with strokes that the
// crash left unfinished cancelled.
#pragma once

#include "kiji/operation.h"
#include "kiji/plugin_loader.h"

#include <cstdio>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace kiji {

class Session;

constexpr const char* kSessionChannel = "KIJI_OPS";
constexpr const char* kSessionStateChannel = "KIJI_STATE";
constexpr int kSessionFileProtocol = 1;

// What reading a session file found.
struct SessionFileReport {
  std::size_t operations = 0;     // complete, intact operations read
  std::size_t good_bytes = 0;     // where the last of them ends in the file
  std::size_t file_bytes = 0;
  std::string damage;             // why reading stopped before the end ("" if it did not)
};

// Writes `before`, then every operation of the session's log, then the session's whole state, to
// `path` (replaced). `before` is the history of a session that was opened from a saved state (see
// SavedState): written first, so that the file keeps all of it. Throws InputError if it cannot.
void save_session(const Session& session, const std::string& path, const std::vector<Operation>& before = {});

// The last whole state a session file carries, and how many of its operations came before it: a
// session is opened by applying the state (a Checkpoint) and then the operations after it.
struct SavedState {
  Operation checkpoint;        // op::Checkpoint with the state
  std::size_t after = 0;       // the operations before it in the file (its history)
  bool found = false;
};

// The operations of a session file, in order. A damaged or cut-off tail (a crash while writing) is
// left out and said in `report`; records on other channels are skipped, but for the last intact state
// on KIJI_STATE, given in `state`. Throws InputError for a file that cannot be read or is not a
// session file (no record on KIJI_OPS where it should start).
std::vector<Operation> load_session(const std::string& path, SessionFileReport* report = nullptr,
                                    SavedState* state = nullptr);

// Applies a session file's operations to a session (a new one): from its saved state when it has one
// (the operations before it are not replayed), else every operation. Returns the operations applied.
std::size_t open_operations(Session& session, const std::vector<Operation>& operations, const SavedState& state);

// One record of a session file (also the bytes of one KIJI_OPS message, as lcm-logplayer plays it)
// as an operation. Returns false, saying why, for bytes that are not a whole, intact record.
bool decode_session_record(std::string_view bytes, Operation& out, std::string& why);

// Appends every operation the session applies to a session file, from construction until
// destruction. An existing file is appended to only with `append` (recover() does so); otherwise a
// file that exists and is not empty is refused, so that no earlier session is overwritten.
class Autosave {
 public:
  Autosave(Session& session, const std::string& path, bool append = false);
  ~Autosave();
  Autosave(const Autosave&) = delete;
  Autosave& operator=(const Autosave&) = delete;
  const std::string& path() const { return path_; }
  std::size_t written() const { return written_; }
  // Writes the session's whole state (the session is not changed), so that recovery starts there:
  // an autosave begun on a session opened from a file, and one that has run long, write one.
  void write_state();

 private:
  void write(const Operation& op, const char* channel = kSessionChannel);
  Session& session_;
  std::string path_;
  struct Log;
  std::unique_ptr<Log> log_;
  int listener_ = -1;
  std::size_t written_ = 0;
};

struct Recovered {
  std::unique_ptr<Session> session;
  std::unique_ptr<Autosave> autosave;  // continuing in the same file, unless not asked for
  SessionFileReport report;
  std::size_t cancelled_strokes = 0;   // left unfinished by the crash
};

// Rebuilds a session from a session file (with the tools of `registry`, or the default plugins):
// from the last state it holds, every complete operation after it applied in order, unfinished
// strokes cancelled. With `keep_saving`, the
// file's damaged tail (if any) is cut off and the session goes on autosaving into it.
Recovered recover(const std::string& path, std::shared_ptr<ToolRegistry> registry = nullptr,
                  bool keep_saving = true);

}  // namespace kiji
