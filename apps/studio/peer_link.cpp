#include "peer_link.h"

#include "kiji/error.h"
#include "kiji/session_key.h"

#include <chrono>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <mutex>

namespace kiji::studio {

namespace {

// The clock PeerRunner gives its Peer (PeerInfo::last_heard is on it).
double seconds_now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

Vec3 hsv(double h, double s, double v) {
  const double c = v * s, hp = std::fmod(h, 1.0) * 6, x = c * (1 - std::abs(std::fmod(hp, 2.0) - 1));
  Vec3 rgb = hp < 1 ? Vec3(c, x, 0) : hp < 2 ? Vec3(x, c, 0) : hp < 3 ? Vec3(0, c, x)
           : hp < 4 ? Vec3(0, x, c) : hp < 5 ? Vec3(x, 0, c) : Vec3(c, 0, x);
  return rgb + Vec3::Constant(v - c);
}

std::string new_key_path(const std::string& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw InputError("cannot make the folder '" + dir + "' for a new session key: " + ec.message());
  char stamp[32];
  const std::time_t t = std::time(nullptr);
  std::strftime(stamp, sizeof stamp, "%Y%m%d-%H%M%S", std::localtime(&t));
  std::string path = (std::filesystem::path(dir) / (std::string("session-") + stamp + ".key")).string();
  for (int n = 2; std::filesystem::exists(path); ++n)
    path = (std::filesystem::path(dir) / (std::string("session-") + stamp + "-" + std::to_string(n) + ".key")).string();
  return path;
}

}  // namespace

Vec3 peer_colour(std::uint32_t id) {
  // Hues spread by the golden ratio; the cloth's red and the pen's blue and orange are avoided by
  // keeping to the greens, purples and cyans between them.
  const double spread = std::fmod(double(id % 100003) * 0.6180339887, 1.0);
  return hsv(0.22 + 0.58 * spread, 0.85, 0.9);
}

Vec3 PeerView::colour_of(std::uint32_t id) const {
  const PeerRow* r = row(id);
  return r ? r->colour : peer_colour(id);
}

const PeerRow* PeerView::row(std::uint32_t id) const {
  for (const PeerRow& r : peers)
    if (r.id == id) return &r;
  return nullptr;
}

PeerLink::PeerLink(Session& session, PeerSettings settings) : session_(session), settings_(std::move(settings)) {
  if (settings_.host && settings_.key_file.empty()) {
    if (settings_.default_key_dir.empty()) throw InputError("give the session's key file");
    settings_.key_file = new_key_path(settings_.default_key_dir);
  }
  if (!(settings_.stop_seconds >= 0 && settings_.stop_seconds <= 1e6))
    throw InputError("the shared clock's stop must be 0 (never) to 1e6 seconds");
  PeerOptions options;
  options.key = read_session_key(settings_.key_file, settings_.host, &made_key_);
  options.host = settings_.host;
  options.name = settings_.name.empty() ? (settings_.host ? "host" : "peer") : settings_.name;
  PeerNetwork network;
  network.url = settings_.url;
  network.channel = settings_.channel;
  {
    std::lock_guard<std::recursive_mutex> lock(session_.mutex());
    if (settings_.host && settings_.stop_seconds > 0)
      options.stop_step = static_cast<std::uint64_t>(
          std::ceil((session_.time() + settings_.stop_seconds) * session_.frame_rate() - 1e-9));
    runner_ = std::make_unique<PeerRunner>(session_, options, network);
  }
}

PeerLink::~PeerLink() {
  if (runner_) runner_->stop();
}

std::string PeerLink::error() const { return runner_->running() ? std::string() : runner_->error(); }

std::vector<std::string> PeerLink::take_refusals() {
  std::vector<std::string> out;
  out.swap(refusals_);
  return out;
}

bool PeerLink::update(const PeerPresence* presence, bool sample) {
  std::unique_lock<std::recursive_mutex> lock(session_.mutex(), std::try_to_lock);
  if (!lock.owns_lock()) return false;
  runner_->with_peer([&](Peer& peer) {
    if (presence) peer.set_presence(*presence);
    const std::vector<PeerRefusal>& refused = peer.refusals();
    for (; refusals_seen_ < refused.size(); ++refusals_seen_) refusals_.push_back(refused[refusals_seen_].reason);
    if (!sample) return;
    auto view = std::make_shared<PeerView>();
    const double now = seconds_now();
    view->host = settings_.host;
    view->joined = peer.joined();
    view->converged = peer.converged();
    view->self = peer.id();
    view->sequencer = peer.sequencer();
    view->step = session_.steps();
    view->stop_step = peer.stop_step();
    view->state_hash = peer.state_hash();
    view->applied = peer.applied();
    view->url = settings_.url;
    view->channel = settings_.channel;
    view->key_file = settings_.key_file;
    view->leases = peer.leases();
    for (auto& [id, row] : seen_) row.present = false;
    for (const PeerInfo& p : peer.peers()) {
      PeerRow& r = seen_[p.id];
      r.id = p.id;
      r.name = p.name;
      r.colour = peer_colour(p.id);
      r.self = p.self;
      r.sequencer = p.sequencer;
      r.joined = p.joined;
      r.present = true;
      r.step = p.step;
      r.heard_seconds_ago = p.self ? 0 : std::max(0.0, now - p.last_heard);
      r.hash_agrees = p.hash_agrees;
      r.presence = p.presence;
      r.has_presence = p.presence.pointer != Vec3::Zero() || p.presence.eye != p.presence.target;
    }
    for (auto& [id, r] : seen_) {
      r.leased_vertices = 0;
      if (!r.present) r.sequencer = false;
      for (const LeaseInfo& l : view->leases)
        if (l.holder == id) r.leased_vertices += l.vertices.size();
    }
    const auto self = seen_.find(peer.id());
    if (self != seen_.end()) view->peers.push_back(self->second);
    for (const auto& [id, r] : seen_)
      if (id != peer.id()) view->peers.push_back(r);
    view_ = std::move(view);
  });
  return true;
}

}  // namespace kiji::studio
