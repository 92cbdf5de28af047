#include "kiji/peer_runner.h"

#include "kiji/error.h"
#include "kiji/session_file.h"
#include "net/lcm_bus.h"

#include <chrono>
#include <condition_variable>
#include <deque>
#include <exception>
#include <random>

namespace kiji {

namespace {
double seconds_now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}
// How long the thread waits for a message before it ticks anyway: the engine's timers and the
// shared clock need ticks much finer than a frame, and waiting longer would delay their steps.
constexpr int kWaitMs = 1;
// After holding the session this long, the thread lets go of it this long.
constexpr double kLongHoldSeconds = 0.01;
constexpr int kYieldMs = 2;
}  // namespace

// Sends from a thread of its own, paced: a snapshot's thousands of chunks leave while the peer
// steps (a large garment's step is longer than a frame) without overflowing the receivers' queues.
class PeerRunner::Transport : public PeerTransport {
 public:
  explicit Transport(detail::LcmBus& bus) : bus_(bus), thread_([this] { run(); }) {}
  ~Transport() override {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      closing_ = true;
    }
    wake_.notify_one();
    thread_.join();  // what was queued (a goodbye) still goes out
  }
  void send(const std::string& bytes) override {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      queue_.push_back(bytes);
    }
    wake_.notify_one();
  }
  void keep_alive(std::vector<std::string> sealed, double every) override {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      alive_.assign(std::make_move_iterator(sealed.begin()), std::make_move_iterator(sealed.end()));
      every_ = std::chrono::duration<double>(every);
      next_alive_ = Clock::now() + std::chrono::duration_cast<Clock::duration>(every_);
    }
    wake_.notify_one();
  }

 private:
  using Clock = std::chrono::steady_clock;
  void run() {
    std::deque<std::string> batch;
    for (;;) {
      {
        std::unique_lock<std::mutex> lock(mutex_);
        // Queued messages at once; a keep-alive when it is due (the peer's thread is in a long step).
        for (;;) {
          if (closing_ || !queue_.empty()) break;
          if (alive_.empty()) {
            wake_.wait(lock);
          } else if (Clock::now() >= next_alive_) {
            queue_.push_back(std::move(alive_.front()));
            alive_.pop_front();
            next_alive_ += std::chrono::duration_cast<Clock::duration>(every_);
          } else {
            wake_.wait_until(lock, next_alive_);
          }
        }
        if (queue_.empty()) return;
        batch.swap(queue_);
      }
      std::size_t sent = 0;
      for (const std::string& m : batch) {
        bus_.publish(m);
        // A burst on loopback was delivered whole when paced about 10 microseconds a message.
        if (++sent % kPaceEvery == 0) std::this_thread::sleep_for(std::chrono::microseconds(kPaceMicroseconds));
      }
      batch.clear();
    }
  }
  static constexpr std::size_t kPaceEvery = 32;
  static constexpr int kPaceMicroseconds = 300;
  detail::LcmBus& bus_;
  std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<std::string> queue_;
  std::deque<std::string> alive_;  // keep-alives for a long step, one due at next_alive_
  std::chrono::duration<double> every_{0};
  Clock::time_point next_alive_;
  bool closing_ = false;
  std::thread thread_;
};

PeerRunner::PeerRunner(Session& session, PeerOptions options, PeerNetwork network) : session_(session) {
  options.validate();
  if (!options.clock) options.clock = seconds_now;
  if (network.channel.empty()) throw InputError("a peer network needs a channel name");
  if (!(network.loss >= 0 && network.loss <= 0.9))
    throw InputError("a peer network's loss must be a share between 0 and 0.9, not " + std::to_string(network.loss));
  loss_ = network.loss;
  bus_ = std::make_unique<detail::LcmBus>(network.url, network.channel);
  if (!network.play_channel.empty()) bus_->listen_also(network.play_channel);
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
  std::mt19937_64 random(std::random_device{}());
  std::uniform_real_distribution<double> uniform(0, 1);
  try {
    while (!stop_.load()) {
      std::vector<std::string> messages = bus_->receive(kWaitMs);
      double held = 0;
      {
        std::lock_guard<std::recursive_mutex> lock(session_.mutex());
        const double now = seconds_now();
        for (const std::string& m : messages)
          if (loss_ == 0 || uniform(random) >= loss_) peer_->receive(m, now);
        for (const std::string& record : bus_->side_messages()) play(record);
        peer_->tick(now);
        joined_ = peer_->joined();
        held = seconds_now() - now;
      }
      // A mutex hands itself to no one: after a long step this thread would take the lock again
      // before a user waiting for it woke, and a user's change could wait for many steps.
      if (held > kLongHoldSeconds) std::this_thread::sleep_for(std::chrono::milliseconds(kYieldMs));
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

void PeerRunner::play(const std::string& record) {
  Operation op;
  std::string why;
  if (!decode_session_record(record, op, why)) {
  } else if (std::holds_alternative<op::Advance>(op.data) || std::holds_alternative<op::Checkpoint>(op.data)) {
    why = std::string("a recorded '") + operation_kind(op.data) + "' is the recording's own, not a change to share";
  } else if (!peer_->joined()) {
    why = "a recorded operation came before this peer had the shared session";
  } else {
    op.step = session_.steps();
    op.user = 0;
    // The recording's clock is not the shared one: its events happen now.
    if (auto* input = std::get_if<op::ToolInput>(&op.data)) input->event.time = session_.time();
    peer_->propose(op);
    ++played_;
    return;
  }
  ++play_dropped_;
  std::lock_guard<std::mutex> lock(error_mutex_);
  play_error_ = why;
}

std::string PeerRunner::play_error() const {
  std::lock_guard<std::mutex> lock(error_mutex_);
  return play_error_;
}

std::string PeerRunner::error() const {
  std::lock_guard<std::mutex> lock(error_mutex_);
  return error_;
}

}  // namespace kiji
