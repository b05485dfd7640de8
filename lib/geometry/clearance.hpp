#pragma once
// Keeping points out of obstacles: the last word on every position a model
// writes, so no insect is ever inside an obstacle.
//
// apply(x) pushes x out along the gradient of the obstacles' signed distance
// (sampled trilinearly) until it is `radius` clear; a few projections settle
// corners. Cells so far from every obstacle that no point in them can need it
// are marked once, so far-away points cost one lookup (the distance is
// 1-Lipschitz, and trilinear corners lie within 1.5 cell diagonals).
#include <algorithm>
#include <cstdint>
#include <vector>

#include "core/lanes.hpp"
#include "core/vec.hpp"
#include "fields/grid3.hpp"

namespace swarmsim {

class ObstacleClearance {
 public:
  ObstacleClearance() = default;
  // `sdf`: signed distance to the obstacles (negative inside); `any`: whether
  // there are obstacles at all (without, apply is the identity)
  ObstacleClearance(Grid3<float> sdf, float radius, bool any);

  // whether apply(x) is x itself for certain (no obstacle, or x in a cell far from every one)
  bool leaves(const Vec3& x) const { return !any_ || far(x); }
  Vec3 apply(Vec3 x) const { return leaves(x) ? x : project(x); }
  // For m points in place (x[i], y[i], z[i]): apply, then the result clamped to [lo, hi] per axis
  // (p.cwiseMax(lo).cwiseMin(hi)), with the same bits as one at a time. Where `lanes` is kAvx2 or kAvx512, the
  // far test of eight points at a time (their cells' flags gathered), and apply's projection only for the
  // points that are not far.
  void settle(float* x, float* y, float* z, std::size_t m, const Vec3& lo, const Vec3& hi, LaneSet lanes) const;
  // the signed distance at x and the outward unit normal there (zero where the
  // gradient vanishes), by central differences of half a cell
  float distance(const Vec3& x) const { return sdf_.sample(x); }
  // A lower bound of distance(x) from one look-up: the smallest of the eight grid values that distance(x)
  // blends, less their blend's rounding, so distanceBound(s, x) <= distance(x) always. A caller that needs the
  // distance only below some range skips distance(x) where the bound is already beyond it. `s` is
  // sdf().sampler() (the same base cells as distance(x)). Only after prepareDistanceBound() (a table as large
  // as the distance grid, so only for the models that use it).
  void prepareDistanceBound();
  float distanceBound(const Grid3<float>::Sampler& s, const Vec3& x) const {
    float f;
    const std::size_t i = s.base(x.x(), 0, f), j = s.base(x.y(), 1, f), k = s.base(x.z(), 2, f);
    return cornerMin_[(k * ny_ + j) * nx_ + i];
  }
  Vec3 normal(const Vec3& x) const;
  bool any() const { return any_; }
  const Grid3<float>& sdf() const { return sdf_; }

 private:
  Grid3<float> sdf_;
  std::vector<std::uint8_t> far_;  // per cell: 1 = no clearance needed anywhere in it (then 3 bytes of padding,
                                   // for settle's 4-byte gathers)
  std::vector<float> cornerMin_;   // per base cell of a sample: its eight corners' smallest value, less rounding
                                   // (prepareDistanceBound)
  std::size_t nx_ = 0, ny_ = 0;
  // the cell of a point for far_, in float: near a cell's border it may name the neighbour, which changes
  // nothing (a point there is within the far margin of either, and apply leaves a far point where it is)
  float min_[3] = {0, 0, 0}, inv_[3] = {1, 1, 1}, top_[3] = {0, 0, 0};
  bool far(const Vec3& x) const {
    int cell[3];
    for (int a = 0; a < 3; ++a) {
      const float t = (x[a] - min_[a]) * inv_[a];
      cell[a] = t > 0.0f ? static_cast<int>(std::min(t, top_[a])) : 0;  // NaN: 0
    }
    return far_[sdf_.spec.index(cell[0], cell[1], cell[2])] != 0;
  }
  Vec3 project(Vec3 x) const;  // apply near an obstacle
#if SWARMSIM_X86_LANES
  // settle's whole eights (returns how many points it did)
  SWARMSIM_AVX2 std::size_t settleAvx2(float* x, float* y, float* z, std::size_t m, const Vec3& lo,
                                       const Vec3& hi) const;
#endif
  float radius_ = 0.0f;
  bool any_ = false;
};

}  // namespace swarmsim
