#include "core/rng_lanes.hpp"

#include <algorithm>

namespace swarmsim {

namespace {

void firstUniformsScalar(std::uint64_t seed, std::uint64_t step, const std::uint32_t* ids, std::size_t first,
                         std::size_t m, RngPurpose purpose, std::uint32_t stream, float* const out[4]) {
  for (std::size_t i = first; i < m; ++i) {
    AgentRng rng(seed, step, ids[i], purpose, stream);
    for (int w = 0; w < 4; ++w) out[w][i] = rng.uniform();
  }
}

#if SWARMSIM_X86_LANES
// Philox4x32-10's ten rounds on integer lanes, one counter per lane (core/rng.hpp: philox4x32). W gives the
// lanes (W::I, a struct around one register, as core/lanes.hpp's lane types: no vector crosses a function
// without its target), set1, the xor of two lanes and a key word, and mulHiLo: the high and low 32 bits of
// a · M per lane (vpmuludq on the even lanes, then on the odd ones)
template <typename W>
__attribute__((always_inline)) inline void philoxRounds(typename W::I c[4], std::uint64_t seed) {
  using I = typename W::I;
  std::uint32_t k0 = static_cast<std::uint32_t>(seed), k1 = static_cast<std::uint32_t>(seed >> 32);
  for (int round = 0; round < 10; ++round) {
    if (round > 0) {
      k0 += kPhiloxW0;
      k1 += kPhiloxW1;
    }
    I hi0, lo0, hi1, lo1;
    W::mulHiLo(c[0], kPhiloxM0, hi0, lo0);
    W::mulHiLo(c[2], kPhiloxM1, hi1, lo1);
    c[0] = W::xorKey(hi1, c[1], k0);
    c[1] = lo1;
    c[2] = W::xorKey(hi0, c[3], k1);
    c[3] = lo0;
  }
}

// sixteen lanes (the zero-masked forms where GCC 12 warns about the undefined vector the unmasked ones start
// from)
struct Philox16 {
  struct I {
    __m512i a;
  };
  SWARMSIM_AVX512 static I set1(std::uint32_t x) { return {_mm512_set1_epi32(static_cast<int>(x))}; }
  SWARMSIM_AVX512 static I xorKey(I x, I y, std::uint32_t k) {
    return {_mm512_xor_si512(_mm512_xor_si512(x.a, y.a), set1(k).a)};
  }
  SWARMSIM_AVX512 static void mulHiLo(I x, std::uint32_t mul, I& hi, I& lo) {
    const __m512i m = set1(mul).a;
    const __m512i even = _mm512_maskz_mul_epu32(0xff, x.a, m);
    const __m512i odd = _mm512_maskz_mul_epu32(0xff, _mm512_maskz_srli_epi64(0xff, x.a, 32), m);
    hi.a = _mm512_mask_blend_epi32(0xAAAA, _mm512_maskz_srli_epi64(0xff, even, 32), odd);
    lo.a = _mm512_mask_blend_epi32(0xAAAA, even, _mm512_maskz_slli_epi64(0xff, odd, 32));
  }
};
// eight lanes
struct Philox8 {
  struct I {
    __m256i a;
  };
  SWARMSIM_AVX2 static I set1(std::uint32_t x) { return {_mm256_set1_epi32(static_cast<int>(x))}; }
  SWARMSIM_AVX2 static I xorKey(I x, I y, std::uint32_t k) {
    return {_mm256_xor_si256(_mm256_xor_si256(x.a, y.a), set1(k).a)};
  }
  SWARMSIM_AVX2 static void mulHiLo(I x, std::uint32_t mul, I& hi, I& lo) {
    const __m256i m = set1(mul).a;
    const __m256i even = _mm256_mul_epu32(x.a, m);
    const __m256i odd = _mm256_mul_epu32(_mm256_srli_epi64(x.a, 32), m);
    hi.a = _mm256_blend_epi32(_mm256_srli_epi64(even, 32), odd, 0xAA);
    lo.a = _mm256_blend_epi32(even, _mm256_slli_epi64(odd, 32), 0xAA);
  }
};

// every agent, sixteen at a time (the last ones by masked loads and stores); returns m
SWARMSIM_AVX512 __attribute__((flatten)) std::size_t firstUniformsAvx512(std::uint64_t seed, std::uint64_t step,
                                                                         const std::uint32_t* ids, std::size_t m,
                                                                         std::uint32_t word3, float* const out[4]) {
  using W = Philox16;
  const __m512 scale = _mm512_set1_ps(AgentRng::kUniformScale);
  for (std::size_t i = 0; i < m; i += 16) {
    const auto live = static_cast<__mmask16>(firstLanes(m - i, 16));
    W::I c[4] = {W::set1(static_cast<std::uint32_t>(step)),
                 W::set1(static_cast<std::uint32_t>(step >> 32)),
                 {_mm512_maskz_loadu_epi32(live, ids + i)},
                 W::set1(word3)};
    philoxRounds<W>(c, seed);
    for (int w = 0; w < 4; ++w) {
      const __m512i top =
          _mm512_maskz_srli_epi32(0xffff, c[w].a, AgentRng::kUniformShift);  // (24 bits: converted exactly)
      _mm512_mask_storeu_ps(out[w] + i, live, _mm512_mul_ps(_mm512_maskz_cvtepi32_ps(0xffff, top), scale));
    }
  }
  return m;
}
// eight at a time, whole eights only; returns how many agents it did
SWARMSIM_AVX2 __attribute__((flatten)) std::size_t firstUniformsAvx2(std::uint64_t seed, std::uint64_t step,
                                                                     const std::uint32_t* ids, std::size_t m,
                                                                     std::uint32_t word3, float* const out[4]) {
  using W = Philox8;
  const __m256 scale = _mm256_set1_ps(AgentRng::kUniformScale);
  std::size_t i = 0;
  for (; i + 8 <= m; i += 8) {
    W::I c[4] = {W::set1(static_cast<std::uint32_t>(step)),
                 W::set1(static_cast<std::uint32_t>(step >> 32)),
                 {_mm256_loadu_si256(reinterpret_cast<const __m256i*>(ids + i))},
                 W::set1(word3)};
    philoxRounds<W>(c, seed);
    for (int w = 0; w < 4; ++w) {
      _mm256_storeu_ps(out[w] + i,
                       _mm256_mul_ps(_mm256_cvtepi32_ps(_mm256_srli_epi32(c[w].a, AgentRng::kUniformShift)), scale));
    }
  }
  return i;
}
#endif

}  // namespace

void firstUniforms(std::uint64_t seed, std::uint64_t step, const std::uint32_t* ids, std::size_t m, RngPurpose purpose,
                   std::uint32_t stream, float* const out[4], LaneSet lanes) {
  // word 3 of block 0 (AgentRng's counter layout)
  const std::uint32_t word3 = AgentRng::firstWord3(purpose, stream);
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
