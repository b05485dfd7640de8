// sampleBatch (sample_batch.hpp)
#include "fields/sample_batch.hpp"

#include <algorithm>
#include <cstdint>
#include <cstring>

namespace swarmsim {
namespace {

using Constants = Grid3<Vec3>::Sampler::Constants;

#if SWARMSIM_X86_LANES
// Sampler::base on eight coordinates of axis a: the cells as integers, the fractions f
SWARMSIM_AVX inline void basesAvx(const Constants& c, int a, const float* x, std::int32_t* cell, float* f) {
  const __m256 t = _mm256_sub_ps(
      _mm256_div_ps(_mm256_sub_ps(_mm256_loadu_ps(x), _mm256_set1_ps(c.min[a])), _mm256_set1_ps(c.cell[a])),
      _mm256_set1_ps(0.5f));
  const int last = c.last[a];
  const __m256 inside = _mm256_cmp_ps(t, _mm256_setzero_ps(), _CMP_GT_OQ);  // (NaN: false)
  const __m256 top = _mm256_cmp_ps(t, _mm256_set1_ps(static_cast<float>(last)), _CMP_GE_OQ);
  // below the top: i = (int) t, f = t - i (t > 0, so the conversion's truncation is the floor)
  const __m256i i = _mm256_cvttps_epi32(_mm256_min_ps(t, _mm256_set1_ps(static_cast<float>(last))));
  const __m256 mid = _mm256_sub_ps(t, _mm256_cvtepi32_ps(i));
  const __m256 atTop = _mm256_set1_ps(last > 0 ? 1.0f : 0.0f);
  const __m256 fr = _mm256_and_ps(inside, _mm256_blendv_ps(mid, atTop, top));
  _mm256_storeu_ps(f, fr);
  alignas(32) std::int32_t lane[8];
  _mm256_store_si256(reinterpret_cast<__m256i*>(lane), i);
  alignas(32) float in[8], tp[8];
  _mm256_store_ps(in, inside);
  _mm256_store_ps(tp, top);
  const std::int32_t topCell = std::max(0, last - 1);
  for (int l = 0; l < 8; ++l) {
    std::uint32_t inBits, topBits;
    std::memcpy(&inBits, &in[l], 4);
    std::memcpy(&topBits, &tp[l], 4);
    cell[l] = inBits == 0 ? 0 : (topBits != 0 ? topCell : lane[l]);
  }
}

SWARMSIM_AVX __attribute__((flatten)) void sampleAvx(const Grid3<Vec3>::Sampler& s, const float* x, const float* y,
                                                     const float* z, std::size_t n, Vec3* out) {
  const Constants c = s.constants();
  std::size_t i = 0;
  for (; i + 8 <= n; i += 8) {
    std::int32_t cell[3][8];
    alignas(32) float f[3][8];
    basesAvx(c, 0, x + i, cell[0], f[0]);
    basesAvx(c, 1, y + i, cell[1], f[1]);
    basesAvx(c, 2, z + i, cell[2], f[2]);
    for (int l = 0; l < 8; ++l) {
      const std::size_t i0[3] = {static_cast<std::size_t>(cell[0][l]), static_cast<std::size_t>(cell[1][l]),
                                 static_cast<std::size_t>(cell[2][l])};
      const float fl[3] = {f[0][l], f[1][l], f[2][l]};
      out[i + l] = s.blendAt(s.cornersOf(i0, fl));
    }
  }
  for (; i < n; ++i) out[i] = s(Vec3(x[i], y[i], z[i]));
}
#endif

}  // namespace

void sampleBatch(const Grid3<Vec3>::Sampler& s, const float* x, const float* y, const float* z, std::size_t n,
                 Vec3* out, LaneSet lanes) {
#if SWARMSIM_X86_LANES
  if (lanes != LaneSet::kSse) {
    sampleAvx(s, x, y, z, n, out);
    return;
  }
#else
  (void)lanes;
#endif
  for (std::size_t i = 0; i < n; ++i) out[i] = s(Vec3(x[i], y[i], z[i]));
}

}  // namespace swarmsim
