// A small pool of worker threads for the solver's data-parallel loops, private to libkiji.
//
// for_range(n, grain, fn) calls fn(begin, end) on disjoint chunks covering [0, n), on the pool's
// workers and on the calling thread, and returns when every chunk is done. The chunks are of
// `grain` items or more, about 16 a thread: claimed one at a time, they let a thread that drew
// cheap items take more (a loop's items differ in cost: a vertex's contacts, a region's blocks).
// The loops it runs are the ones whose iterations write disjoint data (constraints of one colour,
// one vertex each), so the result is the same, bit for bit, whatever the number of threads.
//
// Workers spin briefly between calls (a substep issues a few dozen back to back) and then sleep,
// so an idle solver costs no CPU. One parallel loop runs at a time in the process: a second
// caller (another garment's solver on another thread, or a loop within a chunk of one) runs its
// loop serially instead of waiting.
// KIJI_THREADS=N in the environment sets the number of threads (1 = serial); the default is the
// number of hardware threads, at most 8.
//
// An exception thrown by fn in any chunk reaches the caller of the loop: the first one thrown, once
// every chunk is finished or abandoned (the chunks not yet started when it was thrown are skipped).
// The pool stays usable.
#pragma once

#include <algorithm>
#include <cstddef>
#include <type_traits>

namespace kiji::parallel {

using RangeFn = void (*)(void* context, int begin, int end);

int thread_count();
void for_range(int n, int grain, void* context, RangeFn fn);
void for_each(int n, void* context, RangeFn fn);

// Seconds the calling thread has spent in loops large enough to be shared (more items than their
// grain), since it started, whatever the number of threads: with KIJI_THREADS=1 the share of a
// step outside them is the part that more cores cannot shorten.
double shared_seconds();

// From now on every loop runs on the calling thread: for a forked child process, which has only the
// thread that forked it.
void run_serially();

// The first item of piece `piece` of `pieces` contiguous, near-equal pieces of [0, n) (piece
// `pieces` gives n): pieces of work whose outputs are joined in order, the same for any thread count.
inline int piece_begin(int n, int piece, int pieces) {
  return static_cast<int>(static_cast<long long>(n) * piece / pieces);
}

// How many pieces to cut [0, n) into for piece_begin: about `grain` items or more a piece, at
// most four a thread (for the threads to end together), at least one.
inline int piece_count(int n, int grain) { return std::clamp(n / grain, 1, 4 * thread_count()); }

template <typename F>
void for_range(int n, int grain, F&& f) {
  if (n <= 0) return;
  if (n <= grain) {
    f(0, n);
    return;
  }
  for_range(n, grain, static_cast<void*>(&f),
            [](void* c, int b, int e) { (*static_cast<std::remove_reference_t<F>*>(c))(b, e); });
}

// Calls f(k) for each k in [0, n), each k a task of its own, claimed in order: for a few tasks of
// uneven sizes (the cloth's blocks under a local region), put the largest first and the threads
// end together.
template <typename F>
void for_each(int n, F&& f) {
  if (n <= 0) return;
  if (n == 1) {
    f(0);
    return;
  }
  for_each(n, static_cast<void*>(&f), [](void* c, int b, int e) {
    for (int k = b; k < e; ++k) (*static_cast<std::remove_reference_t<F>*>(c))(k);
  });
}

}  // namespace kiji::parallel
