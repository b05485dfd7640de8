#pragma once
// The lane sets of lib/core/lanes.hpp this CPU can run, SSE first: tests run a kernel on each and compare the
// bits (laneSet() picks only the widest).
#include <vector>

#include "core/lanes.hpp"

namespace swarmsim_test {

inline std::vector<swarmsim::LaneSet> laneSetsOfThisCpu() {
  std::vector<swarmsim::LaneSet> sets = {swarmsim::LaneSet::kSse};
#if SWARMSIM_X86_LANES
  if (__builtin_cpu_supports("avx")) sets.push_back(swarmsim::LaneSet::kAvx);
  if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("popcnt")) sets.push_back(swarmsim::LaneSet::kAvx2);
  if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("avx512f")) sets.push_back(swarmsim::LaneSet::kAvx512);
#endif
  return sets;
}

}  // namespace swarmsim_test
