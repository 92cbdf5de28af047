// A simulated network for many peers in one process, deterministic from a seed: each message sent
// reaches every other peer after a random delay, or is lost, or arrives twice; peers can crash.
// The tests drive it in virtual time, a millisecond a tick, so every run of a seed is the same.
#pragma once

#include "kiji/peer.h"

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

}  // namespace kiji::test
