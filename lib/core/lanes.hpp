#pragma once
// Eight logical float lanes for SIMD kernels: one AVX register (AvxLanes), two
// SSE registers (SseLanes, any x86-64 CPU) or plain code elsewhere
// (ScalarLanes). Every operation is exact IEEE arithmetic per lane (no fused
// multiply-add), so a kernel written once over `L` gives the same bits with any
// of them; lanes are combined in a fixed order by the kernels. useAvx() picks
// AVX at run time (SWARMSIM_NO_AVX=1 in the environment forces the SSE lanes,
// for tests). Entry points compiled for AVX carry SWARMSIM_AVX and `flatten`,
// so the lane operations inline into them.
//
// Masks are all-one (true) or all-zero bit patterns per lane, as the compare
// instructions make them.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <type_traits>
#if defined(__GNUC__) && defined(__x86_64__) && !defined(SWARMSIM_PORTABLE_LANES)
#include <immintrin.h>
#define SWARMSIM_X86_LANES 1
#define SWARMSIM_AVX __attribute__((target("avx")))
#endif

namespace swarmsim {

constexpr std::size_t kLanes = 8;

// set bits of an 8-lane mask (__builtin_popcount is a library call on x86-64 without POPCNT)
inline int laneCount(unsigned mask) {
  static constexpr std::uint8_t kNibble[16] = {0, 1, 1, 2, 1, 2, 2, 3, 1, 2, 2, 3, 2, 3, 3, 4};
  return kNibble[mask & 15u] + kNibble[(mask >> 4) & 15u];
}

#if SWARMSIM_X86_LANES
struct SseLanes {
  struct V {
    __m128 a, b;
  };
  static V load(const float* p) { return {_mm_loadu_ps(p), _mm_loadu_ps(p + 4)}; }
  static V set1(float x) { return {_mm_set1_ps(x), _mm_set1_ps(x)}; }
  static V add(V x, V y) { return {_mm_add_ps(x.a, y.a), _mm_add_ps(x.b, y.b)}; }
  static V sub(V x, V y) { return {_mm_sub_ps(x.a, y.a), _mm_sub_ps(x.b, y.b)}; }
  static V mul(V x, V y) { return {_mm_mul_ps(x.a, y.a), _mm_mul_ps(x.b, y.b)}; }
  static V div(V x, V y) { return {_mm_div_ps(x.a, y.a), _mm_div_ps(x.b, y.b)}; }
  static V max(V x, V y) { return {_mm_max_ps(x.a, y.a), _mm_max_ps(x.b, y.b)}; }
  static V sqrt(V x) { return {_mm_sqrt_ps(x.a), _mm_sqrt_ps(x.b)}; }
  static V lt(V x, V y) { return {_mm_cmplt_ps(x.a, y.a), _mm_cmplt_ps(x.b, y.b)}; }
  static V le(V x, V y) { return {_mm_cmple_ps(x.a, y.a), _mm_cmple_ps(x.b, y.b)}; }
  static V band(V x, V y) { return {_mm_and_ps(x.a, y.a), _mm_and_ps(x.b, y.b)}; }
  static V andnot(V x, V y) { return {_mm_andnot_ps(x.a, y.a), _mm_andnot_ps(x.b, y.b)}; }  // ~x & y
  static int count(V m) {
    return laneCount(static_cast<unsigned>(_mm_movemask_ps(m.a) | (_mm_movemask_ps(m.b) << 4)));
  }
  static void store(float* p, V x) {
    _mm_storeu_ps(p, x.a);
    _mm_storeu_ps(p + 4, x.b);
  }
  static void fold4(V x, float* p) { _mm_storeu_ps(p, _mm_add_ps(x.a, x.b)); }  // lane i + lane i+4
  static V min(V x, V y) { return {_mm_min_ps(x.a, y.a), _mm_min_ps(x.b, y.b)}; }
  static V gt(V x, V y) { return {_mm_cmpgt_ps(x.a, y.a), _mm_cmpgt_ps(x.b, y.b)}; }
  static V bor(V x, V y) { return {_mm_or_ps(x.a, y.a), _mm_or_ps(x.b, y.b)}; }
  static unsigned mask(V m) {
    return static_cast<unsigned>(_mm_movemask_ps(m.a) | (_mm_movemask_ps(m.b) << 4));
  }
  // round to the nearest integer (ties to even: the default rounding mode), as floats
  static V round(V x) {
    return {_mm_cvtepi32_ps(_mm_cvtps_epi32(x.a)), _mm_cvtepi32_ps(_mm_cvtps_epi32(x.b))};
  }
  // 2^n for integer-valued n in [-126, 127]
  static V pow2(V n) {
    const __m128i bias = _mm_set1_epi32(127);
    return {_mm_castsi128_ps(_mm_slli_epi32(_mm_add_epi32(_mm_cvtps_epi32(n.a), bias), 23)),
            _mm_castsi128_ps(_mm_slli_epi32(_mm_add_epi32(_mm_cvtps_epi32(n.b), bias), 23))};
  }
};

struct AvxLanes {
  struct V {
    __m256 a;
  };
  SWARMSIM_AVX static V load(const float* p) { return {_mm256_loadu_ps(p)}; }
  SWARMSIM_AVX static V set1(float x) { return {_mm256_set1_ps(x)}; }
  SWARMSIM_AVX static V add(V x, V y) { return {_mm256_add_ps(x.a, y.a)}; }
  SWARMSIM_AVX static V sub(V x, V y) { return {_mm256_sub_ps(x.a, y.a)}; }
  SWARMSIM_AVX static V mul(V x, V y) { return {_mm256_mul_ps(x.a, y.a)}; }
  SWARMSIM_AVX static V div(V x, V y) { return {_mm256_div_ps(x.a, y.a)}; }
  SWARMSIM_AVX static V max(V x, V y) { return {_mm256_max_ps(x.a, y.a)}; }
  SWARMSIM_AVX static V sqrt(V x) { return {_mm256_sqrt_ps(x.a)}; }
  SWARMSIM_AVX static V lt(V x, V y) { return {_mm256_cmp_ps(x.a, y.a, _CMP_LT_OQ)}; }
  SWARMSIM_AVX static V le(V x, V y) { return {_mm256_cmp_ps(x.a, y.a, _CMP_LE_OQ)}; }
  SWARMSIM_AVX static V band(V x, V y) { return {_mm256_and_ps(x.a, y.a)}; }
  SWARMSIM_AVX static V andnot(V x, V y) { return {_mm256_andnot_ps(x.a, y.a)}; }
  SWARMSIM_AVX static int count(V m) { return laneCount(static_cast<unsigned>(_mm256_movemask_ps(m.a))); }
  SWARMSIM_AVX static void store(float* p, V x) { _mm256_storeu_ps(p, x.a); }
  SWARMSIM_AVX static void fold4(V x, float* p) {
    _mm_storeu_ps(p, _mm_add_ps(_mm256_castps256_ps128(x.a), _mm256_extractf128_ps(x.a, 1)));
  }
  // lane i + lane i+4 of two vectors: [p_lo + p_hi | q_lo + q_hi]
  SWARMSIM_AVX static __m256 fold(__m256 p, __m256 q) {
    return _mm256_add_ps(_mm256_permute2f128_ps(p, q, 0x20), _mm256_permute2f128_ps(p, q, 0x31));
  }
  // treeSum (below) of eight vectors at once, out[i] = treeSum(x[i]), the same additions of the same operands:
  // transposed, three vector additions where eight treeSums take twenty-four scalar ones
  SWARMSIM_AVX static void treeSums8(const V x[8], float* out) {
    // the pairs (0, 4), (1, 5), (2, 6), (3, 7): the last step's lanes come out as 0, 1, 2, 3 | 4, 5, 6, 7
    const __m256 f04 = fold(x[0].a, x[4].a), f15 = fold(x[1].a, x[5].a);
    const __m256 f26 = fold(x[2].a, x[6].a), f37 = fold(x[3].a, x[7].a);
    // f0 + f2 and f1 + f3 of each
    const __m256 s01 = _mm256_add_ps(_mm256_shuffle_ps(f04, f15, _MM_SHUFFLE(1, 0, 1, 0)),
                                     _mm256_shuffle_ps(f04, f15, _MM_SHUFFLE(3, 2, 3, 2)));
    const __m256 s23 = _mm256_add_ps(_mm256_shuffle_ps(f26, f37, _MM_SHUFFLE(1, 0, 1, 0)),
                                     _mm256_shuffle_ps(f26, f37, _MM_SHUFFLE(3, 2, 3, 2)));
    // (f0 + f2) + (f1 + f3)
    _mm256_storeu_ps(out, _mm256_add_ps(_mm256_shuffle_ps(s01, s23, _MM_SHUFFLE(2, 0, 2, 0)),
                                        _mm256_shuffle_ps(s01, s23, _MM_SHUFFLE(3, 1, 3, 1))));
  }
  SWARMSIM_AVX static V min(V x, V y) { return {_mm256_min_ps(x.a, y.a)}; }
  SWARMSIM_AVX static V gt(V x, V y) { return {_mm256_cmp_ps(x.a, y.a, _CMP_GT_OQ)}; }
  SWARMSIM_AVX static V bor(V x, V y) { return {_mm256_or_ps(x.a, y.a)}; }
  SWARMSIM_AVX static unsigned mask(V m) { return static_cast<unsigned>(_mm256_movemask_ps(m.a)); }
  SWARMSIM_AVX static V round(V x) { return {_mm256_cvtepi32_ps(_mm256_cvtps_epi32(x.a))}; }
  // AVX has no 256-bit integer arithmetic: the exponent is built in two SSE halves
  SWARMSIM_AVX static V pow2(V n) {
    const __m256i e = _mm256_cvtps_epi32(n.a);
    const __m128i bias = _mm_set1_epi32(127);
    const __m128i lo = _mm_slli_epi32(_mm_add_epi32(_mm256_castsi256_si128(e), bias), 23);
    const __m128i hi = _mm_slli_epi32(_mm_add_epi32(_mm256_extractf128_si256(e, 1), bias), 23);
    return {_mm256_castsi256_ps(_mm256_insertf128_si256(_mm256_castsi128_si256(lo), hi, 1))};
  }
};
#endif
// the same lanes in portable code (masks are all-one bit patterns, as in the SIMD versions)
struct ScalarLanes {
  struct V {
    float l[kLanes];
  };
  template <typename F>
  static V map(V x, V y, F f) {
    V r;
    for (std::size_t i = 0; i < kLanes; ++i) r.l[i] = f(x.l[i], y.l[i]);
    return r;
  }
  static float bits(std::uint32_t u) {
    float f;
    std::memcpy(&f, &u, sizeof f);
    return f;
  }
  static std::uint32_t bits(float f) {
    std::uint32_t u;
    std::memcpy(&u, &f, sizeof u);
    return u;
  }
  static V load(const float* p) {
    V r;
    std::copy(p, p + kLanes, r.l);
    return r;
  }
  static V set1(float x) {
    V r;
    std::fill(r.l, r.l + kLanes, x);
    return r;
  }
  static V add(V x, V y) {
    return map(x, y, [](float a, float b) { return a + b; });
  }
  static V sub(V x, V y) {
    return map(x, y, [](float a, float b) { return a - b; });
  }
  static V mul(V x, V y) {
    return map(x, y, [](float a, float b) { return a * b; });
  }
  static V div(V x, V y) {
    return map(x, y, [](float a, float b) { return a / b; });
  }
  static V max(V x, V y) {
    return map(x, y, [](float a, float b) { return a > b ? a : b; });
  }
  static V sqrt(V x) {
    return map(x, x, [](float a, float) { return std::sqrt(a); });
  }
  static V lt(V x, V y) {
    return map(x, y, [](float a, float b) { return bits(a < b ? ~0u : 0u); });
  }
  static V le(V x, V y) {
    return map(x, y, [](float a, float b) { return bits(a <= b ? ~0u : 0u); });
  }
  static V band(V x, V y) {
    return map(x, y, [](float a, float b) { return bits(bits(a) & bits(b)); });
  }
  static V andnot(V x, V y) {
    return map(x, y, [](float a, float b) { return bits(~bits(a) & bits(b)); });
  }
  static int count(V m) {
    int c = 0;
    for (const float f : m.l) c += bits(f) ? 1 : 0;
    return c;
  }
  static void store(float* p, V x) { std::copy(x.l, x.l + kLanes, p); }
  static void fold4(V x, float* p) {
    for (std::size_t i = 0; i < 4; ++i) p[i] = x.l[i] + x.l[i + 4];
  }
  static V min(V x, V y) {
    return map(x, y, [](float a, float b) { return a < b ? a : b; });
  }
  static V gt(V x, V y) {
    return map(x, y, [](float a, float b) { return bits(a > b ? ~0u : 0u); });
  }
  static V bor(V x, V y) {
    return map(x, y, [](float a, float b) { return bits(bits(a) | bits(b)); });
  }
  static unsigned mask(V m) {
    unsigned r = 0;
    for (std::size_t i = 0; i < kLanes; ++i) r |= (bits(m.l[i]) >> 31) << i;
    return r;
  }
  static V round(V x) {
    return map(x, x, [](float a, float) { return std::nearbyint(a); });
  }
  static V pow2(V n) {
    return map(n, n, [](float a, float) { return bits(static_cast<std::uint32_t>(static_cast<int>(a) + 127) << 23); });
  }
};


// the sum of a vector's lanes in a fixed tree order, (l0 + l4) + (l2 + l6) + ((l1 + l5) + (l3 + l7)), the same
// bits for every lane type
template <typename L>
__attribute__((always_inline)) inline float treeSum(typename L::V x) {
  alignas(16) float f[4];
  L::fold4(x, f);
  return (f[0] + f[2]) + (f[1] + f[3]);
}

template <typename L, typename = void>
struct HasTreeSums8 : std::false_type {};
template <typename L>
struct HasTreeSums8<L, std::void_t<decltype(L::treeSums8(nullptr, nullptr))>> : std::true_type {};

// out[i] = treeSum(x[i]) for i < 8: the lane type's own treeSums8 where it has one
template <typename L>
__attribute__((always_inline)) inline void treeSums8(const typename L::V x[8], float* out) {
  if constexpr (HasTreeSums8<L>::value) {
    L::treeSums8(x, out);
  } else {
    for (int i = 0; i < 8; ++i) out[i] = treeSum<L>(x[i]);
  }
}

// the bits of lanes 0..n-1 of a `width`-lane vector (all of them for n >= width)
constexpr unsigned firstLanes(std::size_t n, std::size_t width) {
  return n >= width ? (1u << width) - 1u : (1u << n) - 1u;
}

// 0, 1, ..., 7: lt(load(kLaneIndex), set1(c)) is the mask of lanes 0..c-1
alignas(32) inline constexpr float kLaneIndex[kLanes] = {0.0f, 1.0f, 2.0f, 3.0f, 4.0f, 5.0f, 6.0f, 7.0f};

inline bool useAvx() {
#if SWARMSIM_X86_LANES
  static const bool avx = __builtin_cpu_supports("avx");
  return avx && !std::getenv("SWARMSIM_NO_AVX");
#else
  return false;
#endif
}

// the widest lanes this CPU has, for kernels with AVX2 or AVX-512 variants (SWARMSIM_NO_AVX=1: SSE;
// SWARMSIM_NO_AVX2=1: AVX at most; SWARMSIM_NO_AVX512=1: AVX2 at most). Every variant of a kernel gives the same
// bits; a kernel without an AVX-512 variant takes its AVX2 one for kAvx512.
enum class LaneSet { kSse, kAvx, kAvx2, kAvx512 };
inline LaneSet laneSet() {
#if SWARMSIM_X86_LANES
  if (!useAvx()) return LaneSet::kSse;
  static const bool avx2 = __builtin_cpu_supports("avx2"), avx512 = __builtin_cpu_supports("avx512f");
  if (!avx2 || std::getenv("SWARMSIM_NO_AVX2")) return LaneSet::kAvx;
  return avx512 && !std::getenv("SWARMSIM_NO_AVX512") ? LaneSet::kAvx512 : LaneSet::kAvx2;
#else
  return LaneSet::kSse;
#endif
}

#if SWARMSIM_X86_LANES
// entry points and helpers that use AVX2 (and POPCNT, which every AVX2 CPU has); laneSet() says when
#define SWARMSIM_AVX2 __attribute__((target("avx2,popcnt")))
// entry points and helpers that use AVX-512 (laneSet() == kAvx512). AVX-512F has fused multiply-adds: a file
// with such entries is compiled with -ffp-contract=off (lib/CMakeLists.txt), so that they give the other
// lanes' bits
#define SWARMSIM_AVX512 __attribute__((target("avx512f,avx2,fma,popcnt")))

// Sixteen float lanes in one AVX-512 register (laneSet() == kAvx512), each computed exactly as AvxLanes computes
// it, for kernels that take sixteen at a time and add their halves to eight lanes' sums in the eight-lane order.
// (The zero-masked forms where GCC 12 warns about the undefined vector the unmasked ones start from.)
struct Avx512Lanes {
  struct V {
    __m512 a;
  };
  static constexpr std::size_t kWidth = 16;
  SWARMSIM_AVX512 static V load(const float* p) { return {_mm512_loadu_ps(p)}; }
  SWARMSIM_AVX512 static V set1(float x) { return {_mm512_set1_ps(x)}; }
  SWARMSIM_AVX512 static V add(V x, V y) { return {_mm512_add_ps(x.a, y.a)}; }
  SWARMSIM_AVX512 static V sub(V x, V y) { return {_mm512_sub_ps(x.a, y.a)}; }
  SWARMSIM_AVX512 static V mul(V x, V y) { return {_mm512_mul_ps(x.a, y.a)}; }
  SWARMSIM_AVX512 static V min(V x, V y) { return {_mm512_maskz_min_ps(0xffff, x.a, y.a)}; }
  SWARMSIM_AVX512 static V max(V x, V y) { return {_mm512_maskz_max_ps(0xffff, x.a, y.a)}; }
  SWARMSIM_AVX512 static V sqrt(V x) { return {_mm512_maskz_sqrt_ps(0xffff, x.a)}; }
  SWARMSIM_AVX512 static __m512i toInt(V x) { return _mm512_maskz_cvtps_epi32(0xffff, x.a); }  // to nearest
  SWARMSIM_AVX512 static V round(V x) { return {_mm512_maskz_cvtepi32_ps(0xffff, toInt(x))}; }
  SWARMSIM_AVX512 static V pow2(V n) {
    return {_mm512_castsi512_ps(_mm512_maskz_slli_epi32(0xffff, _mm512_add_epi32(toInt(n), _mm512_set1_epi32(127)), 23))};
  }
  // x <= y, x < y, x >= y per lane as bits (lane l: bit l)
  SWARMSIM_AVX512 static unsigned le(V x, V y) { return _mm512_cmp_ps_mask(x.a, y.a, _CMP_LE_OQ); }
  SWARMSIM_AVX512 static unsigned lt(V x, V y) { return _mm512_cmp_ps_mask(x.a, y.a, _CMP_LT_OQ); }
  SWARMSIM_AVX512 static unsigned ge(V x, V y) { return _mm512_cmp_ps_mask(x.a, y.a, _CMP_GE_OQ); }
  // lanes 0..7 and 8..15 as eight lanes each
  SWARMSIM_AVX512 static void halves(V x, AvxLanes::V& lo, AvxLanes::V& hi) {
    alignas(64) float t[16];
    _mm512_store_ps(t, x.a);
    lo = AvxLanes::load(t);
    hi = AvxLanes::load(t + 8);
  }
};

// for each 8-lane mask, the numbers of its set lanes in order (the rest 0): a table that packs them
struct LanePackTable {
  alignas(32) std::uint32_t lanes[256][kLanes];
  constexpr LanePackTable() : lanes() {
    for (unsigned mask = 0; mask < 256; ++mask) {
      unsigned n = 0;
      for (unsigned l = 0; l < kLanes; ++l) {
        if (mask & (1u << l)) lanes[mask][n++] = l;
      }
    }
  }
};
inline constexpr LanePackTable kLanePack;

// base + l for each set lane l of `mask`, in order, to out[0, popcount(mask)); writes 8 entries (out needs
// room for them); returns how many were set. The same result as a loop over the set bits.
SWARMSIM_AVX2 inline std::size_t packLaneIndices(std::uint32_t base, unsigned mask, std::uint32_t* out) {
  const __m256i pick = _mm256_load_si256(reinterpret_cast<const __m256i*>(kLanePack.lanes[mask]));
  const __m256i v = _mm256_add_epi32(_mm256_set1_epi32(static_cast<int>(base)), pick);
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(out), v);
  return static_cast<std::size_t>(__builtin_popcount(mask));
}
// the values in[l] of the set lanes l of `mask`, in order, to out[0, popcount) (writes 8 floats); the count.
// (in: eight floats in memory, so that no function without the AVX target passes an AVX vector)
SWARMSIM_AVX2 inline std::size_t packLaneFloats(unsigned mask, const float* in, float* out) {
  const __m256i pick = _mm256_load_si256(reinterpret_cast<const __m256i*>(kLanePack.lanes[mask]));
  _mm256_storeu_ps(out, _mm256_permutevar8x32_ps(_mm256_loadu_ps(in), pick));
  return static_cast<std::size_t>(__builtin_popcount(mask));
}
#endif

// base + l for each set lane l of `mask`, in order, to out[0, count); returns the count. kAvx2: by
// packLaneIndices (which writes 8 entries; only inside SWARMSIM_AVX2 entries), else a loop over the set bits
template <bool kAvx2>
inline std::size_t packSetLanes(std::uint32_t base, unsigned mask, std::uint32_t* out) {
#if SWARMSIM_X86_LANES
  if constexpr (kAvx2) return packLaneIndices(base, mask, out);
#endif
  std::size_t n = 0;
  for (; mask; mask &= mask - 1u) out[n++] = base + static_cast<std::uint32_t>(__builtin_ctz(mask));
  return n;
}

// c[0] z^(N-1) + ... + c[N-1] by Horner's rule, per lane: p = c[0], then p = p z + c[i] (each step a
// multiplication, then an addition: the same bits on every lane type)
template <typename L, std::size_t N>
__attribute__((always_inline)) inline typename L::V hornerLanes(typename L::V z, const float (&c)[N]) {
  typename L::V p = L::set1(c[0]);
  for (std::size_t i = 1; i < N; ++i) p = L::add(L::mul(p, z), L::set1(c[i]));
  return p;
}

// e^x per lane (x clamped to [-87, 88]): x = n ln 2 + g with integer n = round(x log2 e) and |g| <= ln 2 / 2
// (ln 2 in two parts, Cody and Waite, so g is nearly exact), then 2^n times the degree-7 Taylor polynomial
// of e^g: relative error about 2e-7 at most. Written in lane operations only, so every lane type gives
// the same bits.
template <typename L>
__attribute__((always_inline)) inline typename L::V expLanes(typename L::V x) {
  using V = typename L::V;
  x = L::min(L::max(x, L::set1(-87.0f)), L::set1(88.0f));
  const V n = L::round(L::mul(x, L::set1(1.44269504f)));
  const V g = L::sub(L::sub(x, L::mul(n, L::set1(0.693359375f))), L::mul(n, L::set1(-2.12194440e-4f)));
  constexpr float kTaylor[] = {1.0f / 5040.0f, 1.0f / 720.0f, 1.0f / 120.0f, 1.0f / 24.0f,
                               1.0f / 6.0f,    0.5f,          1.0f,          1.0f};
  return L::mul(hornerLanes<L>(g, kTaylor), L::pow2(n));
}

// a where the mask m is set, else b (masks as the compares make them)
template <typename L>
__attribute__((always_inline)) inline typename L::V selectLanes(typename L::V m, typename L::V a, typename L::V b) {
  return L::bor(L::band(m, a), L::andnot(m, b));
}

// ln x per lane for x in [2^-31, 1] (the Box-Muller draws' 1 - u): x = m 2^e with m in [√½, √2), found by
// scaling x by 2^16, 2^8, 2^4, 2^2, 2^1 where it is below the matching power (exact), then ln m = 2 s (1 + s²/3
// + ... + s¹⁰/11) with s = (m − 1) / (m + 1), |s| <= 0.172, and e ln 2 in two parts (Cody and Waite): error a
// few units in the last place. Lane operations only: every lane type gives the same bits.
template <typename L>
__attribute__((always_inline)) inline typename L::V logUnitLanes(typename L::V x) {
  using V = typename L::V;
  V m = x, e = L::set1(0.0f);
  for (const int k : {16, 8, 4, 2, 1}) {
    const float up = static_cast<float>(1u << k);
    const V below = L::lt(m, L::set1(1.0f / up));
    m = selectLanes<L>(below, L::mul(m, L::set1(up)), m);
    e = selectLanes<L>(below, L::sub(e, L::set1(static_cast<float>(k))), e);
  }
  const V low = L::lt(m, L::set1(0.70710678f));
  m = selectLanes<L>(low, L::add(m, m), m);
  e = selectLanes<L>(low, L::sub(e, L::set1(1.0f)), e);
  const V s = L::div(L::sub(m, L::set1(1.0f)), L::add(m, L::set1(1.0f)));
  const V z = L::mul(s, s);
  constexpr float kSeries[] = {1.0f / 11.0f, 1.0f / 9.0f, 1.0f / 7.0f, 1.0f / 5.0f, 1.0f / 3.0f, 1.0f};
  const V lnm = L::mul(L::add(s, s), hornerLanes<L>(z, kSeries));
  return L::add(L::mul(e, L::set1(0.693359375f)), L::add(L::mul(e, L::set1(-2.12194440e-4f)), lnm));
}

// cos 2πu and sin 2πu per lane for u in [0, 1]: t = u − round(u) in [−½, ½], q = round(4 t) (the quarter turn)
// and r = t − q/4 in [−⅛, ⅛] (both exact), θ = 2π r, Taylor polynomials of cos θ (to θ¹⁰) and sin θ (to θ⁹),
// then the quarter turn's swap and signs: error about 1e-7. Lane operations only (the same bits on every lane
// type).
template <typename L>
__attribute__((always_inline)) inline void cosSinTurnLanes(typename L::V u, typename L::V& c, typename L::V& s) {
  using V = typename L::V;
  const V t = L::sub(u, L::round(u));
  const V q = L::round(L::mul(t, L::set1(4.0f)));
  const V th = L::mul(L::sub(t, L::mul(q, L::set1(0.25f))), L::set1(6.28318531f));
  const V z = L::mul(th, th);
  constexpr float kCos[] = {-1.0f / 3628800.0f, 1.0f / 40320.0f, -1.0f / 720.0f, 1.0f / 24.0f, -0.5f, 1.0f};
  constexpr float kSin[] = {1.0f / 362880.0f, -1.0f / 5040.0f, 1.0f / 120.0f, -1.0f / 6.0f, 1.0f};
  const V pc = hornerLanes<L>(z, kCos), ps = L::mul(hornerLanes<L>(z, kSin), th);
  // q = ±1: cos and sin swap; cos < 0 for q = 1 or ±2, sin < 0 for q = −1 or ±2
  const V half = L::set1(0.5f), threeHalves = L::set1(1.5f);
  const V plus1 = L::band(L::gt(q, half), L::lt(q, threeHalves));
  const V minus1 = L::band(L::lt(q, L::set1(-0.5f)), L::gt(q, L::set1(-1.5f)));
  const V two = L::bor(L::gt(q, threeHalves), L::lt(q, L::set1(-1.5f)));
  const V swap = L::bor(plus1, minus1);
  const V cs = selectLanes<L>(swap, ps, pc), sn = selectLanes<L>(swap, pc, ps);
  const V zero = L::set1(0.0f);
  c = selectLanes<L>(L::bor(plus1, two), L::sub(zero, cs), cs);
  s = selectLanes<L>(L::bor(minus1, two), L::sub(zero, sn), sn);
}

}  // namespace swarmsim
