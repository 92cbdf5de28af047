// The solver's worker pool: loops shared between threads give the serial loop's result, and an
// exception thrown in any piece reaches the loop's caller with the pool still usable.
#include "base/parallel.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <numeric>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

using namespace kiji;

// Four threads whatever the machine, so that the pieces run on workers (set before the pool's
// first use, which reads it once).
const bool kThreadsSet = (setenv("KIJI_THREADS", "4", 1), true);

long long sum_of_squares(int n) {
  std::vector<long long> out(n, 0);
  parallel::for_range(n, 16, [&](int b, int e) {
    for (int i = b; i < e; ++i) out[i] = static_cast<long long>(i) * i;
  });
  return std::accumulate(out.begin(), out.end(), 0LL);
}

TEST(Parallel, EveryItemIsDoneOnceOnTheThreadsAsked) {
  ASSERT_TRUE(kThreadsSet);
  EXPECT_EQ(parallel::thread_count(), 4);
  std::vector<std::atomic<int>> seen(100000);
  parallel::for_range(100000, 64, [&](int b, int e) {
    for (int i = b; i < e; ++i) ++seen[i];
  });
  for (const auto& s : seen) ASSERT_EQ(s.load(), 1);
  std::vector<std::atomic<int>> tasks(37);
  parallel::for_each(37, [&](int k) { ++tasks[k]; });
  for (const auto& t : tasks) ASSERT_EQ(t.load(), 1);
}

TEST(Parallel, AnExceptionInOnePieceReachesTheCallerAndThePoolGoesOn) {
  const int n = 1 << 16;
  for (int bad : {0, n / 2, n - 1}) {  // the caller's first piece, a worker's, the last one
    std::atomic<int> done{0};
    try {
      parallel::for_range(n, 64, [&](int b, int e) {
        for (int i = b; i < e; ++i) {
          if (i == bad) throw std::range_error("item " + std::to_string(i) + " is bad");
          ++done;
        }
      });
      FAIL() << "the exception of item " << bad << " did not reach the caller";
    } catch (const std::range_error& e) {
      EXPECT_EQ(std::string(e.what()), "item " + std::to_string(bad) + " is bad");
    }
    EXPECT_LT(done.load(), n);
    // The pool runs the next loops whole.
    const long long n2 = 5000;
    EXPECT_EQ(sum_of_squares(static_cast<int>(n2)), (n2 - 1) * n2 * (2 * n2 - 1) / 6);
  }
}

TEST(Parallel, OfSeveralExceptionsTheCallerGetsOneAndNoneIsLost) {
  // Every piece throws: one exception arrives, the process does not end, the pool goes on.
  for (int round = 0; round < 20; ++round) {
    EXPECT_THROW(parallel::for_range(4096, 16, [&](int, int) { throw std::runtime_error("every piece fails"); }),
                 std::runtime_error);
    EXPECT_THROW(parallel::for_each(9, [&](int k) {
                   if (k % 2) throw std::logic_error("odd task");
                 }),
                 std::logic_error);
  }
  EXPECT_EQ(sum_of_squares(1000), 332833500LL);
}

TEST(Parallel, AnExceptionInALoopNestedInAPieceReachesTheOuterCaller) {
  EXPECT_THROW(parallel::for_each(8,
                                  [&](int k) {
                                    parallel::for_range(1000, 10, [&](int b, int) {
                                      if (k == 5 && b == 0) throw std::invalid_argument("inner");
                                    });
                                  }),
               std::invalid_argument);
  EXPECT_EQ(sum_of_squares(1000), 332833500LL);
}

TEST(Parallel, LoopsWithinTasksDoEveryItemOnce) {
  // Two tasks side by side (a rebuild's long-range limits and collision structures), each with
  // loops of its own, which run on the task's thread: on the caller's as on a worker's.
  for (int round = 0; round < 50; ++round) {
    std::vector<std::atomic<int>> seen(2 * 5000);
    parallel::for_each(2, [&](int task) {
      for (int pass = 0; pass < 3; ++pass)
        parallel::for_range(5000, 16, [&](int b, int e) {
          for (int i = b; i < e; ++i) seen[task * 5000 + i] += pass == 1 ? 1 : 0;
        });
    });
    for (const auto& s : seen) ASSERT_EQ(s.load(), 1);
  }
  EXPECT_EQ(sum_of_squares(1000), 332833500LL);
}

TEST(Parallel, TheTimeInSharedLoopsIsCounted) {
  const double before = parallel::shared_seconds();
  // Atomic: every worker writes it, and it only keeps the sums from being optimised away.
  std::atomic<double> sink{0};
  parallel::for_range(1 << 20, 1024, [&](int b, int e) {
    double s = 0;
    for (int i = b; i < e; ++i) s += 1.0 / (1 + i);
    sink.store(sink.load(std::memory_order_relaxed) + s, std::memory_order_relaxed);
  });
  EXPECT_GT(parallel::shared_seconds(), before);
  // A loop too small to share is not counted: it runs on the caller alone, on any machine.
  const double after = parallel::shared_seconds();
  parallel::for_range(10, 64, [&](int, int) { sink.store(sink.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed); });
  EXPECT_EQ(parallel::shared_seconds(), after);
}

}  // namespace
