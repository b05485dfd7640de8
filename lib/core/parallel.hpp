#pragma once
// The one place parallel loops go through. Every body must write only to its
// own index, so results do not depend on the number of threads.
#include <algorithm>
#include <cstddef>

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
