#include "kiji/peer_runner.h"

#include "kiji/error.h"
#include "lcm_bus.h"

#include <chrono>
#include <exception>

namespace kiji {

namespace {
double seconds_now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}
// How long the thread waits for a message before it ticks anyway: the engine's timers and the
// shared clock need ticks much finer than a frame, and waiting longer would delay their steps.
constexpr int kWaitMs = 1;
}  // namespace

class PeerRunner::Transport : public PeerTransport {
 public:
  explicit Transport(detail::LcmBus& bus) : bus_(bus) {}
  void send(const std::string& bytes) override { bus_.publish(bytes); }

 private:
  detail::LcmBus& bus_;
};

PeerRunner::PeerRunner(Session& session, PeerOptions options, PeerNetwork network) : session_(session) {
  options.validate();
  if (network.channel.empty()) throw InputError("a peer network needs a channel name");
  bus_ = std::make_unique<detail::LcmBus>(network.url, network.channel);
  transport_ = std::make_unique<Transport>(*bus_);
  {
    std::lock_guard<std::recursive_mutex> lock(session_.mutex());
    peer_ = std::make_unique<Peer>(session_, *transport_, std::move(options));
  }
  running_ = true;
  thread_ = std::thread([this] { run(); });
}

PeerRunner::~PeerRunner() { stop(); }

void PeerRunner::run() {
  try {
    while (!stop_.load()) {
      std::vector<std::string> messages = bus_->receive(kWaitMs);
      std::lock_guard<std::recursive_mutex> lock(session_.mutex());
      const double now = seconds_now();
      for (const std::string& m : messages) peer_->receive(m, now);
      peer_->tick(now);
    }
  } catch (const std::exception& e) {
    // A step the solver refuses, or the network failing: the peer stops here, the session is kept.
    std::lock_guard<std::mutex> lock(error_mutex_);
    error_ = e.what();
  }
  running_ = false;
}

void PeerRunner::stop() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  if (peer_) {
    std::lock_guard<std::recursive_mutex> lock(session_.mutex());
    peer_->leave(seconds_now());
    peer_.reset();
  }
}

std::string PeerRunner::error() const {
  std::lock_guard<std::mutex> lock(error_mutex_);
  return error_;
}

}  // namespace kiji
