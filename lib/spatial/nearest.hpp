#pragma once
// K-nearest-neighbour search on a UniformGrid (the shape model's F_int,
// docs/models/shape.md; tests/knn_test.cpp checks it against nanoflann).
//
// A neighbour is one 64-bit key: its squared distance (a non-negative float,
// whose bits order as the float does) in the high half, its sorted position in
// the grid in the low half, so keys sort by distance, ties by position.
//
// blockKeys(block, k, r, keys): the keys of the block's points j != k within r
// of sorted point k, from the squared distances its last filter left in d2 (so
// r should not exceed grid.coveredRadius(block, k's position), or points are
// missed).
//
// nearestKeys(grid, k, K, r, hint, rMax, keys): `keys` holds the keys of every
// point j != k within r of sorted point k (and within rMax), for example from
// blockKeys. When they are fewer than K and r < rMax it searches again: at the
// hint when that is beyond r (a radius expected to hold K, such as the K-th
// distance of the last step, or a bound), else at 2 r, and doubles the radius
// up to rMax until K are found. It leaves the min(K, found) nearest, ascending,
// in keys[0, m) and returns m. The result depends neither on r nor on hint
// (only on the points), so a caller may pass any radius hint.
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <vector>

#include "spatial/uniform_grid.hpp"

namespace swarmsim {

inline std::uint64_t neighbourKey(float d2, std::uint32_t j) {
  std::uint32_t bits;
  std::memcpy(&bits, &d2, sizeof bits);
  return (static_cast<std::uint64_t>(bits) << 32) | j;
}
inline float keyDistance2(std::uint64_t key) {
  const auto bits = static_cast<std::uint32_t>(key >> 32);
  float d2;
  std::memcpy(&d2, &bits, sizeof d2);
  return d2;
}
inline std::uint32_t keyIndex(std::uint64_t key) { return static_cast<std::uint32_t>(key); }

inline std::size_t blockKeys(const CellBlock& block, std::uint32_t k, float r, std::vector<std::uint64_t>& keys) {
  if (keys.size() < block.size) keys.resize(block.size + block.size / 2 + 16);  // grows rarely
  const float r2 = r * r;
  std::uint64_t* out = keys.data();
  const float* d2 = block.d2.data();
  const std::uint32_t* index = block.index.data();
  std::size_t found = 0;
  for (std::size_t b = 0; b < block.size; ++b) {  // branch-free compaction
    out[found] = neighbourKey(d2[b], index[b]);
    found += static_cast<std::size_t>(d2[b] <= r2) & static_cast<std::size_t>(index[b] != k);
  }
  keys.resize(found);
  return found;
}

inline std::size_t nearestKeys(const UniformGrid& grid, std::uint32_t k, std::size_t K, float r, float hint, float rMax,
                               std::vector<std::uint64_t>& keys) {
  const float qx = grid.sortedX()[k], qy = grid.sortedY()[k], qz = grid.sortedZ()[k];
  const float rMax2 = rMax * rMax;
  if (keys.size() < K && r < rMax) {
    // the caller's pass covered r: start beyond it, at the hint if that is farther
    r = std::min(rMax, hint > r ? hint : 2.0f * r);
    for (;;) {
      keys.clear();
      grid.forEachNeighbor(qx, qy, qz, r, [&](std::uint32_t j, float, float, float, float d2) {
        if (j != k && d2 <= rMax2) keys.push_back(neighbourKey(d2, j));
      });
      if (keys.size() >= K || r >= rMax) break;
      r = std::min(2.0f * r, rMax);
    }
  }
  if (keys.size() > K) std::nth_element(keys.begin(), keys.begin() + static_cast<std::ptrdiff_t>(K), keys.end());
  const std::size_t m = std::min(K, keys.size());
  std::sort(keys.begin(), keys.begin() + static_cast<std::ptrdiff_t>(m));
  return m;
}

}  // namespace swarmsim
