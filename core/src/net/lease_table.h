// Exclusive control: each user's leases on cloth (the vertices near where they work, until a step),
// decided as ordered operations are applied, so that every peer grants and refuses the same. A tool
// event leases the cloth around its hit point; an event, an edit, undo or redo on cloth another
// user holds is refused (a refused stroke is cancelled and its later events dropped until the
// user's next begin). The table travels in a joiner's snapshot. Internal to the core.
#pragma once

#include "kiji/operation.h"
#include "kiji/peer.h"
#include "kiji/session.h"

#include <cstdint>
#include <functional>
#include <map>
#include <set>
#include <string>
#include <string_view>
#include <vector>

namespace kiji::detail {

struct Lease {
  std::map<std::uint32_t, std::set<std::uint32_t>> vertices;  // by garment
  std::uint64_t expires = 0;                                   // the step it ends at
};

class LeaseTable {
 public:
  using NameOf = std::function<std::string(UserId)>;
  using Refuse = std::function<void(UserId, const std::string&)>;
  // A tool event leases `radius` metres around its hit for `hold_seconds` of simulated time.
  // `name_of` names the holder in a refusal; `refuse` tells a user why their change was refused.
  LeaseTable(Session& session, double radius, double hold_seconds, NameOf name_of, Refuse refuse);

  // Whether `op` by `user` may apply under the leases, granting what a tool event takes.
  bool admit(UserId user, Operation& op);
  // A lease asked for outright (Peer::lease): granted, or refused when another user holds cloth there.
  void lease(UserId user, std::uint32_t garment, const Vec3& center, double radius, double seconds);
  void release(UserId user) { leases_.erase(user); }
  // A garment removed: the indices the leases name are another garment's now.
  void clear() { leases_.clear(); }
  // A user gone: their leases, and their refused stroke.
  void forget(UserId user) {
    leases_.erase(user);
    refused_.erase(user);
  }
  // A new start (a checkpoint): no stroke is refused any more.
  void clear_refused() { refused_.clear(); }
  // Leases whose step has come go.
  void expire();

  std::vector<LeaseInfo> infos() const;
  // The table in a snapshot's binary form, and back.
  std::string encode() const;
  void decode(std::string_view bytes);

 private:
  std::vector<std::uint32_t> region(std::size_t g, const Vec3& p, double radius) const;
  UserId holder(UserId user, std::size_t g, const std::vector<std::uint32_t>* vertices) const;
  void grant(UserId user, std::size_t g, const std::vector<std::uint32_t>& vertices, double seconds);

  Session& session_;
  double radius_, hold_seconds_;
  NameOf name_of_;
  Refuse refuse_;
  std::map<UserId, Lease> leases_;
  std::set<UserId> refused_;  // users whose stroke was refused: their events are dropped until a begin
};

}  // namespace kiji::detail
