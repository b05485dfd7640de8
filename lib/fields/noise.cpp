#include "fields/noise.hpp"

#include "core/lanes.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <utility>

namespace swarmsim {

namespace {

// splitmix64 (Steele, Lea & Flood 2014): a 64-bit counter passed through a bijective mixer
std::uint64_t splitmix64(std::uint64_t& state) {
  std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

// the 12 cube-edge directions, padded to 16 with four of them (a regular tetrahedron,
// as in Perlin 2002) so a hash picks one with `& 15`
constexpr double kGrad[16][3] = {
    {1, 1, 0}, {-1, 1, 0}, {1, -1, 0}, {-1, -1, 0}, {1, 0, 1}, {-1, 0, 1}, {1, 0, -1}, {-1, 0, -1},
    {0, 1, 1}, {0, -1, 1}, {0, 1, -1}, {0, -1, -1}, {1, 1, 0}, {-1, 1, 0}, {0, -1, 1}, {0, -1, -1},
};

// 1 / (largest reachable magnitude, 1.036354, rounded up): see noise.hpp
constexpr double kNormalize = 1.0 / 1.0364;

// The arithmetic below is written once for one point (T = double) and for a batch of points, one per lane of
// a GCC vector (T = V4 or V2): IEEE addition, subtraction and multiplication are exactly rounded per lane, so the
// same operations in the same order give withGradientLanes the bits of withGradient. This file is compiled
// with -ffp-contract=off (lib/CMakeLists.txt): with FMA available (-march=native) the compiler could otherwise
// fuse a multiply and an add in one path and not in the other.
//
// A batch of PerlinNoise3::kLanes points is one V4 (an AVX register: the entry with target("avx")) or, without
// AVX, two halves of one V2 (an SSE2 register) each: a V4 there would take two registers per value, and the
// blend's values would no longer fit in the 16 registers (that spilling made the SSE2 batch a third slower).
// The functions taking vectors are internal and always inlined into each entry, so no call passes a 32-byte
// vector, whose ABI would depend on AVX (-Wno-psabi, lib/CMakeLists.txt, silences GCC's note about that ABI).
typedef double V4 __attribute__((vector_size(32)));
typedef double V2 __attribute__((vector_size(16)));
typedef double V8 __attribute__((vector_size(64)));
#if SWARMSIM_X86_LANES
// the wide batch's entry (zero-masked intrinsics where GCC 12 warns about the undefined vector the unmasked
// ones start from)
#define SWARMSIM_NOISE_WIDE __attribute__((target("avx512f,avx2")))
#endif
static_assert(PerlinNoise3::kLanes == 4, "V4 holds one batch");

// Every function that takes or returns a vector is always inlined: a call passing one would depend on the
// caller's instruction set for its ABI (in the clang ASan build, flatten alone left some of them as calls,
// and the AVX entry then computed wrong values: tests/noise_batch_test.cpp caught it).
#define SWARMSIM_LANE_INLINE inline __attribute__((always_inline))

template <typename T>
SWARMSIM_LANE_INLINE T fade(T t) {
  return t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
}
template <typename T>
SWARMSIM_LANE_INLINE T dfade(T t) {  // fade'(t) = 30 t^2 (t - 1)^2
  return 30.0 * t * t * (t - 1.0) * (t - 1.0);
}
template <typename T>
SWARMSIM_LANE_INLINE T lerp(T a, T b, T t) {
  return a + t * (b - a);
}
// g · (tx, ty, tz) for a corner gradient g (three doubles, or three lanes)
template <typename G, typename T>
SWARMSIM_LANE_INLINE T dot(const G& g, T tx, T ty, T tz) {
  return g[0] * tx + g[1] * ty + g[2] * tz;
}
inline double dotGrad(int hash, double x, double y, double z) { return dot(kGrad[hash & 15], x, y, z); }

// the lattice cell index along an axis, wrapped to the table's period, from the floor of the coordinate
inline int wrapCell(double f) { return static_cast<int>(static_cast<long long>(f) & 255); }

// the gradients at the 8 corners of cell (X, Y, Z), in the order of blend()
inline void cornerGradients(const std::uint8_t* perm, int X, int Y, int Z, const double* G[8]) {
  const int a = perm[X] + Y, aa = perm[a] + Z, ab = perm[a + 1] + Z;
  const int b = perm[X + 1] + Y, ba = perm[b] + Z, bb = perm[b + 1] + Z;
  G[0] = kGrad[perm[aa] & 15];
  G[1] = kGrad[perm[ba] & 15];
  G[2] = kGrad[perm[ab] & 15];
  G[3] = kGrad[perm[bb] & 15];
  G[4] = kGrad[perm[aa + 1] & 15];
  G[5] = kGrad[perm[ba + 1] & 15];
  G[6] = kGrad[perm[ab + 1] & 15];
  G[7] = kGrad[perm[bb + 1] & 15];
}

// withGradient's interpolation and its derivative, the value normalised but not clamped. G[c][a]: component a
// of the gradient at corner c, the corners named by (c_x, c_y, c_z) in the order 000, 100, 010, 110, 001, 101,
// 011, 111; (x, y, z) the offset in the cell, (u, v, w) its fades and (du, dv, dw) their derivatives.
template <typename T, typename Corners>
SWARMSIM_LANE_INLINE T blend(const Corners& G, T x, T y, T z, T u, T v, T w, T du, T dv, T dw, T grad[3]) {
  // corner values g = G · (t − c)
  const T g000 = dot(G[0], x, y, z), g100 = dot(G[1], x - 1.0, y, z);
  const T g010 = dot(G[2], x, y - 1.0, z), g110 = dot(G[3], x - 1.0, y - 1.0, z);
  const T g001 = dot(G[4], x, y, z - 1.0), g101 = dot(G[5], x - 1.0, y, z - 1.0);
  const T g011 = dot(G[6], x, y - 1.0, z - 1.0), g111 = dot(G[7], x - 1.0, y - 1.0, z - 1.0);

  // the same blend as operator() (so the values agree bit for bit)
  const T x00 = lerp(g000, g100, u), x10 = lerp(g010, g110, u);
  const T x01 = lerp(g001, g101, u), x11 = lerp(g011, g111, u);
  const T y0 = lerp(x00, x10, v), y1 = lerp(x01, x11, v);
  const T value = lerp(y0, y1, w) * kNormalize;

  // d/dt of the blend: the weights' derivatives times the corner values, plus
  // the weights times the corner gradients
  const T dx00 = g100 - g000, dx10 = g110 - g010, dx01 = g101 - g001, dx11 = g111 - g011;
  const T dy0 = x10 - x00, dy1 = x11 - x01;
  const T dValue[3] = {
      du * lerp(lerp(dx00, dx10, v), lerp(dx01, dx11, v), w),
      dv * lerp(dy0, dy1, w),
      dw * (y1 - y0),
  };
  for (int c = 0; c < 3; ++c) {
    const T l00 = lerp(G[0][c], G[1][c], u), l10 = lerp(G[2][c], G[3][c], u);
    const T l01 = lerp(G[4][c], G[5][c], u), l11 = lerp(G[6][c], G[7][c], u);
    grad[c] = (dValue[c] + lerp(lerp(l00, l10, v), lerp(l01, l11, v), w)) * kNormalize;
  }
  return value;
}

template <typename V>
SWARMSIM_LANE_INLINE V load(const double* p) {
  V v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
template <typename V>
SWARMSIM_LANE_INLINE void store(double* p, V v) {
  std::memcpy(p, &v, sizeof v);
}
// std::floor per lane, exactly, in plain arithmetic (SSE2 has no rounding instruction, and a libm call per
// lane would cost more than the lane saves): for |t| < 2^52, (t + c) − c with c = 2^52 of t's sign is t
// rounded to an integer, one too high where it rounded up. floor(t) has the sign of t, −0 for −0 included,
// which that sum turns into +0: t's sign bit is put back (a no-op on the nonzero results). Larger |t|,
// infinities and NaN are their own floor.
template <typename V>
SWARMSIM_LANE_INLINE V floorLanes(V t) {
  using I = decltype(t < t);  // 64-bit integer lanes, for the bits
  constexpr std::int64_t kSign = std::numeric_limits<std::int64_t>::min();
  constexpr std::int64_t kTwo52 = 0x4330000000000000;  // the bits of 2^52
  const I bits = __builtin_bit_cast(I, t);
  const I sign = bits & kSign;
  const V c = __builtin_bit_cast(V, sign | kTwo52);
  V r = (t + c) - c;
  r = r > t ? r - 1.0 : r;
  r = __builtin_bit_cast(V, __builtin_bit_cast(I, r) | sign);
  return __builtin_bit_cast(V, bits & ~kSign) < 0x1p52 ? r : t;
}

}  // namespace

// withGradientLanes' body, inlined (flatten) into one entry per instruction set
struct PerlinNoise3::Lanes {
  // the batch's lanes first, ..., first + width - 1 (width: the doubles in V)
  template <typename V>
  SWARMSIM_LANE_INLINE static void run(const PerlinNoise3* noises, int count, const double* px, const double* py, const double* pz,
                  double* value, double* gx, double* gy, double* gz, int first) {
    constexpr int W = sizeof(V) / sizeof(double);
    // what depends on the points only: the cells, the offsets in them, the fades and their derivatives
    const V p[3] = {load<V>(px + first), load<V>(py + first), load<V>(pz + first)};
    int cell[3][W];
    V t[3], f[3], df[3];
    for (int a = 0; a < 3; ++a) {
      const V fl = floorLanes(p[a]);
      for (int l = 0; l < W; ++l) cell[a][l] = wrapCell(fl[l]);
      t[a] = p[a] - fl;
      f[a] = fade(t[a]);
      df[a] = dfade(t[a]);
    }
    double* const out[3] = {gx, gy, gz};
    for (int k = 0; k < count; ++k) {
      // the corner gradients, looked up per lane: g[l][c], corner c of point l
      const std::uint8_t* perm = noises[k].perm_.data();
      const double* g[W][8];
      for (int l = 0; l < W; ++l) cornerGradients(perm, cell[0][l], cell[1][l], cell[2][l], g[l]);
      // (vectors built whole: GCC takes lanes assigned one by one for possibly uninitialised reads)
      const auto lanes = [&g](int c, int a) __attribute__((always_inline)) {
        if constexpr (W == 4) {
          return V{g[0][c][a], g[1][c][a], g[2][c][a], g[3][c][a]};
        } else {
          return V{g[0][c][a], g[1][c][a]};
        }
      };
      const V G[8][3] = {
          {lanes(0, 0), lanes(0, 1), lanes(0, 2)}, {lanes(1, 0), lanes(1, 1), lanes(1, 2)},
          {lanes(2, 0), lanes(2, 1), lanes(2, 2)}, {lanes(3, 0), lanes(3, 1), lanes(3, 2)},
          {lanes(4, 0), lanes(4, 1), lanes(4, 2)}, {lanes(5, 0), lanes(5, 1), lanes(5, 2)},
          {lanes(6, 0), lanes(6, 1), lanes(6, 2)}, {lanes(7, 0), lanes(7, 1), lanes(7, 2)},
      };
      V grad[3];
      const V v = blend(G, t[0], t[1], t[2], f[0], f[1], f[2], df[0], df[1], df[2], grad);
      const int at = k * kLanes + first;
      for (int a = 0; a < 3; ++a) store(out[a] + at, grad[a]);
      if (value) {
        for (int l = 0; l < W; ++l) value[at + l] = std::clamp(v[l], -1.0, 1.0);
      }
    }
  }

  __attribute__((flatten)) static void baseline(const PerlinNoise3* noises, int count, const double* px,
                                                const double* py, const double* pz, double* value, double* gx,
                                                double* gy, double* gz) {
    run<V2>(noises, count, px, py, pz, value, gx, gy, gz, 0);
    run<V2>(noises, count, px, py, pz, value, gx, gy, gz, 2);
  }
#if SWARMSIM_X86_LANES
  SWARMSIM_AVX __attribute__((flatten)) static void avx(const PerlinNoise3* noises, int count, const double* px,
                                                        const double* py, const double* pz, double* value, double* gx,
                                                        double* gy, double* gz) {
    run<V4>(noises, count, px, py, pz, value, gx, gy, gz, 0);
  }

  // The wide batch's generic halves. No vector crosses between them and the AVX-512 entry below (only
  // pointers to doubles do): clang refuses a call passing a 64-byte vector between a function with
  // AVX-512 and one without, and the generic code cannot carry the AVX-512 attribute (the scalar and
  // narrower lanes share it). Inlined into the entry, they compile to its instructions.
  //
  // the points' cells (wrapped), offsets, fades and their derivatives, per lane
  template <typename V>
  SWARMSIM_LANE_INLINE static void wideLattice(const double* px, const double* py, const double* pz,
                                               int cell[3][kWideLanes], double t[3][kWideLanes],
                                               double f[3][kWideLanes], double df[3][kWideLanes]) {
    const V p[3] = {load<V>(px), load<V>(py), load<V>(pz)};
    for (int a = 0; a < 3; ++a) {
      const V fl = floorLanes(p[a]);
      for (int l = 0; l < kWideLanes; ++l) cell[a][l] = wrapCell(fl[l]);
      const V ta = p[a] - fl;
      store(t[a], ta);
      store(f[a], fade(ta));
      store(df[a], dfade(ta));
    }
  }
  // blend() of one noise from its corners' gradients G[c][a][l] to (gx, gy, gz)[l]
  template <typename V>
  SWARMSIM_LANE_INLINE static void wideBlend(const double G[8][3][kWideLanes], const double t[3][kWideLanes],
                                             const double f[3][kWideLanes], const double df[3][kWideLanes],
                                             double* gx, double* gy, double* gz) {
    V g[8][3];
    for (int c = 0; c < 8; ++c) {
      for (int a = 0; a < 3; ++a) g[c][a] = load<V>(G[c][a]);
    }
    V grad[3];
    blend(g, load<V>(t[0]), load<V>(t[1]), load<V>(t[2]), load<V>(f[0]), load<V>(f[1]), load<V>(f[2]),
          load<V>(df[0]), load<V>(df[1]), load<V>(df[2]), grad);
    store(gx, grad[0]);
    store(gy, grad[1]);
    store(gz, grad[2]);
  }

  // The eight lanes' corner rows of one noise by byte permutes (AVX-512 VBMI): perm_[i] is p[i mod 256] for
  // every index the hash forms (below 512), so the hash's sums wrap in bytes and each look-up is a permute of
  // the 256-byte table (two 128-byte halves, chosen by the index's top bit). The eight corners' indices come
  // out in cornerGradients' order (aa, ba, ab, bb, then each + 1), eight lanes each: rows[8 c + l].
#define SWARMSIM_NOISE_VBMI __attribute__((target("avx512f,avx512bw,avx512vl,avx512vbmi,avx2")))
  // p[i] of the table t0..t3 (256 bytes) for each byte i
  SWARMSIM_NOISE_VBMI SWARMSIM_LANE_INLINE static __m512i lookup(__m512i i, __m512i t0, __m512i t1, __m512i t2,
                                                                 __m512i t3) {
    const __m512i lo = _mm512_permutex2var_epi8(t0, i, t1), hi = _mm512_permutex2var_epi8(t2, i, t3);
    return _mm512_mask_blend_epi8(_mm512_movepi8_mask(i), lo, hi);
  }
  // (never inlined: wide()'s flatten would otherwise pull the VBMI instructions into a function without them,
  // which clang 14's back end fails on)
  SWARMSIM_NOISE_VBMI __attribute__((noinline)) static void hashRowsVbmi(const std::uint8_t* perm,
                                                                         const int cells[3][kWideLanes],
                                                                         std::uint8_t* rows) {
    const __m512i t0 = _mm512_loadu_si512(perm), t1 = _mm512_loadu_si512(perm + 64);
    const __m512i t2 = _mm512_loadu_si512(perm + 128), t3 = _mm512_loadu_si512(perm + 192);
    // each axis' cells as bytes, lanes 0..7: the low byte of each int, by a byte permute (clang 14's back end
    // fails on the truncating conversion here)
    const __m512i lowBytes = _mm512_set_epi64(0, 0, 0, 0, 0, 0, 0, 0x1c1814100c080400);
    __m128i c8[3];
    for (int a = 0; a < 3; ++a) {
      const __m512i ints = _mm512_castsi256_si512(_mm256_load_si256(reinterpret_cast<const __m256i*>(cells[a])));
      c8[a] = _mm512_maskz_extracti32x4_epi32(0xf, _mm512_maskz_permutexvar_epi8(~std::uint64_t{0}, lowBytes, ints), 0);
    }
    const __m128i one = _mm_set1_epi8(1);
    // [X | X + 1] -> [a | b] = p[·] + Y
    const __m128i x = _mm_unpacklo_epi64(c8[0], _mm_add_epi8(c8[0], one));
    const __m128i ab =
        _mm_add_epi8(_mm512_maskz_extracti32x4_epi32(0xf, lookup(_mm512_castsi128_si512(x), t0, t1, t2, t3), 0),
                     _mm_unpacklo_epi64(c8[1], c8[1]));
    // [a | b | a + 1 | b + 1] -> [aa | ba | ab | bb] = p[·] + Z
    const __m256i v2 = _mm256_inserti128_si256(_mm256_castsi128_si256(ab), _mm_add_epi8(ab, one), 1);
    const __m256i w =
        _mm256_add_epi8(_mm256_castpd_si256(_mm512_maskz_extractf64x4_pd(
                            0xf, _mm512_castsi512_pd(lookup(_mm512_castsi256_si512(v2), t0, t1, t2, t3)), 0)),
                        _mm256_broadcastq_epi64(c8[2]));
    // the corners: [w | w + 1], their rows p[·] & 15
    const __m512i v3 =
        _mm512_maskz_inserti64x4(0xff, _mm512_castsi256_si512(w), _mm256_add_epi8(w, _mm256_set1_epi8(1)), 1);
    _mm512_store_si512(rows, _mm512_and_si512(lookup(v3, t0, t1, t2, t3), _mm512_set1_epi8(15)));
  }

  // eight points on the eight doubles of an AVX-512 register: the hashes per lane, the corners' gradients
  // by two-register permutes (kGrad's 16 rows), the arithmetic the same generic code as every other batch
  SWARMSIM_NOISE_WIDE __attribute__((flatten)) static void wide(const PerlinNoise3* noises, int count, const double* px,
                                                                const double* py, const double* pz, double* gx,
                                                                double* gy, double* gz, bool vbmi) {
    alignas(64) int cells[3][kWideLanes];
    alignas(64) double t[3][kWideLanes], f[3][kWideLanes], df[3][kWideLanes];
    wideLattice<V8>(px, py, pz, cells, t, f, df);
    // kGrad's column a as two registers of eight rows
    __m512d col[3][2];
    for (int a = 0; a < 3; ++a) {
      alignas(64) double c[16];
      for (int r = 0; r < 16; ++r) c[r] = kGrad[r][a];
      col[a][0] = _mm512_load_pd(c);
      col[a][1] = _mm512_load_pd(c + 8);
    }
    // each noise's corner rows (hash & 15) per lane, rows[k][8 c + l]: by byte permutes where the CPU has
    // AVX-512 VBMI (hashRowsVbmi), else by cornerGradients' scalar look-ups (their short chains of loads are
    // quicker than vector gathers), three noises at a time, then the gradients as vectors
    alignas(64) std::uint8_t rows[3][8 * kWideLanes];
    alignas(64) double G[8][3][kWideLanes];
    for (int first = 0; first < count; first += 3) {
      const int group = std::min(3, count - first);
      for (int k = 0; k < group; ++k) {
        const std::uint8_t* perm = noises[first + k].perm_.data();
        if (vbmi) {
          hashRowsVbmi(perm, cells, rows[k]);
          continue;
        }
        for (int l = 0; l < kWideLanes; ++l) {
          const int X = cells[0][l], Y = cells[1][l], Z = cells[2][l];
          const int a = perm[X] + Y, aa = perm[a] + Z, ab = perm[a + 1] + Z;
          const int b = perm[X + 1] + Y, ba = perm[b] + Z, bb = perm[b + 1] + Z;
          const int corner[8] = {aa, ba, ab, bb, aa + 1, ba + 1, ab + 1, bb + 1};
          for (int c = 0; c < 8; ++c) rows[k][kWideLanes * c + l] = static_cast<std::uint8_t>(perm[corner[c]] & 15);
        }
      }
      for (int k = 0; k < group; ++k) {
        for (int c = 0; c < 8; ++c) {
          const __m512i row = _mm512_maskz_cvtepu8_epi64(
              0xff, _mm_loadl_epi64(reinterpret_cast<const __m128i*>(rows[k] + kWideLanes * c)));
          for (int d = 0; d < 3; ++d) _mm512_store_pd(G[c][d], _mm512_maskz_permutex2var_pd(0xff, col[d][0], row, col[d][1]));
        }
        const int at = (first + k) * kWideLanes;
        wideBlend<V8>(G, t, f, df, gx + at, gy + at, gz + at);
      }
    }
  }
#endif
};

PerlinNoise3::PerlinNoise3(std::uint64_t seed) {
  // Fisher–Yates shuffle of 0..255 (modulo bias of a 64-bit draw is below 2^-55)
  std::array<std::uint8_t, 256> p{};
  for (int i = 0; i < 256; ++i) p[i] = static_cast<std::uint8_t>(i);
  std::uint64_t state = seed;
  for (int i = 255; i > 0; --i) {
    const auto j = static_cast<int>(splitmix64(state) % static_cast<std::uint64_t>(i + 1));
    std::swap(p[i], p[j]);
  }
  for (int i = 0; i < 512; ++i) perm_[i] = p[i & 255];
}

double PerlinNoise3::operator()(const Vec3d& p) const {
  // lattice cell (wrapped to the table's period) and offset inside it
  const double fx = std::floor(p.x()), fy = std::floor(p.y()), fz = std::floor(p.z());
  const int X = wrapCell(fx), Y = wrapCell(fy), Z = wrapCell(fz);
  const double x = p.x() - fx, y = p.y() - fy, z = p.z() - fz;
  const double u = fade(x), v = fade(y), w = fade(z);

  // hashes of the 8 corners
  const int a = perm_[X] + Y, aa = perm_[a] + Z, ab = perm_[a + 1] + Z;
  const int b = perm_[X + 1] + Y, ba = perm_[b] + Z, bb = perm_[b + 1] + Z;

  // blend the corner contributions g · (t − c), x first, then y, then z
  const double x00 = lerp(dotGrad(perm_[aa], x, y, z), dotGrad(perm_[ba], x - 1, y, z), u);
  const double x10 = lerp(dotGrad(perm_[ab], x, y - 1, z), dotGrad(perm_[bb], x - 1, y - 1, z), u);
  const double x01 = lerp(dotGrad(perm_[aa + 1], x, y, z - 1), dotGrad(perm_[ba + 1], x - 1, y, z - 1), u);
  const double x11 = lerp(dotGrad(perm_[ab + 1], x, y - 1, z - 1), dotGrad(perm_[bb + 1], x - 1, y - 1, z - 1), u);
  const double value = lerp(lerp(x00, x10, v), lerp(x01, x11, v), w) * kNormalize;
  return std::clamp(value, -1.0, 1.0);  // a no-op but for rounding
}

double PerlinNoise3::withGradient(const Vec3d& p, Vec3d& grad) const {
  const double fx = std::floor(p.x()), fy = std::floor(p.y()), fz = std::floor(p.z());
  const double x = p.x() - fx, y = p.y() - fy, z = p.z() - fz;
  const double* G[8];
  cornerGradients(perm_.data(), wrapCell(fx), wrapCell(fy), wrapCell(fz), G);
  double g[3];
  const double value = blend(G, x, y, z, fade(x), fade(y), fade(z), dfade(x), dfade(y), dfade(z), g);
  grad = Vec3d(g[0], g[1], g[2]);
  return std::clamp(value, -1.0, 1.0);
}

void PerlinNoise3::withGradientLanes(const PerlinNoise3* noises, int count, const double* px, const double* py,
                                     const double* pz, double* value, double* gx, double* gy, double* gz, bool avx) {
#if SWARMSIM_X86_LANES
  if (avx) {
    Lanes::avx(noises, count, px, py, pz, value, gx, gy, gz);
    return;
  }
#endif
  (void)avx;
  Lanes::baseline(noises, count, px, py, pz, value, gx, gy, gz);
}

bool PerlinNoise3::batchAvx() {
#if SWARMSIM_X86_LANES
  static const bool cpu = __builtin_cpu_supports("avx");
  return cpu && !std::getenv("SWARMSIM_NO_AVX");
#else
  return false;
#endif
}

void PerlinNoise3::withGradientWide(const PerlinNoise3* noises, int count, const double* px, const double* py,
                                    const double* pz, double* gx, double* gy, double* gz, bool vbmi) {
#if SWARMSIM_X86_LANES
  Lanes::wide(noises, count, px, py, pz, gx, gy, gz, vbmi);
#else
  (void)noises, (void)count, (void)px, (void)py, (void)pz, (void)gx, (void)gy, (void)gz, (void)vbmi;
  throw std::logic_error("PerlinNoise3::withGradientWide without AVX-512");
#endif
}

bool PerlinNoise3::batchVbmi() {
#if SWARMSIM_X86_LANES
  static const bool cpu =
      __builtin_cpu_supports("avx512vbmi") && __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512vl");
  return cpu && !std::getenv("SWARMSIM_NO_VBMI");
#else
  return false;
#endif
}

bool PerlinNoise3::batchWide() {
#if SWARMSIM_X86_LANES
  static const bool cpu = __builtin_cpu_supports("avx512f");
  return cpu && laneSet() == LaneSet::kAvx512;
#else
  return false;
#endif
}

}  // namespace swarmsim
