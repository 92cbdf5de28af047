#include "kiji/journal.h"

namespace kiji {

void Journal::push(JournalEntry entry) {
  entries_.resize(cursor_);
  entries_.push_back(std::move(entry));
  cursor_ = entries_.size();
}

const JournalEntry& Journal::undo() { return entries_[--cursor_]; }

const JournalEntry& Journal::redo() { return entries_[cursor_++]; }

void Journal::clear() {
  entries_.clear();
  cursor_ = 0;
}

}  // namespace kiji
