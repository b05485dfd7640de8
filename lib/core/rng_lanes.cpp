#include "core/rng_lanes.hpp"

#include <algorithm>

namespace swarmsim {

namespace {

constexpr std::uint32_t kM0 = 0xD2511F53u, kM1 = 0xCD9E8D57u;  // Philox4x32's multipliers (core/rng.hpp)
constexpr std::uint32_t kW0 = 0x9E3779B9u, kW1 = 0xBB67AE85u;  // and its key increments

void firstUniformsScalar(std::uint64_t seed, std::uint64_t step, const std::uint32_t* ids, std::size_t first,
                         std::size_t m, RngPurpose purpose, std::uint32_t stream, float* const out[4]) {
  for (std::size_t i = first; i < m; ++i) {
    AgentRng rng(seed, step, ids[i], purpose, stream);
    for (int w = 0; w < 4; ++w) out[w][i] = rng.uniform();
  }
}

#if SWARMSIM_X86_LANES
// the high and low 32 bits of a · M per 32-bit lane (vpmuludq on the even lanes, then on the odd ones; the
// zero-masked forms where GCC 12 warns about the undefined vector the unmasked ones start from)
SWARMSIM_AVX512 inline void mulHiLo(__m512i a, __m512i m, __m512i& hi, __m512i& lo) {
  const __m512i even = _mm512_maskz_mul_epu32(0xff, a, m);
  const __m512i odd = _mm512_maskz_mul_epu32(0xff, _mm512_maskz_srli_epi64(0xff, a, 32), m);
  hi = _mm512_mask_blend_epi32(0xAAAA, _mm512_maskz_srli_epi64(0xff, even, 32), odd);
  lo = _mm512_mask_blend_epi32(0xAAAA, even, _mm512_maskz_slli_epi64(0xff, odd, 32));
}
SWARMSIM_AVX512 std::size_t firstUniformsAvx512(std::uint64_t seed, std::uint64_t step, const std::uint32_t* ids,
                                                std::size_t m, std::uint32_t word3, float* const out[4]) {
  const __m512i m0 = _mm512_set1_epi32(static_cast<int>(kM0)), m1 = _mm512_set1_epi32(static_cast<int>(kM1));
  const __m512 scale = _mm512_set1_ps(1.0f / 16777216.0f);
  std::size_t i = 0;
  for (; i < m; i += 16) {  // (the last agents by masked loads and stores)
    const auto live = static_cast<__mmask16>(m - i >= 16 ? 0xffffu : (1u << (m - i)) - 1u);
    __m512i c0 = _mm512_set1_epi32(static_cast<int>(static_cast<std::uint32_t>(step)));
    __m512i c1 = _mm512_set1_epi32(static_cast<int>(static_cast<std::uint32_t>(step >> 32)));
    __m512i c2 = _mm512_maskz_loadu_epi32(live, ids + i);
    __m512i c3 = _mm512_set1_epi32(static_cast<int>(word3));
    std::uint32_t k0 = static_cast<std::uint32_t>(seed), k1 = static_cast<std::uint32_t>(seed >> 32);
    for (int round = 0; round < 10; ++round) {
      if (round > 0) {
        k0 += kW0;
        k1 += kW1;
      }
      __m512i hi0, lo0, hi1, lo1;
      mulHiLo(c0, m0, hi0, lo0);
      mulHiLo(c2, m1, hi1, lo1);
      c0 = _mm512_xor_si512(_mm512_xor_si512(hi1, c1), _mm512_set1_epi32(static_cast<int>(k0)));
      c1 = lo1;
      c2 = _mm512_xor_si512(_mm512_xor_si512(hi0, c3), _mm512_set1_epi32(static_cast<int>(k1)));
      c3 = lo0;
    }
    const __m512i words[4] = {c0, c1, c2, c3};
    for (int w = 0; w < 4; ++w) {
      const __m512i top = _mm512_maskz_srli_epi32(0xffff, words[w], 8);  // (24 bits: converted exactly)
      _mm512_mask_storeu_ps(out[w] + i, live, _mm512_mul_ps(_mm512_maskz_cvtepi32_ps(0xffff, top), scale));
    }
  }
  return m;
}
// the same on eight lanes (whole eights only)
SWARMSIM_AVX2 inline void mulHiLo(__m256i a, __m256i m, __m256i& hi, __m256i& lo) {
  const __m256i even = _mm256_mul_epu32(a, m);
  const __m256i odd = _mm256_mul_epu32(_mm256_srli_epi64(a, 32), m);
  hi = _mm256_blend_epi32(_mm256_srli_epi64(even, 32), odd, 0xAA);
  lo = _mm256_blend_epi32(even, _mm256_slli_epi64(odd, 32), 0xAA);
}
SWARMSIM_AVX2 std::size_t firstUniformsAvx2(std::uint64_t seed, std::uint64_t step, const std::uint32_t* ids,
                                            std::size_t m, std::uint32_t word3, float* const out[4]) {
  const __m256i m0 = _mm256_set1_epi32(static_cast<int>(kM0)), m1 = _mm256_set1_epi32(static_cast<int>(kM1));
  const __m256 scale = _mm256_set1_ps(1.0f / 16777216.0f);
  std::size_t i = 0;
  for (; i + 8 <= m; i += 8) {
    __m256i c0 = _mm256_set1_epi32(static_cast<int>(static_cast<std::uint32_t>(step)));
    __m256i c1 = _mm256_set1_epi32(static_cast<int>(static_cast<std::uint32_t>(step >> 32)));
    __m256i c2 = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(ids + i));
    __m256i c3 = _mm256_set1_epi32(static_cast<int>(word3));
    std::uint32_t k0 = static_cast<std::uint32_t>(seed), k1 = static_cast<std::uint32_t>(seed >> 32);
    for (int round = 0; round < 10; ++round) {
      if (round > 0) {
        k0 += kW0;
        k1 += kW1;
      }
      __m256i hi0, lo0, hi1, lo1;
      mulHiLo(c0, m0, hi0, lo0);
      mulHiLo(c2, m1, hi1, lo1);
      c0 = _mm256_xor_si256(_mm256_xor_si256(hi1, c1), _mm256_set1_epi32(static_cast<int>(k0)));
      c1 = lo1;
      c2 = _mm256_xor_si256(_mm256_xor_si256(hi0, c3), _mm256_set1_epi32(static_cast<int>(k1)));
      c3 = lo0;
    }
    const __m256i words[4] = {c0, c1, c2, c3};
    for (int w = 0; w < 4; ++w) {
      _mm256_storeu_ps(out[w] + i, _mm256_mul_ps(_mm256_cvtepi32_ps(_mm256_srli_epi32(words[w], 8)), scale));
    }
  }
  return i;
}
#endif

}  // namespace

void firstUniforms(std::uint64_t seed, std::uint64_t step, const std::uint32_t* ids, std::size_t m, RngPurpose purpose,
                   std::uint32_t stream, float* const out[4], LaneSet lanes) {
  // word 3 of block 0 (AgentRng's counter layout)
  const std::uint32_t word3 = (static_cast<std::uint32_t>(purpose) << 24) ^ (stream << 8);
  std::size_t done = 0;
#if SWARMSIM_X86_LANES
  if (lanes == LaneSet::kAvx512) {
    done = firstUniformsAvx512(seed, step, ids, m, word3, out);
  } else if (lanes == LaneSet::kAvx2) {
    done = firstUniformsAvx2(seed, step, ids, m, word3, out);
  }
#else
  (void)lanes;
  (void)word3;
#endif
  firstUniformsScalar(seed, step, ids, done, m, purpose, stream, out);  // the rest (or all) one at a time
}

}  // namespace swarmsim
