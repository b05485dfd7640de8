#pragma once
// The one place parallel loops go through. Every body must write only to its
// own index, so results do not depend on the number of threads.
#include <algorithm>
#include <atomic>
#include <cstddef>
#include <memory>

#include <omp.h>

namespace swarmsim {

// below this many indices a loop runs on the calling thread: waking the team
// costs more than it saves, and on a busy machine a barrier can stall
inline constexpr std::size_t kSerialBelow = 2048;

template <typename F>
void parallelFor(std::size_t n, F&& body) {
  if (n < kSerialBelow) {
    for (std::size_t i = 0; i < n; ++i) body(i);
    return;
  }
  const auto count = static_cast<long long>(n);
#pragma omp parallel for schedule(static)
  for (long long i = 0; i < count; ++i) body(static_cast<std::size_t>(i));
}

// as parallelFor, with dynamic scheduling in chunks (for uneven work per index)
template <typename F>
void parallelForDynamic(std::size_t n, std::size_t chunk, F&& body) {
  const auto count = static_cast<long long>(n);
  const int c = static_cast<int>(chunk);
#pragma omp parallel for schedule(dynamic, c)
  for (long long i = 0; i < count; ++i) body(static_cast<std::size_t>(i));
}

// as parallelFor: each thread takes the indices of its own contiguous range in order, `chunk` at a time (the
// range libgomp's schedule(static) gives it, so it mostly reads what it wrote in the static loops before),
// and a thread that has finished its range goes on with what is left of the others', a chunk at a time:
// uneven work per index no longer leaves a thread waiting for the slowest range. body(a, b) takes the indices
// [a, b), at most `chunk` of them
template <typename F>
void parallelForBalancedChunks(std::size_t n, std::size_t chunk, F&& body) {
  chunk = std::max<std::size_t>(1, chunk);
  const int threads = omp_get_max_threads();
  if (n < kSerialBelow || threads < 2) {
    for (std::size_t a = 0; a < n; a += chunk) body(a, std::min(n, a + chunk));
    return;
  }
  struct alignas(64) Share {
    std::atomic<std::size_t> next;  // the first index not yet taken
    std::size_t end;
  };
  const auto t = static_cast<std::size_t>(threads);
  const std::unique_ptr<Share[]> ranges(new Share[t]);
  for (std::size_t r = 0; r < t; ++r) {  // schedule(static)'s split: the first n % t ranges one longer
    const std::size_t size = n / t, extra = n % t;
    const std::size_t begin = r * size + std::min(r, extra);
    ranges[r].next.store(begin, std::memory_order_relaxed);
    ranges[r].end = begin + size + (r < extra ? 1 : 0);
  }
#pragma omp parallel num_threads(threads)
  {
    const auto self = static_cast<std::size_t>(omp_get_thread_num());
    for (std::size_t v = 0; v < t; ++v) {
      Share& r = ranges[(self + v) % t];
      for (;;) {
        const std::size_t a = r.next.fetch_add(chunk, std::memory_order_relaxed);
        if (a >= r.end) break;
        body(a, std::min(r.end, a + chunk));
      }
    }
  }
}

// parallelForBalancedChunks one index at a time: body(i)
template <typename F>
void parallelForBalanced(std::size_t n, std::size_t chunk, F&& body) {
  parallelForBalancedChunks(n, chunk, [&](std::size_t a, std::size_t b) {
    for (std::size_t i = a; i < b; ++i) body(i);
  });
}

// A team of threads kept for a sequence of short loops, without a fork and a join for each (parallelTeam):
// every thread runs body(team), and every thread must reach each of the team's calls, in the same order.
struct Team {
  // as parallelForDynamic; then every thread waits for the others
  template <typename F>
  void forDynamic(std::size_t n, std::size_t chunk, F&& body) const {
    const auto count = static_cast<long long>(n);
    const int c = static_cast<int>(chunk);
#pragma omp for schedule(dynamic, c)
    for (long long i = 0; i < count; ++i) body(static_cast<std::size_t>(i));
  }
  // f on one thread while the others wait for it
  template <typename F>
  void serial(F&& f) const {
#pragma omp single
    f();
  }
};
template <typename F>
void parallelTeam(F&& body) {
#pragma omp parallel
  {
    const Team team;
    body(team);
  }
}

// Split [0, n) into one contiguous chunk per thread, in index order, and call
// body(begin, end, chunk) once per chunk (chunk < chunkCount(n)); for per-thread
// partial results combined afterwards in chunk order. Small n: one chunk.
inline int chunkCount(std::size_t n) { return n < kSerialBelow ? 1 : omp_get_max_threads(); }
template <typename F>
void parallelChunks(std::size_t n, F&& body) {
  const int chunks = chunkCount(n);
  const std::size_t size = (n + static_cast<std::size_t>(chunks) - 1) / static_cast<std::size_t>(chunks);
#pragma omp parallel for schedule(static, 1) num_threads(chunks) if (chunks > 1)
  for (int t = 0; t < chunks; ++t) {
    const std::size_t a = std::min(n, static_cast<std::size_t>(t) * size), b = std::min(n, a + size);
    body(a, b, t);
  }
}

// index of the calling thread inside a parallel loop (0 outside, and in loops
// run serially), for per-thread scratch
inline int threadIndex() { return omp_get_thread_num(); }

// number of threads parallelFor will use
inline int threadCount() { return omp_get_max_threads(); }
inline void setThreadCount(int n) {
  if (n > 0) omp_set_num_threads(n);
}

}  // namespace swarmsim
