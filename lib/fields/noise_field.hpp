#pragma once
// A curl-noise (or plain Perlin) velocity field over a domain, sampled at any
// point: the one place the models turn NoiseParams into per-insect noise.
//
// When it fits (at most 256 cells per axis and `maxCells` cells) the field is
// precomputed on a grid with about 3 samples per Perlin lattice cell and
// sampled trilinearly; otherwise (fine noise in a large domain) it is evaluated
// at each point: Perlin directly, or the curl exactly from the noises' analytic
// gradients, except within the blend's distance of a boundary, where it is the
// curl of the blended potential by central differences of step 0.1 of a grid
// cell. Curl noise is blended toward the obstacles and the domain's walls
// (curl_noise.hpp, eq. 2-3 of wang2014), so it flows along them rather than
// into them.
#include <array>
#include <cstddef>
#include <memory>
#include <vector>

#include "core/lanes.hpp"
#include "core/vec.hpp"
#include "core/world.hpp"
#include "fields/curl_noise.hpp"
#include "fields/grid3.hpp"

namespace swarmsim {

enum class NoiseFieldKind { kCurl, kPerlin };

class NoiseField {
 public:
  NoiseField() = default;
  // `cells` > 0: that grid, always; {0, 0, 0}: a grid of edge unit / (3 scale)
  // when it fits, else direct evaluation. `boundary` (signed distance to
  // obstacles and walls, negative inside) is the blend's distance in direct
  // mode; it must outlive the field. Grid mode computes its own on its grid.
  NoiseField(NoiseFieldKind kind, const NoiseParams& params, const Aabb& domain, const Obstacles& obstacles,
             std::array<int, 3> cells, const Grid3<float>* boundary, double maxCells = 8e6);

  // the field at x (m/s)
  Vec3 operator()(const Vec3& x) const { return direct_ ? evaluate(x) : grid_.sample(x); }
  // the field at the n points (x[i], y[i], z[i]) into (ox[i], oy[i], oz[i]), equal bit for bit to operator() at
  // each; direct curl noise away from the boundary (the exact curl) takes PerlinNoise3::kLanes points at a time
  // on SIMD lanes (AVX where the CPU has it and SWARMSIM_NO_AVX is unset), every other point operator()
  void evaluateBatch(const float* x, const float* y, const float* z, std::size_t n, float* ox, float* oy,
                     float* oz) const;
  bool direct() const { return direct_; }
  const GridSpec& spec() const { return grid_.spec; }

 private:
  Vec3 evaluate(const Vec3& x) const;
  // direct curl: whether x is far enough from the boundary for the exact curl (evaluate's test)
  bool exactCurlAt(const Vec3& x) const;
  // exactCurlAt of the n points (x[i], y[i], z[i]) into exact[i]; on AVX2 the floor test of eight at a time,
  // then exactCurlAt of those it does not pass (the same answers); lanes: laneSet()
  void exactCurlBatch(const float* x, const float* y, const float* z, std::size_t n, bool* exact, LaneSet lanes) const;
  void buildFloor();
  // direct curl near the boundary: central differences of the blended potential at p
  Vec3 blendedCurl(const Vec3d& p) const;

  NoiseFieldKind kind_ = NoiseFieldKind::kCurl;
  bool direct_ = false;
  Grid3<Vec3> grid_;
  std::shared_ptr<const NoisePotential> potential_;
  const Grid3<float>* boundary_ = nullptr;
  double step_ = 0.0;  // central-difference step of direct curl, m
  double gain_ = 1.0;  // direct Perlin: the gain (the potential carries it for curl)
  // direct curl with a boundary: a lower bound of boundary_->sample over each block of kFloorBlock^3 base
  // cells (a cache-sized summary of the distance grid: most points pass exactCurlAt on it alone)
  static constexpr int kFloorBlock = 8;
  std::vector<float> floor_;
  std::array<int, 3> floorDims_ = {0, 0, 0};
  double exactFrom_ = 0.0;  // the distance from which the curl is exact
  float exactFromF_ = 0.0f;  // the least float f with f >= exactFrom_ (a float compare with the same answer)
};

}  // namespace swarmsim
