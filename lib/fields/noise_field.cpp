#include "fields/noise_field.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/lanes.hpp"
#include "core/parallel.hpp"

#include "geometry/obstacles.hpp"
#include "geometry/signed_distance.hpp"
#include "models/params_util.hpp"

namespace swarmsim {

NoiseField::NoiseField(NoiseFieldKind kind, const NoiseParams& params, const Aabb& domain, const Obstacles& obstacles,
                       std::array<int, 3> cells, const Grid3<float>* boundary, double maxCells)
    : kind_(kind), boundary_(boundary), gain_(params.gain) {
  // 3 samples per lattice cell when that fits (at most 256 per axis and maxCells cells)
  const double edge = params.unit / (3.0 * params.scale);
  double total = 1.0;
  bool fits = true;
  for (int a = 0; a < 3; ++a) {
    const double na = std::ceil(domain.extent()[a] / edge);
    fits = fits && na <= 256.0;
    total *= na;
  }
  direct_ = cells[0] == 0 && !(fits && total <= maxCells);
  if (direct_) {
    potential_ = std::make_shared<NoisePotential>(params);
    step_ = 0.1 * edge;
    exactFrom_ = potential_->d0() + 1.7320508 * step_;
    exactFromF_ = static_cast<float>(exactFrom_);
    if (static_cast<double>(exactFromF_) < exactFrom_) {
      exactFromF_ = std::nextafter(exactFromF_, std::numeric_limits<float>::infinity());
    }
    if (boundary_ && kind_ == NoiseFieldKind::kCurl) buildFloor();
    return;
  }
  const GridSpec spec =
      GridSpec::covering(domain.min, domain.max, cells[0] > 0 ? cells : cellsForEdge(domain, edge, maxCells));
  if (kind == NoiseFieldKind::kCurl) {
    Grid3<float> walls = signedDistance(obstacles, spec);
    addBoxWalls(walls, domain);
    grid_ = curl(noisePotential(spec, params, &walls));
  } else {
    grid_ = perlinVelocity(spec, params);
  }
}

void NoiseField::buildFloor() {
  const GridSpec& spec = boundary_->spec;
  for (int a = 0; a < 3; ++a) floorDims_[a] = (spec.n[a] + kFloorBlock - 1) / kFloorBlock;
  floor_.assign(static_cast<std::size_t>(floorDims_[0]) * floorDims_[1] * floorDims_[2], 0.0f);
  // a sample based at cell i reads cells i and i + 1: a block's bases [8c, 8c + 7] read [8c, 8c + 8]
  parallelFor(floor_.size(), [&](std::size_t f) {
    const int c[3] = {static_cast<int>(f % floorDims_[0]), static_cast<int>((f / floorDims_[0]) % floorDims_[1]),
                      static_cast<int>(f / (static_cast<std::size_t>(floorDims_[0]) * floorDims_[1]))};
    int lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
      lo[a] = c[a] * kFloorBlock;
      hi[a] = std::min(spec.n[a] - 1, lo[a] + kFloorBlock);
    }
    float m = std::numeric_limits<float>::infinity();
    for (int k = lo[2]; k <= hi[2]; ++k) {
      for (int j = lo[1]; j <= hi[1]; ++j) {
        for (int i = lo[0]; i <= hi[0]; ++i) m = std::min(m, boundary_->at(i, j, k));
      }
    }
    // the sample is a convex combination of those values, but for a few roundings (relative 1e-6 at most)
    floor_[f] = m > 0.0f ? m * (1.0f - 1e-5f) : m * (1.0f + 1e-5f) - 1e-30f;
  });
}

bool NoiseField::exactCurlAt(const Vec3& x) const {
  // the blend is 1 over the whole difference stencil (the trilinear distance changes by at most sqrt(3) per metre)
  if (!boundary_) return true;
  const Grid3<float>::Sampler sample(*boundary_);
  if (!floor_.empty()) {
    // the block of the sample's base cell (the one the sample computes)
    std::size_t block[3];
    for (int a = 0; a < 3; ++a) {
      float f;
      block[a] = sample.base(x[a], a, f) / kFloorBlock;
    }
    const std::size_t fi = (block[2] * static_cast<std::size_t>(floorDims_[1]) + block[1]) * floorDims_[0] + block[0];
    if (static_cast<double>(floor_[fi]) >= exactFrom_) return true;  // the same answer as the sample's, sooner
  }
  return sample(x) >= exactFrom_;
}

#if SWARMSIM_X86_LANES
namespace {

// the floor test of exactCurlAt for eight points: Grid3::Sampler::base's float arithmetic per axis (the same
// base cells), the floor block's lower bound by a gather, compared with exactFrom as a float; bit l of the
// result: point l passes
SWARMSIM_AVX2 unsigned floorPass8(const float* x, const float* y, const float* z, const float mn[3], const float cell[3],
                                  const int last[3], const int dims[3], const float* floor, float from) {
  const float* p[3] = {x, y, z};
  __m256i block[3];
  for (int a = 0; a < 3; ++a) {
    const __m256 t = _mm256_sub_ps(_mm256_div_ps(_mm256_sub_ps(_mm256_loadu_ps(p[a]), _mm256_set1_ps(mn[a])),
                                                 _mm256_set1_ps(cell[a])),
                                   _mm256_set1_ps(0.5f));
    const __m256i inside = _mm256_castps_si256(_mm256_cmp_ps(t, _mm256_setzero_ps(), _CMP_GT_OQ));
    const __m256i beyond =
        _mm256_castps_si256(_mm256_cmp_ps(t, _mm256_set1_ps(static_cast<float>(last[a])), _CMP_GE_OQ));
    __m256i base = _mm256_blendv_epi8(_mm256_cvttps_epi32(t), _mm256_set1_epi32(std::max(0, last[a] - 1)), beyond);
    base = _mm256_and_si256(base, inside);  // not above 0 (or NaN): cell 0
    block[a] = _mm256_srli_epi32(base, 3);  // / kFloorBlock (8)
  }
  const __m256i fi = _mm256_add_epi32(
      _mm256_mullo_epi32(_mm256_add_epi32(_mm256_mullo_epi32(block[2], _mm256_set1_epi32(dims[1])), block[1]),
                         _mm256_set1_epi32(dims[0])),
      block[0]);
  const __m256 f = _mm256_i32gather_ps(floor, fi, 4);
  return static_cast<unsigned>(_mm256_movemask_ps(_mm256_cmp_ps(f, _mm256_set1_ps(from), _CMP_GE_OQ)));
}

}  // namespace
#endif

void NoiseField::exactCurlBatch(const float* x, const float* y, const float* z, std::size_t n, bool* exact,
                                LaneSet lanes) const {
  std::size_t i = 0;
#if SWARMSIM_X86_LANES
  static_assert(kFloorBlock == 8, "floorPass8 divides by 8");
  if (boundary_ && !floor_.empty() && (lanes == LaneSet::kAvx2 || lanes == LaneSet::kAvx512)) {
    const GridSpec& g = boundary_->spec;
    float mn[3], cell[3];
    int last[3];
    for (int a = 0; a < 3; ++a) {  // as Grid3::Sampler has them
      mn[a] = static_cast<float>(g.min[a]);
      cell[a] = static_cast<float>(g.cell[a]);
      last[a] = g.n[a] - 1;
    }
    for (; i + kLanes <= n; i += kLanes) {
      const unsigned pass =
          floorPass8(x + i, y + i, z + i, mn, cell, last, floorDims_.data(), floor_.data(), exactFromF_);
      for (std::size_t l = 0; l < kLanes; ++l) {
        exact[i + l] = (pass >> l & 1u) != 0 || exactCurlAt(Vec3(x[i + l], y[i + l], z[i + l]));
      }
    }
  }
#else
  (void)lanes;
#endif
  for (; i < n; ++i) exact[i] = exactCurlAt(Vec3(x[i], y[i], z[i]));
}

Vec3 NoiseField::evaluate(const Vec3& x) const {
  const Vec3d p = x.cast<double>();
  if (kind_ == NoiseFieldKind::kPerlin) return (potential_->noise(p) * gain_).cast<float>();
  // away from the boundary the curl is exact, from the noises' gradients
  if (exactCurlAt(x)) return potential_->curlRaw(p).cast<float>();
  return blendedCurl(p);
}

Vec3 NoiseField::blendedCurl(const Vec3d& p) const {
  Vec3d d[3];  // d[a] = ∂N/∂x_a
  for (int a = 0; a < 3; ++a) {
    Vec3d e = Vec3d::Zero();
    e[a] = step_;
    d[a] = ((*potential_)(p + e, boundary_) - (*potential_)(p - e, boundary_)) / (2.0 * step_);
  }
  return Vec3d(d[1].z() - d[2].y(), d[2].x() - d[0].z(), d[0].y() - d[1].x()).cast<float>();
}

void NoiseField::evaluateBatch(const float* x, const float* y, const float* z, std::size_t n, float* ox, float* oy,
                               float* oz) const {
  if (!direct_ || kind_ != NoiseFieldKind::kCurl) {
    for (std::size_t i = 0; i < n; ++i) {
      const Vec3 v = (*this)(Vec3(x[i], y[i], z[i]));
      ox[i] = v.x();
      oy[i] = v.y();
      oz[i] = v.z();
    }
    return;
  }
  // blocks of points: first the boundary test of each (the distance samples are independent, so their cache
  // misses overlap), then the differences near the boundary one point at a time and the exact curl of the
  // others on SIMD lanes
  constexpr std::size_t kBlock = 64;
  // (the lane sets asked once: each question reads the environment)
  const bool avx = PerlinNoise3::batchAvx(), wide = avx && PerlinNoise3::batchWide();
  const bool vbmi = wide && PerlinNoise3::batchVbmi();
  const LaneSet lanes = laneSet();
  bool exact[kBlock];
  double px[kBlock], py[kBlock], pz[kBlock], cx[kBlock], cy[kBlock], cz[kBlock];
  std::size_t slot[kBlock];
  for (std::size_t start = 0; start < n; start += kBlock) {
    const std::size_t m = std::min(kBlock, n - start);
    exactCurlBatch(x + start, y + start, z + start, m, exact, lanes);
    std::size_t k = 0;
    for (std::size_t j = 0; j < m; ++j) {
      const std::size_t i = start + j;
      if (exact[j]) {
        px[k] = static_cast<double>(x[i]);
        py[k] = static_cast<double>(y[i]);
        pz[k] = static_cast<double>(z[i]);
        slot[k++] = i;
        continue;
      }
      const Vec3 v = blendedCurl(Vec3(x[i], y[i], z[i]).cast<double>());
      ox[i] = v.x();
      oy[i] = v.y();
      oz[i] = v.z();
    }
    potential_->curlRawBatch(px, py, pz, k, cx, cy, cz, avx, wide, vbmi);
    for (std::size_t q = 0; q < k; ++q) {
      ox[slot[q]] = static_cast<float>(cx[q]);
      oy[slot[q]] = static_cast<float>(cy[q]);
      oz[slot[q]] = static_cast<float>(cz[q]);
    }
  }
}

}  // namespace swarmsim
