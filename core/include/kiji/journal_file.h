// Journal files: a session's history as JSON, the readable export of a session (the session's own
// file is the LCM log of kiji/session_file.h), read back and replayed on a new session.
//
// Version 2 holds every operation in the order it was applied, so replaying it on a new session
// gives the same garments bit for bit:
//   {"format": "kiji-journal", "version": 2, "kiji": "0.2.0", "operations": [
//     {"step": 0, "user": 0, "kind": "set_body", "body": "<base64>"},
//     {"step": 0, "user": 0, "kind": "add_garment", "garment": "<base64>"},
//     {"step": 12, "user": 0, "kind": "tool", "tool": "cut", "params": {"mode": "stroke"},
//      "event": {"phase": "begin", "time": 0.2, "position": [x, y, z], "orientation": [w, x, y, z],
//                "buttons": 1, "pressure": 1.0, "ray": [x, y, z]}}, ...]}
// Kinds: tool (params on begin only), add_garment, remove_garment (index), set_garment (index,
// garment), set_body (body or null), set_solver_params (params, by name), set_frame_rate
// (steps_per_second), set_simulating (simulating), set_pick_radius (radius), undo, redo, advance
// (the clock reached `step`; a saved file ends with one), checkpoint (state or null). Garments
// and bodies are their binary forms (kiji/operation.h) in base64; numbers are written so that
// doubles read back exactly.
//
// Version 1 (read, and written for a list of strokes): {"format": "kiji-journal", "version": 1,
// "strokes": [{"tool", "params", "events": [...]}]}: strokes only, replayed at their events' times
// on a session set up the same way.
#pragma once

#include "kiji/journal.h"
#include "kiji/operation.h"

#include <functional>
#include <map>
#include <string>
#include <string_view>
#include <vector>

namespace kiji {

class Session;

constexpr int kJournalFileVersion = 2;

// One stroke: enough to run it again.
struct JournalStroke {
  std::string tool;
  std::map<std::string, ParamValue> params;
  Stroke events;
};

// A journal file's content: strokes (version 1) or operations (version 2).
struct JournalFile {
  int version = kJournalFileVersion;
  std::vector<JournalStroke> strokes;
  std::vector<Operation> operations;
};

// The strokes done so far (steps of the undo history before its cursor that are strokes).
std::vector<JournalStroke> journal_strokes(const Journal& journal);
// The strokes a list of operations leaves done: each user's events from begin to end, in the order
// the strokes ended, without those undone (or cancelled, or cut off at the end of the list).
std::vector<JournalStroke> strokes_of(const std::vector<Operation>& operations);

// The operations that save a session: its log, and an `advance` to its clock if time passed since
// the last one (so that a replay ends where the session is).
std::vector<Operation> operations_to_save(const Session& session);
// Writes every operation of the session's log (version 2). Throws InputError if it cannot.
void save_journal(const Session& session, const std::string& path);
void save_journal(const std::vector<Operation>& operations, const std::string& path);
// Writes strokes (version 1).
void save_journal(const std::vector<JournalStroke>& strokes, const std::string& path);

// Reads a journal file of either version. Throws InputError for a missing or unreadable file,
// another format or a later version, or a malformed entry, naming the entry and the field.
JournalFile read_journal_file(const std::string& path);
// The same from the file's text; `name` is what messages call it.
JournalFile parse_journal(std::string_view text, const std::string& name = "journal");
// The strokes of a journal file (version 2: strokes_of its operations).
std::vector<JournalStroke> load_journal(const std::string& path);

// Called after each replayed event or operation with those done and the total; return false to
// stop (a stroke in progress is cancelled, so nothing is half-applied).
using ReplayProgress = std::function<bool(std::size_t done, std::size_t total)>;

// Runs strokes, in order, through session.apply(), at their times: from the session's clock on
// where the first stroke began before it (the strokes keep their times apart). Returns the number
// of strokes finished. Throws InputError, before changing anything, if a stroke names a tool the
// session does not have or a bad parameter.
std::size_t replay(Session& session, const std::vector<JournalStroke>& strokes, const ReplayProgress& progress = {});
// Performs operations, in order, on a new session or one whose own log is a beginning of them (a
// session set up with the same operations: those are skipped). Returns the number of operations the
// session then has of the list. Throws InputError, before changing anything, if the session's log
// differs from the list's beginning, if the session's clock has passed the step of the first
// operation it would apply (time ran on since it was set up: the operations cannot come at their
// steps, so the result would not be the journal's), or if the steps go back. Strokes the list
// leaves unfinished stay in progress.
std::size_t replay(Session& session, const std::vector<Operation>& operations, const ReplayProgress& progress = {});
// Replays a journal file of either version.
std::size_t replay_file(Session& session, const std::string& path, const ReplayProgress& progress = {});

}  // namespace kiji
