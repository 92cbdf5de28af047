// The app's side of a shared session (docs/peers.md): a PeerRunner for the app's session, and what
// the UI shows of it (the peers, their pointers and viewpoints, the cloth each holds, refusals),
// copied under the session's lock only when the lock is free, so that the UI never waits on a step
// or on the network. No Qt here: the window reads PeerView.
#pragma once

#include "kiji/peer_runner.h"

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace kiji::studio {

struct PeerSettings {
  bool host = false;
  std::string url = PeerNetwork{}.url;
  std::string channel = PeerNetwork{}.channel;
  std::string name;
  // The session's key. A host with an empty path gets a new key file in `default_key_dir`.
  std::string key_file;
  std::string default_key_dir;
  double stop_seconds = 0;  // (host) the shared clock stops at this simulated time; 0: never
};

// One row of the Peers list.
struct PeerRow {
  std::uint32_t id = 0;
  std::string name;
  Vec3 colour{0.5, 0.5, 0.5};
  bool self = false, sequencer = false, joined = false;
  bool present = true;            // false: it left or went silent (kept, so the list says so)
  double heard_seconds_ago = 0;   // 0 for this app
  std::uint64_t step = 0;
  std::size_t leased_vertices = 0;
  std::optional<bool> hash_agrees;  // unset: not yet compared (or this app's own row)
  bool has_presence = false;      // it has said where its pointer and viewpoint are
  PeerPresence presence;
};

struct PeerView {
  bool host = false, joined = false, converged = false;
  std::uint32_t self = 0, sequencer = 0;
  std::uint64_t step = 0, stop_step = 0, state_hash = 0, applied = 0;
  std::vector<PeerRow> peers;     // this app first, then the others by id
  std::vector<LeaseInfo> leases;  // unexpired, in the holder's colour (colour_of)
  std::string url, channel, key_file;
  Vec3 colour_of(std::uint32_t id) const;
  const PeerRow* row(std::uint32_t id) const;
};

// A colour for a peer, the same in every app of the session (from its id), far from the cloth's
// and the pen's own.
Vec3 peer_colour(std::uint32_t id);

class PeerLink {
 public:
  // Joins or hosts: reads (a host: makes) the key file, opens the network. Throws InputError with
  // what was wrong (a bad key file, a network LCM cannot open); the session is then left unshared.
  PeerLink(Session& session, PeerSettings settings);
  ~PeerLink();  // leaves: the others free this app's leases at once
  PeerLink(const PeerLink&) = delete;
  PeerLink& operator=(const PeerLink&) = delete;

  const PeerSettings& settings() const { return settings_; }
  bool made_key() const { return made_key_; }

  // Sends this user's presence (at most `presence` when given) and, when `sample`, copies the
  // peers into view(). Returns false, doing nothing, when the session is busy (a step, a stroke):
  // the caller tries again on its next tick.
  bool update(const PeerPresence* presence, bool sample);
  std::shared_ptr<const PeerView> view() const { return view_; }
  // Refusals of this app's user's edits since the last call (each with its reason).
  std::vector<std::string> take_refusals();
  // Why the peer stopped by itself (the network failed, the shared session could not be applied),
  // or "" while it runs.
  std::string error() const;

 private:
  Session& session_;
  PeerSettings settings_;
  bool made_key_ = false;
  std::unique_ptr<PeerRunner> runner_;
  std::shared_ptr<const PeerView> view_;
  std::map<std::uint32_t, PeerRow> seen_;  // every peer met, for the list
  std::size_t refusals_seen_ = 0;
  std::vector<std::string> refusals_;
};

}  // namespace kiji::studio
