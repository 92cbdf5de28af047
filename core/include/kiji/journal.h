// The session journal: the log of every operation the session applied, in order (what replay,
// saving, autosave and peers use), and the undo history built on it: each completed change to the
// garments (a stroke, a garment added, removed or edited) with the garments as they were before and
// after it, so that undo and redo restore them exactly.
//
// The undo history is bounded by bytes (history_limit): the oldest steps are dropped first. A
// garment's painted texture is stored once while it does not change, not once per step.
#pragma once

#include "kiji/garment.h"
#include "kiji/operation.h"
#include "kiji/params.h"
#include "kiji/tool_event.h"

#include <map>
#include <memory>
#include <string>
#include <vector>

namespace kiji {

// Every garment of a session at one moment. Textures are held apart from the garments and shared
// between snapshots while they are equal.
class GarmentSnapshot {
 public:
  GarmentSnapshot() = default;
  // Takes the garments; a texture equal to the one `previous` holds for the same garment is shared.
  GarmentSnapshot(const std::vector<Garment>& garments, const GarmentSnapshot* previous);
  std::vector<Garment> garments() const;  // the garments as they were, textures included
  std::size_t size() const { return garments_.size(); }
  // Memory held, counting what snapshots share (a texture, the solver's records) only if `counted`
  // has not seen it (and adding it there).
  std::size_t bytes(std::vector<const void*>& counted) const;

 private:
  std::vector<Garment> garments_;  // without their textures
  std::vector<std::shared_ptr<const Texture>> textures_;
};

// One step of the undo history.
struct JournalEntry {
  std::string tool;                          // the tool id of a stroke, else the operation's kind
  UserId user = 0;
  std::map<std::string, ParamValue> params;  // a stroke's parameters
  Stroke events;                             // a stroke's events as the tool received them
  GarmentSnapshot before, after;
};

class Journal {
 public:
  // --- the operation log ---
  const std::vector<Operation>& operations() const { return operations_; }
  void record(Operation op) { operations_.push_back(std::move(op)); }

  // --- the undo history ---
  const std::vector<JournalEntry>& entries() const { return entries_; }
  // Entries [0, cursor) are done; [cursor, size) were undone and can be redone.
  std::size_t cursor() const { return cursor_; }
  bool can_undo() const { return cursor_ > 0; }
  bool can_redo() const { return cursor_ < entries_.size(); }
  // Appends a finished step, dropping whatever had been undone, then the oldest steps while the
  // history holds more than history_limit bytes (the newest step is always kept).
  void push(JournalEntry entry);
  const JournalEntry& undo();  // the entry undone; precondition can_undo()
  const JournalEntry& redo();  // the entry redone; precondition can_redo()
  // The newest snapshot in the history (to share textures with), or null.
  const GarmentSnapshot* latest_snapshot() const;
  void clear();
  // Forgets the undo history (the log stays).
  void clear_history();

  // Bytes of garments and textures the undo history holds.
  std::size_t history_bytes() const { return history_bytes_; }
  std::size_t history_limit() const { return history_limit_; }
  // At least 1 MB. The default, 1 GiB, keeps about 80 steps of a 20,000-vertex garment (each step
  // holds the garments before and after it).
  void set_history_limit(std::size_t bytes);
  // Steps dropped from the front of the history to keep within the limit, since the start.
  std::size_t dropped() const { return dropped_; }

 private:
  void enforce_limit();
  std::vector<Operation> operations_;
  std::vector<JournalEntry> entries_;
  std::size_t cursor_ = 0;
  std::size_t history_bytes_ = 0;
  std::size_t history_limit_ = std::size_t(1) << 30;
  std::size_t dropped_ = 0;
};

// Approximate memory of a garment: its mesh, property maps, the solver's records and its texture.
std::size_t garment_bytes(const Garment& garment, bool with_texture = true);

}  // namespace kiji
