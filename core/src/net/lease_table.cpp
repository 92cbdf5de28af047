#include "net/lease_table.h"

#include "base/archive.h"

#include <algorithm>
#include <cmath>

namespace kiji::detail {

namespace {

// The table's fields, in the order a snapshot has them.
template <class A>
void fields(A& a, Field<A, std::map<UserId, Lease>>& leases) {
  a.entries(leases, 4096, 16, "the number of leases", [&](auto& user, auto& lease) {
    a.u32(user);
    a.u64(lease.expires);
    a.entries(lease.vertices, 4096, 8, "the number of garments", [&](auto& garment, auto& vertices) {
      a.u32(garment);
      a.list(vertices, 1u << 24, 4, "the number of vertices", [&](auto& v) { a.u32(v); });
    });
  });
  a.end();
}

}  // namespace

LeaseTable::LeaseTable(Session& session, double radius, double hold_seconds, NameOf name_of, Refuse refuse)
    : session_(session), radius_(radius), hold_seconds_(hold_seconds), name_of_(std::move(name_of)),
      refuse_(std::move(refuse)) {}

std::vector<std::uint32_t> LeaseTable::region(std::size_t g, const Vec3& p, double radius) const {
  std::vector<std::uint32_t> out;
  const Garment& garment = session_.garment(g);
  const double r2 = radius * radius;
  for (Vertex v : garment.mesh().vertices())
    if ((garment.position(v) - p).squaredNorm() <= r2) out.push_back(v.idx());
  return out;
}

// Another user's unexpired lease on any of `vertices` of garment g (all of g when null), or 0.
UserId LeaseTable::holder(UserId user, std::size_t g, const std::vector<std::uint32_t>* vertices) const {
  for (const auto& [other, lease] : leases_) {
    if (other == user || lease.expires <= session_.steps()) continue;
    auto it = lease.vertices.find(static_cast<std::uint32_t>(g));
    if (it == lease.vertices.end() || it->second.empty()) continue;
    if (!vertices) return other;
    for (std::uint32_t v : *vertices)
      if (it->second.count(v)) return other;
  }
  return 0;
}

void LeaseTable::grant(UserId user, std::size_t g, const std::vector<std::uint32_t>& vertices, double seconds) {
  Lease& lease = leases_[user];
  lease.vertices[static_cast<std::uint32_t>(g)].insert(vertices.begin(), vertices.end());
  const auto hold = static_cast<std::uint64_t>(std::ceil(seconds * session_.frame_rate()));
  lease.expires = std::max(lease.expires, session_.steps() + hold);
}

bool LeaseTable::admit(UserId user, Operation& op) {
  const auto refuse_for = [&](UserId other, const std::string& what) {
    refuse_(user, what + ": " + name_of_(other) + " is working there (their lease ends at step " +
                      std::to_string(leases_[other].expires) + ")");
  };
  if (auto* t = std::get_if<op::ToolInput>(&op.data)) {
    const Phase phase = t->event.phase;
    if (phase == Phase::Begin) refused_.erase(user);
    else if (refused_.count(user)) return false;  // the rest of a refused stroke
    if (phase == Phase::Cancel) return true;
    const SurfaceHit hit = session_.pick(t->event.position, t->event.ray);
    if (!hit.hit) return true;
    const std::vector<std::uint32_t> area = region(hit.garment, hit.point, radius_);
    if (const UserId other = holder(user, hit.garment, &area)) {
      refused_.insert(user);
      refuse_for(other, "the '" + t->tool + "' stroke was refused");
      if (phase != Phase::Begin && session_.stroke_active(user))
        session_.perform(
            {session_.steps(), user, op::ToolInput{session_.active_tool(user), {}, cancel_event(session_.time())}});
      return false;
    }
    grant(user, hit.garment, area, hold_seconds_);
    return true;
  }
  auto whole = [&](std::size_t g, const char* what) {
    if (g >= session_.garment_count()) return true;
    if (const UserId other = holder(user, g, nullptr)) {
      refuse_for(other, std::string(what) + " of garment " + std::to_string(g) + " was refused");
      return false;
    }
    return true;
  };
  if (const auto* s = std::get_if<op::SetGarment>(&op.data)) return whole(s->index, "an edit");
  if (const auto* r = std::get_if<op::RemoveGarment>(&op.data)) return whole(r->index, "removing");
  if (std::holds_alternative<op::Undo>(op.data) || std::holds_alternative<op::Redo>(op.data)) {
    for (std::size_t g = 0; g < session_.garment_count(); ++g)
      if (!whole(g, std::holds_alternative<op::Undo>(op.data) ? "undo" : "redo")) return false;
  }
  return true;
}

void LeaseTable::lease(UserId user, std::uint32_t garment, const Vec3& center, double radius, double seconds) {
  if (garment >= session_.garment_count()) {
    refuse_(user, "a lease on garment " + std::to_string(garment) + ", which does not exist");
    return;
  }
  const std::vector<std::uint32_t> area = region(garment, center, radius);
  if (const UserId other = holder(user, garment, &area)) {
    refuse_(user, "the lease was refused: " + name_of_(other) + " holds cloth there");
    return;
  }
  grant(user, garment, area, seconds);
}

void LeaseTable::expire() {
  for (auto it = leases_.begin(); it != leases_.end();)
    it = it->second.expires <= session_.steps() ? leases_.erase(it) : std::next(it);
}

std::vector<LeaseInfo> LeaseTable::infos() const {
  std::vector<LeaseInfo> out;
  for (const auto& [user, lease] : leases_) {
    if (lease.expires <= session_.steps()) continue;
    for (const auto& [g, vs] : lease.vertices)
      out.push_back({user, g, std::vector<std::uint32_t>(vs.begin(), vs.end()), lease.expires});
  }
  return out;
}

std::string LeaseTable::encode() const {
  WriteArchive a;
  fields(a, leases_);
  return a.take();
}

void LeaseTable::decode(std::string_view bytes) {
  ReadArchive a(bytes, "the leases of a snapshot");
  std::map<UserId, Lease> leases;
  fields(a, leases);
  leases_ = std::move(leases);
}

}  // namespace kiji::detail
