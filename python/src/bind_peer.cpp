// kiji.Peer: a session shared with other peers over LCM (kiji::PeerRunner), from Python.
#include "bindings.h"
#include "kiji/peer_runner.h"

#include <chrono>
#include <thread>

namespace kiji::python {

namespace {

using SessionPtr = std::shared_ptr<Session>;

// The Python handle: the runner and the session it shares (kept alive while the peer runs).
class PyPeer {
 public:
  PyPeer(SessionPtr session, PeerOptions options, PeerNetwork network) : session_(std::move(session)) {
    if (!session_) throw py::type_error("Peer: expected a kiji.Session");
    SessionGuard lock(*session_);
    runner_ = std::make_unique<PeerRunner>(*session_, std::move(options), std::move(network));
  }
  ~PyPeer() { close(); }

  // Runs f(peer) holding the session the Python way (the GIL released while waiting for it).
  template <class F>
  auto with(F&& f) {
    if (!runner_) throw Error("this peer is closed: make a new kiji.Peer to take part again");
    SessionGuard lock(*session_);
    return runner_->with_peer(std::forward<F>(f));
  }
  void close() {
    if (!runner_) return;
    py::gil_scoped_release release;  // the runner's thread may be waiting for the GIL (a Python tool)
    runner_->stop();
    runner_.reset();
  }
  bool closed() const { return !runner_; }
  py::tuple played() const {
    if (!runner_) return py::make_tuple(0, 0, "");
    return py::make_tuple(runner_->played(), runner_->play_dropped(), runner_->play_error());
  }
  std::string error() const { return runner_ ? runner_->error() : std::string(); }
  // Polls `ready` with the GIL released, so that the peer's thread can run Python tools; false at the timeout.
  bool wait(const std::function<bool(Peer&)>& ready, double timeout) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout);
    for (;;) {
      if (with([&](Peer& p) { return ready(p); })) return true;
      if (!runner_->running()) throw Error("the peer stopped: " + runner_->error());
      if (std::chrono::steady_clock::now() >= end) return false;
      py::gil_scoped_release release;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
  }
  const SessionPtr& session() const { return session_; }

 private:
  SessionPtr session_;
  std::unique_ptr<PeerRunner> runner_;
};

py::dict peer_info(const PeerInfo& p) {
  py::dict d;
  d["id"] = p.id;
  d["name"] = p.name;
  d["self"] = p.self;
  d["sequencer"] = p.sequencer;
  d["joined"] = p.joined;
  d["step"] = p.step;
  d["hash_agrees"] = p.hash_agrees;
  d["pointer"] = vec3_array(p.presence.pointer);
  d["buttons"] = p.presence.buttons;
  d["eye"] = vec3_array(p.presence.eye);
  d["target"] = vec3_array(p.presence.target);
  d["tool"] = p.presence.tool;
  return d;
}

}  // namespace

void bind_peer(py::module_& m) {
  py::class_<PyPeer, std::shared_ptr<PyPeer>> p(m, "Peer", R"doc(
A session shared with others over LCM: several people design one garment at once, each machine
holding the whole session and simulating it (see docs/peers.md). While the peer runs, the session's
changes are proposed to the peers and applied by all in one order at the same step; its clock is
the shared one (Session.step raises: wait with wait_step or wait_converged instead). close() (or
leaving a `with` block) gives the session back to its users.)doc");
  p.def(py::init([](const SessionPtr& session, const std::string& key, bool host, const std::string& name,
                    const std::string& url, const std::string& channel, std::uint64_t stop_step,
                    double lease_radius, double lease_seconds, int lookahead_steps, int hash_interval,
                    const std::string& play_channel, double loss) {
          PeerOptions o;
          o.key = key;
          o.host = host;
          o.name = name;
          o.stop_step = stop_step;
          o.lease_radius = lease_radius;
          o.lease_hold_seconds = lease_seconds;
          o.lookahead_steps = lookahead_steps;
          o.hash_interval = hash_interval;
          PeerNetwork n;
          n.url = url;
          n.channel = channel;
          n.play_channel = play_channel;
          n.loss = loss;
          return std::make_shared<PyPeer>(session, std::move(o), std::move(n));
        }),
        py::arg("session"), py::kw_only(), py::arg("key"), py::arg("host") = false, py::arg("name") = "peer",
        py::arg("url") = PeerNetwork{}.url, py::arg("channel") = PeerNetwork{}.channel, py::arg("stop_step") = 0,
        py::arg("lease_radius") = PeerOptions{}.lease_radius, py::arg("lease_seconds") = PeerOptions{}.lease_hold_seconds,
        py::arg("lookahead_steps") = PeerOptions{}.lookahead_steps, py::arg("hash_interval") = PeerOptions{}.hash_interval,
        py::arg("play_channel") = "", py::arg("loss") = 0.0,
        "Shares `session` (host=True: start the shared session from its state; else join, and the "
        "session is replaced by the shared state). `key`: the session's secret, 16 characters or more. "
        "`play_channel`: an LCM channel whose recorded operations (a session file played by "
        "lcm-logplayer: 'KIJI_OPS') this peer proposes as its user's. `loss`: the share of arriving "
        "messages dropped at random (0 to 0.9), to try a lossy network.");
  p.def_property_readonly("id", [](PyPeer& self) { return self.with([](Peer& q) { return q.id(); }); },
                          "This peer's id (its user's id in the shared session).");
  p.def_property_readonly("joined", [](PyPeer& self) { return self.with([](Peer& q) { return q.joined(); }); },
                          "Whether this peer has the shared state.");
  p.def_property_readonly("is_sequencer", [](PyPeer& self) { return self.with([](Peer& q) { return q.is_sequencer(); }); },
                          "Whether this peer orders the session's operations now.");
  p.def_property_readonly("sequencer", [](PyPeer& self) { return self.with([](Peer& q) { return q.sequencer(); }); },
                          "The id of the peer that orders operations.");
  p.def_property_readonly("epoch", [](PyPeer& self) { return self.with([](Peer& q) { return q.epoch(); }); },
                          "The sequencer's term (one more at each takeover).");
  p.def_property_readonly("applied", [](PyPeer& self) { return self.with([](Peer& q) { return q.applied(); }); },
                          "Operations applied so far in the shared order.");
  p.def_property_readonly("pending", [](PyPeer& self) { return self.with([](Peer& q) { return q.pending(); }); },
                          "This peer's proposals not yet applied.");
  p.def_property_readonly("stop_step", [](PyPeer& self) { return self.with([](Peer& q) { return q.stop_step(); }); },
                          "The step the shared clock stops at (0: never).");
  p.def_property_readonly("session", &PyPeer::session, "The session this peer shares.");
  p.def_property_readonly("played", &PyPeer::played,
                          "Recorded operations taken from the play channel and proposed, and those dropped: "
                          "(played, dropped, the last reason one was dropped).");
  p.def_property_readonly("closed", &PyPeer::closed, "Whether close() was called.");
  p.def_property_readonly("error", &PyPeer::error, "Why the peer's thread stopped by itself ('' while it runs).");
  p.def("state_hash", [](PyPeer& self) { return self.with([](Peer& q) { return q.state_hash(); }); },
        "A hash of the session's state now: peers at the same step have the same.");
  p.def("converged", [](PyPeer& self) { return self.with([](Peer& q) { return q.converged(); }); },
        "True when every peer known reported this peer's hash for the latest step all reported.");
  p.def("peers", [](PyPeer& self) {
          const std::vector<PeerInfo> all = self.with([](Peer& q) { return q.peers(); });
          py::list out;
          for (const PeerInfo& i : all) out.append(peer_info(i));
          return out;
        },
        "The peers known (this one first): id, name, self, sequencer, joined, step and presence "
        "(pointer, buttons, eye, target, tool).");
  p.def("leases", [](PyPeer& self) {
          const std::vector<LeaseInfo> all = self.with([](Peer& q) { return q.leases(); });
          py::list out;
          for (const LeaseInfo& l : all) {
            py::dict d;
            d["holder"] = l.holder;
            d["garment"] = l.garment;
            d["vertices"] = l.vertices;
            d["expires"] = l.expires;
            out.append(d);
          }
          return out;
        },
        "The cloth leased now: holder (a peer id), garment, vertices and the step the lease ends at.");
  p.def("refusals", [](PyPeer& self) {
          const std::vector<PeerRefusal> all = self.with([](Peer& q) { return q.refusals(); });
          py::list out;
          for (const PeerRefusal& r : all) out.append(py::make_tuple(r.step, r.reason));
          return out;
        },
        "This peer's user's events that were refused, as (step, reason).");
  p.def("divergences", [](PyPeer& self) {
          const std::vector<PeerDivergence> all = self.with([](Peer& q) { return q.divergences(); });
          py::list out;
          for (const PeerDivergence& d : all) {
            py::dict e;
            e["step"] = d.step;
            e["own"] = d.own;
            e["reference"] = d.reference;
            e["reference_peer"] = d.reference_peer;
            out.append(e);
          }
          return out;
        },
        "Disagreements found (and healed): step, own and reference hashes, the peer compared with.");
  p.def("stats", [](PyPeer& self) {
          const PeerStats s = self.with([](Peer& q) { return q.stats(); });
          py::dict d;
          d["sent"] = s.sent;
          d["received"] = s.received;
          d["bytes_sent"] = s.bytes_sent;
          d["bytes_received"] = s.bytes_received;
          d["dropped"] = s.dropped;
          d["nacks_sent"] = s.nacks_sent;
          d["resent"] = s.resent;
          d["chunks_asked"] = s.chunks_asked;
          d["chunks_resent"] = s.chunks_resent;
          d["orders_applied"] = s.orders_applied;
          d["stalls"] = s.stalls;
          d["checkpoints"] = s.checkpoints;
          d["heals"] = s.heals;
          d["elections"] = s.elections;
          return d;
        },
        "The network's figures: messages and bytes, drops by reason, NACKs, resends, heals, elections.");
  p.def("set_presence",
        [](PyPeer& self, py::object pointer, std::uint32_t buttons, py::object eye, py::object target,
           const std::string& tool) {
          PeerPresence pr;
          if (!pointer.is_none()) pr.pointer = to_vec3(pointer, "pointer");
          if (!eye.is_none()) pr.eye = to_vec3(eye, "eye");
          if (!target.is_none()) pr.target = to_vec3(target, "target");
          pr.buttons = buttons;
          pr.tool = tool;
          self.with([&](Peer& q) { q.set_presence(pr); });
        },
        py::kw_only(), py::arg("pointer") = py::none(), py::arg("buttons") = 0, py::arg("eye") = py::none(),
        py::arg("target") = py::none(), py::arg("tool") = "",
        "What the others see of this user: the pen's point and buttons, the viewpoint, the tool.");
  p.def("lease",
        [](PyPeer& self, std::size_t garment, py::object center, double radius, double seconds) {
          const Vec3 c = to_vec3(center, "center");
          self.with([&](Peer& q) { q.lease(garment, c, radius, seconds); });
        },
        py::arg("garment"), py::arg("center"), py::arg("radius"), py::arg("seconds"),
        "Asks for the cloth within `radius` metres of `center` for `seconds` of simulated time; granted "
        "(or refused, see refusals()) in the shared order.");
  p.def("release", [](PyPeer& self) { self.with([](Peer& q) { q.release(); }); },
        "Lets go of every lease this peer's user holds.");
  p.def("wait_joined", [](PyPeer& self, double timeout) { return self.wait([](Peer& q) { return q.joined(); }, timeout); },
        py::arg("timeout") = 10.0, "Waits until this peer has the shared state; False at the timeout.");
  p.def("wait_step",
        [](PyPeer& self, std::uint64_t step, double timeout) {
          const Session& s = *self.session();
          return self.wait([&](Peer&) { return s.steps() >= step; }, timeout);
        },
        py::arg("step"), py::arg("timeout") = 10.0, "Waits until the shared clock reaches `step`; False at the timeout.");
  p.def("wait_converged",
        [](PyPeer& self, double timeout) {
          return self.wait([](Peer& q) { return q.joined() && q.pending() == 0 && q.converged(); }, timeout);
        },
        py::arg("timeout") = 10.0,
        "Waits until this peer's proposals are applied and every peer reported its state hash; False at the timeout.");
  p.def("close", &PyPeer::close, "Leaves (the others free this peer's leases at once); the session is its users' again.");
  p.def("__enter__", [](std::shared_ptr<PyPeer> self) { return self; });
  p.def("__exit__", [](PyPeer& self, py::args) { self.close(); });
  p.def("__repr__", [](PyPeer& self) {
    if (self.closed()) return std::string("<kiji.Peer closed>");
    return self.with([](Peer& q) {
      return "<kiji.Peer " + q.options().name + " id " + std::to_string(q.id()) + (q.joined() ? ", joined" : ", joining") +
             (q.is_sequencer() ? ", sequencer" : "") + ">";
    });
  });
  m.def("session_state_hash", [](const SessionPtr& s) {
          SessionGuard lock(*s);
          return session_state_hash(*s);
        },
        py::arg("session"), "The hash of a session's state that peers compare.");
}

}  // namespace kiji::python
