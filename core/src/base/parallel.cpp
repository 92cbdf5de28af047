// The solver's worker pool: see parallel.h.
#include "base/parallel.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <cstdlib>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#define KIJI_PAUSE() _mm_pause()
#else
#define KIJI_PAUSE() std::this_thread::yield()
#endif

namespace kiji::parallel {

namespace {

// The job's ticket packs, in one atomic word, the job's generation (24 bits), its number of chunks
// (20 bits) and the next chunk to claim (20 bits): a worker claims a chunk with one compare-and-
// swap that also checks it is still the job it woke up for.
constexpr std::uint64_t kChunkBits = 20, kChunkMask = (std::uint64_t(1) << kChunkBits) - 1;
constexpr int kMaxChunks = static_cast<int>(kChunkMask);

std::uint64_t pack(std::uint64_t gen, std::uint64_t chunks, std::uint64_t next) {
  return (gen << (2 * kChunkBits)) | (chunks << kChunkBits) | next;
}
std::uint64_t gen_of(std::uint64_t t) { return t >> (2 * kChunkBits); }
std::uint64_t chunks_of(std::uint64_t t) { return (t >> kChunkBits) & kChunkMask; }
std::uint64_t next_of(std::uint64_t t) { return t & kChunkMask; }

int configured_threads() {
  if (const char* env = std::getenv("KIJI_THREADS")) {
    const int n = std::atoi(env);
    if (n >= 1) return std::min(n, 64);
  }
  const unsigned hw = std::thread::hardware_concurrency();
  return static_cast<int>(std::clamp(hw, 1u, 8u));
}

// Whether this thread is running a chunk of a shared loop.
thread_local bool in_chunk = false;

class Pool {
 public:
  explicit Pool(int threads) : threads_(threads) {
    for (int k = 1; k < threads; ++k) workers_.emplace_back([this] { work(); });
  }
  ~Pool() {
    {
      std::lock_guard<std::mutex> lock(m_);
      stop_ = true;
    }
    cv_.notify_all();
    for (auto& t : workers_) t.join();
  }
  int threads() const { return threads_; }

  // Runs fn over [0, n) in chunks of `grain` items or more (of exactly `grain` when `exact`).
  // Serially, an exception leaves fn for the caller as it would any loop; shared, the first one
  // thrown is kept, the chunks not yet claimed are skipped, and it is thrown here once every chunk
  // is accounted for (the workers never see it leave their loop).
  void run(int n, int grain, void* ctx, RangeFn fn, bool exact = false) {
    if (in_chunk) {  // a loop within a chunk of another (the caller may hold region_ itself)
      fn(ctx, 0, n);
      return;
    }
    std::unique_lock<std::mutex> region(region_, std::try_to_lock);
    if (!region.owns_lock() || workers_.empty()) {
      fn(ctx, 0, n);
      return;
    }
    int chunk = exact ? grain : std::max(grain, (n + 16 * threads_ - 1) / (16 * threads_));
    chunk = std::max(chunk, (n + kMaxChunks - 1) / kMaxChunks);
    const int chunks = (n + chunk - 1) / chunk;
    ctx_ = ctx;
    fn_ = fn;
    n_ = n;
    chunk_ = chunk;
    failed_.store(false, std::memory_order_relaxed);
    error_ = nullptr;
    done_.store(0, std::memory_order_relaxed);
    const std::uint64_t gen = (gen_of(ticket_.load(std::memory_order_relaxed)) + 1) & 0xffffff;
    ticket_.store(pack(gen, chunks, 0), std::memory_order_release);
    if (sleepers_.load(std::memory_order_acquire) > 0) {
      std::lock_guard<std::mutex> lock(m_);
      cv_.notify_all();
    }
    claim(gen);
    while (done_.load(std::memory_order_acquire) < chunks) KIJI_PAUSE();
    if (failed_.load(std::memory_order_acquire)) {
      std::exception_ptr error = std::move(error_);
      error_ = nullptr;
      std::rethrow_exception(error);
    }
  }

 private:
  // Claims and runs chunks of job `gen` until none is left.
  void claim(std::uint64_t gen) {
    std::uint64_t t = ticket_.load(std::memory_order_acquire);
    for (;;) {
      if (gen_of(t) != gen || next_of(t) >= chunks_of(t)) return;
      if (!ticket_.compare_exchange_weak(t, t + 1, std::memory_order_acq_rel, std::memory_order_acquire)) continue;
      const int c = static_cast<int>(next_of(t));
      const int b = c * chunk_;
      if (!failed_.load(std::memory_order_acquire)) {
        try {
          in_chunk = true;
          fn_(ctx_, b, std::min(n_, b + chunk_));
          in_chunk = false;
        } catch (...) {
          in_chunk = false;
          std::lock_guard<std::mutex> lock(error_m_);
          if (!error_) error_ = std::current_exception();
          failed_.store(true, std::memory_order_release);
        }
      }
      done_.fetch_add(1, std::memory_order_acq_rel);
      t = ticket_.load(std::memory_order_acquire);
    }
  }

  void work() {
    std::uint64_t seen = gen_of(ticket_.load(std::memory_order_acquire));
    for (;;) {
      // Spin a little for the next loop of the same substep, then sleep.
      const auto until = std::chrono::steady_clock::now() + std::chrono::microseconds(300);
      std::uint64_t t = ticket_.load(std::memory_order_acquire);
      for (int k = 0; gen_of(t) == seen; ++k) {
        if ((k & 63) == 63 && std::chrono::steady_clock::now() > until) break;
        KIJI_PAUSE();
        t = ticket_.load(std::memory_order_acquire);
      }
      if (gen_of(t) == seen) {
        std::unique_lock<std::mutex> lock(m_);
        sleepers_.fetch_add(1, std::memory_order_acq_rel);
        cv_.wait(lock, [&] { return stop_ || gen_of(ticket_.load(std::memory_order_acquire)) != seen; });
        sleepers_.fetch_sub(1, std::memory_order_acq_rel);
        if (stop_) return;
        t = ticket_.load(std::memory_order_acquire);
      }
      seen = gen_of(t);
      claim(seen);
    }
  }

  const int threads_;
  std::vector<std::thread> workers_;
  std::mutex region_;
  std::mutex m_;
  std::condition_variable cv_;
  bool stop_ = false;
  std::atomic<int> sleepers_{0};
  std::atomic<std::uint64_t> ticket_{0};
  std::atomic<int> done_{0};
  // The first exception a chunk threw in the loop running now (see run).
  std::atomic<bool> failed_{false};
  std::mutex error_m_;
  std::exception_ptr error_;
  void* ctx_ = nullptr;
  RangeFn fn_ = nullptr;
  int n_ = 0, chunk_ = 1;
};

Pool& pool() {
  static Pool p(configured_threads());
  return p;
}

thread_local double shared_total = 0;
std::atomic<bool> serial_only{false};

// Counts the loop's time on the calling thread, however it ends.
class SharedClock {
 public:
  SharedClock() : start_(std::chrono::steady_clock::now()) {}
  ~SharedClock() { shared_total += std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count(); }
  SharedClock(const SharedClock&) = delete;
  SharedClock& operator=(const SharedClock&) = delete;

 private:
  std::chrono::steady_clock::time_point start_;
};

}  // namespace

int thread_count() {
  static const int n = configured_threads();
  return n;
}

double shared_seconds() { return shared_total; }

void run_serially() { serial_only.store(true); }

void for_range(int n, int grain, void* context, RangeFn fn) {
  if (n <= 0) return;
  SharedClock clock;
  if (thread_count() <= 1 || serial_only.load(std::memory_order_relaxed)) {
    fn(context, 0, n);
    return;
  }
  pool().run(n, std::max(grain, 1), context, fn);
}

void for_each(int n, void* context, RangeFn fn) {
  if (n <= 0) return;
  SharedClock clock;
  if (thread_count() <= 1 || serial_only.load(std::memory_order_relaxed)) {
    fn(context, 0, n);
    return;
  }
  pool().run(n, 1, context, fn, true);
}

}  // namespace kiji::parallel
