#include "geometry/clearance.hpp"

#include <algorithm>
#include <cmath>

#include "core/parallel.hpp"

namespace swarmsim {

ObstacleClearance::ObstacleClearance(Grid3<float> sdf, float radius, bool any)
    : sdf_(std::move(sdf)), radius_(radius), any_(any) {
  const float margin = radius_ + 2.0f * static_cast<float>(sdf_.spec.cell.norm());
  far_.assign(sdf_.data.size() + 3, 0);
  parallelFor(sdf_.data.size(), [&](std::size_t c) { far_[c] = sdf_.data[c] >= margin ? 1 : 0; });
  for (int a = 0; a < 3; ++a) {
    min_[a] = static_cast<float>(sdf_.spec.min[a]);
    inv_[a] = static_cast<float>(1.0 / sdf_.spec.cell[a]);
    top_[a] = static_cast<float>(sdf_.spec.n[a] - 1);
  }
}

void ObstacleClearance::prepareDistanceBound() {
  // distanceBound: a trilinear blend of values >= m is >= m up to its three levels of rounding (each a
  // relative 2^-24 or so for the blend and for g = 1 - f): 1e-6 of |m| covers them, 1e-30 the subnormals
  const GridSpec& g = sdf_.spec;
  nx_ = static_cast<std::size_t>(g.n[0]);
  ny_ = static_cast<std::size_t>(g.n[1]);
  const std::size_t dx = g.n[0] > 1 ? 1 : 0, sy = g.n[1] > 1 ? nx_ : 0, sz = g.n[2] > 1 ? nx_ * ny_ : 0;
  cornerMin_.resize(sdf_.data.size());
  parallelFor(cornerMin_.size(), [&](std::size_t b) {
    const std::size_t i = b % nx_, j = (b / nx_) % ny_, k = b / (nx_ * ny_);
    // a base cell is never the last along an axis with more than one cell (Sampler::base)
    const std::size_t ox = i + 1 < nx_ ? dx : 0, oy = j + 1 < ny_ ? sy : 0,
                      oz = k + 1 < static_cast<std::size_t>(g.n[2]) ? sz : 0;
    float m = sdf_.data[b];
    for (const std::size_t o : {ox, oy, ox + oy, oz, oz + ox, oz + oy, oz + oy + ox}) m = std::min(m, sdf_.data[b + o]);
    cornerMin_[b] = std::isfinite(m) ? m - 1e-6f * std::fabs(m) - 1e-30f : m;
  });
}

namespace {
inline void clampInto(Vec3 p, const Vec3& lo, const Vec3& hi, float* x, float* y, float* z, std::size_t i) {
  p = p.cwiseMax(lo).cwiseMin(hi);
  x[i] = p.x();
  y[i] = p.y();
  z[i] = p.z();
}
}  // namespace

#if SWARMSIM_X86_LANES
// settle's eights: the far test on lanes (far()'s operations), the clamp as cwiseMax then cwiseMin
// (max_ps(lo, p) is p < lo ? lo : p, and min_ps(hi, p) is hi < p ? hi : p, as Eigen's scalar max and min)
SWARMSIM_AVX2 std::size_t ObstacleClearance::settleAvx2(float* x, float* y, float* z, std::size_t m, const Vec3& lo,
                                                        const Vec3& hi) const {
  float* const axis[3] = {x, y, z};
  const std::int32_t n0 = sdf_.spec.n[0], n1 = sdf_.spec.n[1];
  std::size_t i = 0;
  for (; i + 8 <= m; i += 8) {
    __m256 p[3];
    for (int a = 0; a < 3; ++a) p[a] = _mm256_loadu_ps(axis[a] + i);
    if (any_) {
      __m256i cell[3];
      for (int a = 0; a < 3; ++a) {
        const __m256 t = _mm256_mul_ps(_mm256_sub_ps(p[a], _mm256_set1_ps(min_[a])), _mm256_set1_ps(inv_[a]));
        const __m256 inside = _mm256_cmp_ps(t, _mm256_setzero_ps(), _CMP_GT_OQ);
        cell[a] = _mm256_and_si256(_mm256_castps_si256(inside),
                                   _mm256_cvttps_epi32(_mm256_min_ps(t, _mm256_set1_ps(top_[a]))));
      }
      const __m256i index = _mm256_add_epi32(
          _mm256_mullo_epi32(_mm256_add_epi32(_mm256_mullo_epi32(cell[2], _mm256_set1_epi32(n1)), cell[1]),
                             _mm256_set1_epi32(n0)),
          cell[0]);
      const __m256i flags = _mm256_and_si256(
          _mm256_i32gather_epi32(reinterpret_cast<const int*>(far_.data()), index, 1), _mm256_set1_epi32(0xff));
      const auto near = static_cast<unsigned>(
          _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(flags, _mm256_setzero_si256()))));
      if (near != 0) {
        alignas(32) float l[3][8];
        for (int a = 0; a < 3; ++a) _mm256_store_ps(l[a], p[a]);
        for (unsigned k = 0; k < 8; ++k) {
          if (!((near >> k) & 1u)) continue;
          const Vec3 q = project(Vec3(l[0][k], l[1][k], l[2][k]));
          for (int a = 0; a < 3; ++a) l[a][k] = q[a];
        }
        for (int a = 0; a < 3; ++a) p[a] = _mm256_load_ps(l[a]);
      }
    }
    for (int a = 0; a < 3; ++a) {
      _mm256_storeu_ps(axis[a] + i, _mm256_min_ps(_mm256_set1_ps(hi[a]), _mm256_max_ps(_mm256_set1_ps(lo[a]), p[a])));
    }
  }
  return i;
}
#endif

void ObstacleClearance::settle(float* x, float* y, float* z, std::size_t m, const Vec3& lo, const Vec3& hi,
                               LaneSet lanes) const {
  std::size_t i = 0;
#if SWARMSIM_X86_LANES
  // (the lanes' cell indices are 32-bit)
  if ((lanes == LaneSet::kAvx2 || lanes == LaneSet::kAvx512) && far_.size() < (std::size_t{1} << 31)) {
    i = settleAvx2(x, y, z, m, lo, hi);
  }
#else
  (void)lanes;
#endif
  for (; i < m; ++i) clampInto(apply(Vec3(x[i], y[i], z[i])), lo, hi, x, y, z, i);
}

Vec3 ObstacleClearance::normal(const Vec3& x) const {
  Vec3 g;
  for (int a = 0; a < 3; ++a) {
    const float h = 0.5f * static_cast<float>(sdf_.spec.cell[a]);
    Vec3 e = Vec3::Zero();
    e[a] = h;
    g[a] = (sdf_.sample(x + e) - sdf_.sample(x - e)) / (2.0f * h);
  }
  return normalizedOrZero(g);
}

Vec3 ObstacleClearance::project(Vec3 x) const {
  for (int it = 0; it < 4; ++it) {
    const float phi = sdf_.sample(x);
    if (phi >= radius_) break;
    const Vec3 nrm = normal(x);
    if (nrm.squaredNorm() == 0.0f) break;
    x += nrm * (radius_ - phi + 1e-4f * static_cast<float>(sdf_.spec.cell.minCoeff()));
  }
  return x;
}

}  // namespace swarmsim
