// sampleBatch (sample_batch.hpp)
#include "fields/sample_batch.hpp"

#include <algorithm>
#include <cstdint>

namespace swarmsim {
namespace {

using Constants = Grid3<Vec3>::Sampler::Constants;

inline void put(PaddedVec3* out, const Vec3& v) { *out = PaddedVec3{{v.x(), v.y(), v.z(), 0.0f}}; }

#if SWARMSIM_X86_LANES
// Sampler::base on eight coordinates of axis a: the cells as integers, the fractions f. With t clamped to
// [0, last] (NaN to 0: max returns its second operand when one is NaN) and the cell trunc(t) held to last − 1 at
// most, f = t − cell gives base()'s cases without a branch or a blend: t ≤ 0 or NaN: cell 0, f 0; t ≥ last: the
// last cell but one and f 1 (0 on a grid of one cell); between: trunc(t) and t − trunc(t)
SWARMSIM_AVX inline void basesAvx(const Constants& c, int a, const float* x, std::int32_t* cell, float* f) {
  const __m256 t = _mm256_sub_ps(
      _mm256_div_ps(_mm256_sub_ps(_mm256_loadu_ps(x), _mm256_set1_ps(c.min[a])), _mm256_set1_ps(c.cell[a])),
      _mm256_set1_ps(0.5f));
  const int last = c.last[a];
  const __m256 tc = _mm256_min_ps(_mm256_max_ps(t, _mm256_setzero_ps()), _mm256_set1_ps(static_cast<float>(last)));
  const __m256 base = _mm256_min_ps(_mm256_round_ps(tc, _MM_FROUND_TO_ZERO | _MM_FROUND_NO_EXC),
                                    _mm256_set1_ps(static_cast<float>(std::max(0, last - 1))));
  _mm256_storeu_ps(f, _mm256_sub_ps(tc, base));
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(cell), _mm256_cvttps_epi32(base));
}

// a sample to 16 bytes with a 0 after it
SWARMSIM_AVX inline void put(PaddedVec3* out, __m128 r) { _mm_store_ps(out->v, _mm_blend_ps(r, _mm_setzero_ps(), 8)); }

// Eight points at a time: their cells and weights on lanes (basesAvx), then each one's blend (blendCorners, as
// Grid3<Vec3>::Sampler::blendAt: the same bits), the next eight's corner rows fetched meanwhile. A corner is read
// as 16 bytes, 4 past its value, so points whose last corner is the data's last value take the sampler's own path
SWARMSIM_AVX __attribute__((flatten)) void sampleAvx(const Grid3<Vec3>::Sampler& s, const float* x, const float* y,
                                                     const float* z, std::size_t n, PaddedVec3* out) {
  const Constants c = s.constants();
  const auto layout = s.layout();
  const float* raw = layout.data->data();
  const std::size_t nx = layout.nx, ny = layout.ny, dx = layout.dx, sy = layout.sy, sz = layout.sz;
  const std::size_t limit = layout.wholeBelow;
  // eight points' base values and weights; the next eight's are found, and their corners' rows fetched, while
  // this eight is blended
  struct Eight {
    std::int32_t cell[3][8];
    std::size_t b[8];
    alignas(32) float f[3][8];
    alignas(32) float g[3][8];
  };
  Eight blocks[2];
  const auto prepare = [&](std::size_t first, Eight& e) SWARMSIM_AVX {
    basesAvx(c, 0, x + first, e.cell[0], e.f[0]);
    basesAvx(c, 1, y + first, e.cell[1], e.f[1]);
    basesAvx(c, 2, z + first, e.cell[2], e.f[2]);
    for (int a = 0; a < 3; ++a) _mm256_store_ps(e.g[a], _mm256_sub_ps(_mm256_set1_ps(1.0f), _mm256_load_ps(e.f[a])));
    for (int l = 0; l < 8; ++l) {
      e.b[l] = (static_cast<std::size_t>(e.cell[2][l]) * ny + static_cast<std::size_t>(e.cell[1][l])) * nx +
               static_cast<std::size_t>(e.cell[0][l]);
      const float* row = raw + 3 * e.b[l];
      __builtin_prefetch(row);
      __builtin_prefetch(row + 3 * sy);
      __builtin_prefetch(row + 3 * sz);
      __builtin_prefetch(row + 3 * (sz + sy));
    }
  };
  std::size_t i = 0;
  if (n >= 8) prepare(0, blocks[0]);
  for (int cur = 0; i + 8 <= n; i += 8, cur ^= 1) {
    if (i + 16 <= n) prepare(i + 8, blocks[cur ^ 1]);
    const Eight& e = blocks[cur];
    for (int l = 0; l < 8; ++l) {
      const std::size_t b = e.b[l];
      if (b >= limit) {
        const std::size_t i0[3] = {static_cast<std::size_t>(e.cell[0][l]), static_cast<std::size_t>(e.cell[1][l]),
                                   static_cast<std::size_t>(e.cell[2][l])};
        const float fl[3] = {e.f[0][l], e.f[1][l], e.f[2][l]};
        put(out + i + l, s.blendAt(s.cornersOf(i0, fl)));
        continue;
      }
      const __m128 r = blendCorners(raw + 3 * b, 3 * dx, 3 * sy, 3 * sz, e.g[0][l], e.f[0][l], e.g[1][l], e.f[1][l],
                                    e.g[2][l], e.f[2][l]);
      put(out + i + l, r);
    }
  }
  for (; i < n; ++i) put(out + i, s(Vec3(x[i], y[i], z[i])));
}
#endif

}  // namespace

void sampleBatch(const Grid3<Vec3>::Sampler& s, const float* x, const float* y, const float* z, std::size_t n,
                 PaddedVec3* out, LaneSet lanes) {
#if SWARMSIM_X86_LANES
  if (lanes != LaneSet::kSse) {
    sampleAvx(s, x, y, z, n, out);
    return;
  }
#else
  (void)lanes;
#endif
  for (std::size_t i = 0; i < n; ++i) put(out + i, s(Vec3(x[i], y[i], z[i])));
}

}  // namespace swarmsim
