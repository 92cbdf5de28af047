// The session journal: every tool stroke, as the events that made it, with the garments as they
// were before and after it, so that undo and redo restore them exactly and a session can be replayed.
#pragma once

#include "kiji/garment.h"
#include "kiji/params.h"
#include "kiji/tool_event.h"

#include <map>
#include <string>
#include <vector>

namespace kiji {

struct JournalEntry {
  std::string tool;                          // tool id
  std::map<std::string, ParamValue> params;  // every parameter's value for the stroke
  Stroke events;                             // as the tool received them (hits filled in)
  std::vector<Garment> before, after;        // every garment of the session
};

class Journal {
 public:
  const std::vector<JournalEntry>& entries() const { return entries_; }
  // Entries [0, cursor) are done; [cursor, size) were undone and can be redone.
  std::size_t cursor() const { return cursor_; }
  bool can_undo() const { return cursor_ > 0; }
  bool can_redo() const { return cursor_ < entries_.size(); }
  // Appends a finished stroke, dropping whatever had been undone.
  void push(JournalEntry entry);
  const JournalEntry& undo();  // the entry undone; precondition can_undo()
  const JournalEntry& redo();  // the entry redone; precondition can_redo()
  void clear();

 private:
  std::vector<JournalEntry> entries_;
  std::size_t cursor_ = 0;
};

}  // namespace kiji
