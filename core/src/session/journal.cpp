#include "kiji/journal.h"

#include "kiji/error.h"
#include "sim/solver_state.h"

#include <algorithm>
#include <cstring>

namespace kiji {

namespace {
// The garment without its records and texture: its mesh and property maps.
std::size_t mesh_bytes(const Garment& g) {
  const Mesh& m = g.mesh();
  const std::size_t v = g.vertex_capacity();
  const std::size_t h = m.number_of_halfedges() + m.number_of_removed_halfedges();
  const std::size_t e = h / 2;
  const std::size_t f = m.number_of_faces() + m.number_of_removed_faces();
  // Surface_mesh's connectivity and removed flags, then Kiji's property maps (point, velocity,
  // inverse mass; uv; rest length, tear threshold; panel).
  std::size_t bytes = v * (4 + 1 + 24 + 24 + 8) + h * (16 + 16) + e * (1 + 8 + 8) + f * (4 + 1 + 4);
  return bytes + g.tacks.size() * 8 + sizeof(Garment);
}

// The solver's records a garment carries (docs/solver.md), each counted once over `counted`: a
// snapshot shares them with the garment and with the snapshots taken while no step ran between,
// and every step record of one build shares the positions the build was taken from and its anchors.
std::size_t record_bytes(const Garment& g, std::vector<const void*>& counted) {
  auto first = [&](const void* p) {
    if (!p || std::find(counted.begin(), counted.end(), p) != counted.end()) return false;
    counted.push_back(p);
    return true;
  };
  std::size_t bytes = 0;
  if (const auto& r = g.sleep_record(); first(r.get())) bytes += bytes_of(*r);
  if (const auto& r = g.step_record(); first(r.get())) {
    bytes += bytes_of(*r);
    if (first(r->built_at.get())) bytes += r->built_at->size() * sizeof(Vec3);
    if (first(r->built_alive.get())) bytes += r->built_alive->size();
    if (first(r->anchors.get()))
      for (const auto& level : *r->anchors) bytes += level.size() * sizeof(int);
  }
  return bytes;
}
}  // namespace

std::size_t garment_bytes(const Garment& g, bool with_texture) {
  std::vector<const void*> counted;
  return mesh_bytes(g) + record_bytes(g, counted) + (with_texture ? g.texture().rgba.size() : 0);
}

GarmentSnapshot::GarmentSnapshot(const std::vector<Garment>& garments, const GarmentSnapshot* previous) {
  garments_.reserve(garments.size());
  textures_.reserve(garments.size());
  for (std::size_t i = 0; i < garments.size(); ++i) {
    const Texture& t = garments[i].texture();
    std::shared_ptr<const Texture> shared;
    if (previous && i < previous->textures_.size()) {
      const auto& p = previous->textures_[i];
      if (p && p->width == t.width && p->height == t.height && p->rgba.size() == t.rgba.size() &&
          (t.rgba.empty() || std::memcmp(p->rgba.data(), t.rgba.data(), t.rgba.size()) == 0))
        shared = p;
    }
    if (!shared) shared = std::make_shared<const Texture>(t);
    textures_.push_back(std::move(shared));
    // The copy without the texture: the shared one stands for it.
    Garment copy = garments[i];
    copy.texture() = Texture{};
    garments_.push_back(std::move(copy));
  }
}

std::vector<Garment> GarmentSnapshot::garments() const {
  std::vector<Garment> out = garments_;
  for (std::size_t i = 0; i < out.size(); ++i) out[i].texture() = *textures_[i];
  return out;
}

std::size_t GarmentSnapshot::bytes(std::vector<const void*>& counted) const {
  std::size_t total = 0;
  for (const Garment& g : garments_) total += mesh_bytes(g) + record_bytes(g, counted);
  for (const auto& t : textures_) {
    if (std::find(counted.begin(), counted.end(), t.get()) != counted.end()) continue;
    counted.push_back(t.get());
    total += t->rgba.size() + sizeof(Texture);
  }
  return total;
}

void Journal::push(JournalEntry entry) {
  entries_.resize(cursor_);
  entries_.push_back(std::move(entry));
  cursor_ = entries_.size();
  enforce_limit();
}

void Journal::enforce_limit() {
  auto total = [&] {
    std::vector<const void*> counted;
    std::size_t bytes = 0;
    for (const JournalEntry& e : entries_) bytes += e.before.bytes(counted) + e.after.bytes(counted);
    return bytes;
  };
  history_bytes_ = total();
  // The oldest go first; the newest stays whatever its size. Recounted after each, since a
  // texture may be shared with the next step.
  while (history_bytes_ > history_limit_ && entries_.size() > 1) {
    entries_.erase(entries_.begin());
    if (cursor_ > 0) --cursor_;
    ++dropped_;
    history_bytes_ = total();
  }
}

const JournalEntry& Journal::undo() { return entries_[--cursor_]; }

const JournalEntry& Journal::redo() { return entries_[cursor_++]; }

const GarmentSnapshot* Journal::latest_snapshot() const {
  return entries_.empty() ? nullptr : &entries_.back().after;
}

void Journal::set_history_limit(std::size_t bytes) {
  if (bytes < (std::size_t(1) << 20))
    throw InputError("undo history limit of " + std::to_string(bytes) + " bytes is too small: use 1 MB or more");
  history_limit_ = bytes;
  enforce_limit();
}

void Journal::clear_history() {
  entries_.clear();
  cursor_ = 0;
  history_bytes_ = 0;
}

void Journal::clear() {
  operations_.clear();
  entries_.clear();
  cursor_ = 0;
  history_bytes_ = 0;
}

}  // namespace kiji
