#pragma once
// Minimum distance enforcement kernel (field model, section 6): the push on one
// agent from the agents of contiguous runs of a grid's sorted arrays.
//
// Every neighbour j closer than d_min moves the agent by half the deficit,
// away from j:  push -= (p_j - p) / d * (d_min - d) / 2,  d = |p_j - p|.
// The loop is branch-free in blocks of kLanes candidates with one partial sum
// per lane, which the compiler turns into SIMD code; the lanes are added in a
// fixed order at the end, so the result depends only on the data (never on
// threads). Candidates at distance 0 (the agent itself, or an exactly
// coincident agent) contribute nothing here and are counted in zeros(): more
// than one means a coincident pair, which the caller resolves separately.
#include <algorithm>
#include <cmath>
#include <cstdint>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "core/lanes.hpp"
#include "core/vec.hpp"

namespace swarmsim {

// One candidate at squared distance d2: true if 0 < d < d_min, with the weight
// w = (d_min - d) / (2 d) of its push contribution -offset w (the scalar
// counterpart of MdeLanes::weights, for the tails of the SIMD loops).
inline bool mdeWeight(float d2, float md, float md2, float& w) {
  if (!(d2 < md2 && d2 > 0.0f)) return false;
  const float d = std::sqrt(d2);
  w = 0.5f * (md - d) / d;
  return true;
}

#if defined(__SSE2__)
// Four candidates at once: from their offsets d = p_j - q, the weights w with
// push contribution -d w (w = (d_min - |d|) / (2 |d|) where 0 < |d| < d_min,
// else 0), the mask of those lanes and the mask of |d| = 0.
struct MdeLanes {
  __m128 md, md2, half, zero, tiny;
  explicit MdeLanes(float minDistance)
      : md(_mm_set1_ps(minDistance)),
        md2(_mm_set1_ps(minDistance * minDistance)),
        half(_mm_set1_ps(0.5f)),
        zero(_mm_setzero_ps()),
        tiny(_mm_set1_ps(1e-30f)) {}
  __m128 weights(__m128 dx, __m128 dy, __m128 dz, __m128& near, __m128& coincident) const {
    const __m128 d2 = _mm_add_ps(_mm_add_ps(_mm_mul_ps(dx, dx), _mm_mul_ps(dy, dy)), _mm_mul_ps(dz, dz));
    near = _mm_and_ps(_mm_cmplt_ps(d2, md2), _mm_cmpgt_ps(d2, zero));
    coincident = _mm_cmpeq_ps(d2, zero);
    const __m128 d = _mm_sqrt_ps(d2);
    return _mm_and_ps(near, _mm_div_ps(_mm_mul_ps(half, _mm_sub_ps(md, d)), _mm_max_ps(d, tiny)));
  }
};
#endif

class MdePush {
 public:
  explicit MdePush(float minDistance) : md_(minDistance), md2_(minDistance * minDistance) {}

  // the query point
  void start(float qx, float qy, float qz) {
    qx_ = qx;
    qy_ = qy;
    qz_ = qz;
    px_ = py_ = pz_ = 0.0f;
    hits_ = zeros_ = 0;
#if defined(__SSE2__)
    sx_ = sy_ = sz_ = _mm_setzero_ps();
    sh_ = s0_ = _mm_setzero_si128();
#endif
  }

  // candidates x[b, e), y[b, e), z[b, e)
  void add(const float* x, const float* y, const float* z, std::uint32_t b, std::uint32_t e) {
    std::uint32_t j = b;
#if defined(__SSE2__)
    const __m128 vqx = _mm_set1_ps(qx_), vqy = _mm_set1_ps(qy_), vqz = _mm_set1_ps(qz_);
    const MdeLanes lanes(md_);
    for (; j + 4 <= e; j += 4) {
      const __m128 dx = _mm_sub_ps(_mm_loadu_ps(x + j), vqx);
      const __m128 dy = _mm_sub_ps(_mm_loadu_ps(y + j), vqy);
      const __m128 dz = _mm_sub_ps(_mm_loadu_ps(z + j), vqz);
      __m128 near, coincident;
      const __m128 w = lanes.weights(dx, dy, dz, near, coincident);
      sx_ = _mm_sub_ps(sx_, _mm_mul_ps(dx, w));
      sy_ = _mm_sub_ps(sy_, _mm_mul_ps(dy, w));
      sz_ = _mm_sub_ps(sz_, _mm_mul_ps(dz, w));
      sh_ = _mm_sub_epi32(sh_, _mm_castps_si128(near));
      s0_ = _mm_sub_epi32(s0_, _mm_castps_si128(coincident));
    }
#endif
    for (; j < e; ++j) {
      const float dx = x[j] - qx_, dy = y[j] - qy_, dz = z[j] - qz_;
      const float d2 = dx * dx + dy * dy + dz * dz;
      zeros_ += d2 == 0.0f ? 1 : 0;
      float w;
      if (!mdeWeight(d2, md_, md2_, w)) continue;
      px_ -= dx * w;
      py_ -= dy * w;
      pz_ -= dz * w;
      ++hits_;
    }
  }

  // the summed push (scalar part, then the SIMD lanes in order)
  Vec3 push() const {
    Vec3 p(px_, py_, pz_);
#if defined(__SSE2__)
    alignas(16) float lx[4], ly[4], lz[4];
    _mm_store_ps(lx, sx_);
    _mm_store_ps(ly, sy_);
    _mm_store_ps(lz, sz_);
    for (int l = 0; l < 4; ++l) p += Vec3(lx[l], ly[l], lz[l]);
#endif
    return p;
  }
  // neighbours closer than d_min (distance 0 excluded)
  int hits() const { return hits_ + laneSum(sh_); }
  // candidates at distance exactly 0 (the agent itself included)
  int zeros() const { return zeros_ + laneSum(s0_); }

 private:
#if defined(__SSE2__)
  static int laneSum(__m128i v) {
    alignas(16) std::int32_t l[4];
    _mm_store_si128(reinterpret_cast<__m128i*>(l), v);
    return l[0] + l[1] + l[2] + l[3];
  }
  __m128 sx_, sy_, sz_;
  __m128i sh_, s0_;
#else
  static int laneSum(int) { return 0; }
  int sh_ = 0, s0_ = 0;
#endif
  float md_, md2_;
  float qx_ = 0.0f, qy_ = 0.0f, qz_ = 0.0f;
  float px_ = 0.0f, py_ = 0.0f, pz_ = 0.0f;
  int hits_ = 0, zeros_ = 0;
};

// The paper's rule (section 6): every pair within one run [b, e) of sorted points (one grid cell), each pair
// examined once. Writes the pushes of the run's points to px/py/pz[b, e) and their counts of neighbours closer
// than d_min to hits[b, e). Pair (k, j), k < j, moves k by -f and j by +f with
//   f = (p_j - p_k) / d * (d_min - d) / 2.
// Two passes over the cell: first, for each point k in turn, the squared distances of its later points, eight at
// a time, with the pairs (k, j) closer than d_min listed (compacted, without a branch); then each listed pair's
// push, in the list's order. So no square root or division is spent on the many pairs that are not close, each
// point's push is stored once per close pair, and the second pass is one loop over the cell's close pairs.
// (Blocks of four pairs that each stored into px[j..j+3] made the next point's blocks load at an offset of one
// from those stores, a failed store-to-load forwarding each time; and a second pass per point, of zero to a few
// pairs, mispredicted its loop's end: on scenarios/locusts_1m.json the whole step gained about 7 % from the
// first pass and 15 % more from the one loop over the pairs, 1 thread.) A
// point's push adds its pairs' contributions in the list's order, its pairs with earlier points of the run
// first (by the earlier point, ascending), then its pairs with later ones (ascending), so the result depends
// only on the data. x, y and z are read up to seven entries past e (the field model's group scratch has
// them; their values do not matter). `lanes`: laneSet(); AVX2 compacts the lists where it is kAvx2 or kAvx512, with
// the same lists and so the same bits. Returns true if two points of the run coincide exactly: those pairs are
// left to the caller (they need an agent order).
bool mdeCellPairs(const float* x, const float* y, const float* z, std::uint32_t b, std::uint32_t e, float md, float* px,
                  float* py, float* pz, std::int32_t* hits, LaneSet lanes);

}  // namespace swarmsim
