// A simulated network for many peers in one process, deterministic from a seed: each message sent
// reaches every other peer after a random delay, or is lost, or arrives twice; peers can crash.
// The tests drive it in virtual time, a millisecond a tick, so every run of a seed is the same.
// SimParts puts the parts a peer is made of (core/src/net/) on it, each part's tests their own.
#pragma once

#include "kiji/peer.h"
#include "net/peer_core.h"
#include "net/peer_wire.h"

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <random>
#include <string>
#include <vector>

namespace kiji::test {

class SimNetwork {
 public:
  struct Faults {
    double loss = 0;        // chance a message to a peer is lost
    double duplicate = 0;   // chance it arrives twice
    double min_delay = 0.0002, max_delay = 0.002;  // seconds: different delays reorder messages
  };

  SimNetwork(std::uint64_t seed, Faults faults) : rng_(seed), faults_(faults) {}

  class Port : public PeerTransport {
   public:
    Port(SimNetwork& net, int node) : net_(net), node_(node) {}
    void send(const std::string& bytes) override { net_.send(node_, bytes); }

   private:
    SimNetwork& net_;
    int node_;
  };

  int add_node() {
    ports_.push_back(std::make_unique<Port>(*this, static_cast<int>(ports_.size())));
    alive_.push_back(true);
    return static_cast<int>(ports_.size()) - 1;
  }
  Port& port(int node) { return *ports_[node]; }
  void crash(int node) { alive_[node] = false; }
  bool alive(int node) const { return alive_[node]; }
  double now() const { return now_; }
  void set_now(double t) { now_ = t; }

  // Hands each message due by now to deliver(node, bytes), in the order they fall due.
  void deliver(const std::function<void(int, const std::string&)>& to) {
    while (!queue_.empty() && queue_.begin()->first.first <= now_) {
      auto it = queue_.begin();
      const auto [node, bytes] = it->second;
      queue_.erase(it);
      if (alive_[node]) to(node, bytes);
    }
  }

  // Every message ever sent, for tests that replay or forge them.
  const std::vector<std::string>& sent() const { return sent_; }
  std::uint64_t lost() const { return lost_; }

 private:
  void send(int from, const std::string& bytes) {
    if (!alive_[from]) return;
    sent_.push_back(bytes);
    std::uniform_real_distribution<double> u(0, 1);
    for (int to = 0; to < static_cast<int>(ports_.size()); ++to) {
      if (to == from) continue;
      if (u(rng_) < faults_.loss) {
        ++lost_;
        continue;
      }
      const int copies = u(rng_) < faults_.duplicate ? 2 : 1;
      for (int c = 0; c < copies; ++c) {
        const double delay = faults_.min_delay + u(rng_) * (faults_.max_delay - faults_.min_delay);
        queue_.emplace(std::make_pair(now_ + delay, serial_++), std::make_pair(to, bytes));
      }
    }
  }

  std::mt19937_64 rng_;
  Faults faults_;
  double now_ = 0;
  std::uint64_t serial_ = 0, lost_ = 0;
  std::vector<std::unique_ptr<Port>> ports_;
  std::vector<bool> alive_;
  std::map<std::pair<double, std::uint64_t>, std::pair<int, std::string>> queue_;
  std::vector<std::string> sent_;
};

// The parts of peers (core/src/net/) on the simulated network, without a Peer around them: each
// node's PeerCore sends through a PeerWire as a Peer does (sealed with the session's key, under the
// node's epoch), and each message that arrives is opened and handed to the node's handler. Time
// moves a millisecond at a time; each node's tick runs after the messages due have arrived.
class SimParts {
 public:
  struct Node {
    detail::PeerCore core;
    std::unique_ptr<detail::PeerWire> wire;
    std::function<std::uint64_t()> epoch;  // its messages' epoch (unset: 0)
    std::function<void(const detail::PeerEnvelope&)> receive;
    std::function<void()> tick;
  };

  SimParts(std::uint64_t seed, SimNetwork::Faults faults, int n, PeerOptions base = {}) : net_(seed, faults) {
    base.key = "a shared secret for the tests, 32 bytes or so";
    for (int i = 0; i < n; ++i) {
      const int node = net_.add_node();
      auto m = std::make_unique<Node>();
      m->core.id = static_cast<std::uint32_t>(100 + i);
      m->core.opt = base;
      m->core.opt.name = "peer" + std::to_string(i);
      m->wire = std::make_unique<detail::PeerWire>(base.key, m->core.id);
      Node* self = m.get();
      m->core.send = [this, self, node](std::uint8_t type, const std::string& body) {
        ++self->core.stats.sent;
        net_.port(node).send(self->wire->seal(type, self->epoch ? self->epoch() : 0, body));
      };
      nodes_.push_back(std::move(m));
    }
  }

  Node& operator[](int i) { return *nodes_[i]; }
  detail::PeerCore& core(int i) { return nodes_[i]->core; }
  SimNetwork& net() { return net_; }
  double now() const { return net_.now(); }

  void run_until(double t, const std::function<void()>& each_ms = {}) {
    while (net_.now() < t - 1e-9) step(each_ms);
  }
  // Runs until `done` (checked each millisecond), for at most `limit` seconds more; true if done.
  bool run_while_not(const std::function<bool()>& done, double limit) {
    const double end = net_.now() + limit;
    while (!done()) {
      if (net_.now() >= end - 1e-9) return false;
      step({});
    }
    return true;
  }

 private:
  void step(const std::function<void()>& each_ms) {
    net_.set_now(net_.now() + 0.001);
    for (auto& n : nodes_) n->core.now = net_.now();
    net_.deliver([&](int node, const std::string& bytes) {
      Node& n = *nodes_[node];
      ++n.core.stats.received;
      detail::PeerEnvelope env;
      if (n.wire->open(bytes, env) == detail::WireVerdict::Ok && n.receive) n.receive(env);
    });
    for (int i = 0; i < static_cast<int>(nodes_.size()); ++i)
      if (net_.alive(i) && nodes_[i]->tick) nodes_[i]->tick();
    if (each_ms) each_ms();
  }

  SimNetwork net_;
  std::vector<std::unique_ptr<Node>> nodes_;
};

}  // namespace kiji::test
