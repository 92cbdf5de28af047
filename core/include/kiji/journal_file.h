// Journal files: a session's strokes saved to disk and read back, and replayed on a fresh session.
//
// A stroke is saved as what made it — the tool id, every parameter's value and the events (phase,
// time, pointer pose, buttons, pressure, ray) — not as the garments it produced: replaying it on a
// session set up the same way (same garments, body and solver parameters) re-runs the simulation to
// each event's time and the tool on each event, and so gives the same garments again.
//
// The format, version 1: one JSON document (UTF-8), numbers written so that doubles read back exactly.
//   {"format": "kiji-journal", "version": 1, "kiji": "0.1.0",
//    "strokes": [{"tool": "cut", "params": {"mode": "stroke"},
//                 "events": [{"phase": "begin", "time": 0.0, "position": [x, y, z],
//                             "orientation": [w, x, y, z], "buttons": 1, "pressure": 1.0,
//                             "ray": [x, y, z]}, ...]}, ...]}
// Parameter values are JSON booleans, integers, floats, strings, or [r, g, b] for colours. A reader
// refuses another format or a later version, saying which. (The LCM log of the design notes will
// replace this format; it will be version 2.)
#pragma once

#include "kiji/journal.h"

#include <functional>
#include <map>
#include <string>
#include <vector>

namespace kiji {

class Session;

constexpr int kJournalFileVersion = 1;

// One stroke as it is saved: enough to run it again.
struct JournalStroke {
  std::string tool;
  std::map<std::string, ParamValue> params;
  Stroke events;
};

// The strokes done so far (entries before the journal's cursor; undone ones are left out).
std::vector<JournalStroke> journal_strokes(const Journal& journal);

// Writes the strokes done so far. Throws InputError if the file cannot be written.
void save_journal(const Journal& journal, const std::string& path);
void save_journal(const std::vector<JournalStroke>& strokes, const std::string& path);

// Reads a journal file. Throws InputError for a missing or unreadable file, another format or
// version, or a malformed stroke, naming the stroke and the field.
std::vector<JournalStroke> load_journal(const std::string& path);

// Called after each replayed event with the events done and the total; return false to stop (the
// stroke in progress is cancelled, so nothing is half-applied).
using ReplayProgress = std::function<bool(std::size_t done, std::size_t total)>;

// Runs the strokes, in order, through session.apply(). Returns the number of strokes finished.
// Throws InputError if a stroke names a tool the session does not have or a bad parameter.
std::size_t replay(Session& session, const std::vector<JournalStroke>& strokes,
                   const ReplayProgress& progress = {});

}  // namespace kiji
