#pragma once
// The one place parallel loops go through. Every body must write only to its
// own index, so results do not depend on the number of threads.
#include <cstddef>

#include <omp.h>

namespace swarmsim {

template <typename F>
void parallelFor(std::size_t n, F&& body) {
  const auto count = static_cast<long long>(n);
#pragma omp parallel for schedule(static)
  for (long long i = 0; i < count; ++i) body(static_cast<std::size_t>(i));
}

// number of threads parallelFor will use
inline int threadCount() { return omp_get_max_threads(); }
inline void setThreadCount(int n) {
  if (n > 0) omp_set_num_threads(n);
}

}  // namespace swarmsim
