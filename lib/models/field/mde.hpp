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

// The paper's rule (section 6): every pair within one run [b, e) of sorted
// points (one grid cell), each pair examined once. Writes the pushes of the
// run's points to px/py/pz[b, e) and their counts of neighbours closer than
// d_min to hits[b, e). Pair (k, j), k < j, moves k by -f and j by +f with
//   f = (p_j - p_k) / d * (d_min - d) / 2;
// the sums run in a fixed order (pairs by k, then lanes), so the result
// depends only on the data. Returns true if two points of the run coincide
// exactly: those pairs are left to the caller (they need an agent order).
inline bool mdeWithinRun(const float* x, const float* y, const float* z, std::uint32_t b, std::uint32_t e, float md,
                         float* px, float* py, float* pz, std::int32_t* hits) {
  const float md2 = md * md;
  for (std::uint32_t k = b; k < e; ++k) px[k] = py[k] = pz[k] = 0.0f, hits[k] = 0;
  int zeros = 0;
  for (std::uint32_t k = b; k < e; ++k) {
    const float qx = x[k], qy = y[k], qz = z[k];
    float ax = 0.0f, ay = 0.0f, az = 0.0f;
    std::int32_t ah = 0;
    std::uint32_t j = k + 1;
#if defined(__SSE2__)
    // four pairs at a time (SSE2 is part of every x86-64 CPU), when there are four (cells often hold fewer:
    // the sums of no lanes would add zeros)
    if (j + 4 <= e) {
      const __m128 vqx = _mm_set1_ps(qx), vqy = _mm_set1_ps(qy), vqz = _mm_set1_ps(qz);
      const MdeLanes lanes(md);
      __m128 sx = _mm_setzero_ps(), sy = _mm_setzero_ps(), sz = _mm_setzero_ps();
      __m128i sh = _mm_setzero_si128(), s0 = _mm_setzero_si128();
      for (; j + 4 <= e; j += 4) {
        const __m128 dx = _mm_sub_ps(_mm_loadu_ps(x + j), vqx);
        const __m128 dy = _mm_sub_ps(_mm_loadu_ps(y + j), vqy);
        const __m128 dz = _mm_sub_ps(_mm_loadu_ps(z + j), vqz);
        __m128 near, coincident;
        const __m128 w = lanes.weights(dx, dy, dz, near, coincident);
        const __m128 fx = _mm_mul_ps(dx, w), fy = _mm_mul_ps(dy, w), fz = _mm_mul_ps(dz, w);
        sx = _mm_sub_ps(sx, fx);
        sy = _mm_sub_ps(sy, fy);
        sz = _mm_sub_ps(sz, fz);
        _mm_storeu_ps(px + j, _mm_add_ps(_mm_loadu_ps(px + j), fx));
        _mm_storeu_ps(py + j, _mm_add_ps(_mm_loadu_ps(py + j), fy));
        _mm_storeu_ps(pz + j, _mm_add_ps(_mm_loadu_ps(pz + j), fz));
        const __m128i nearMask = _mm_castps_si128(near);  // -1 where near
        __m128i* hj = reinterpret_cast<__m128i*>(hits + j);
        _mm_storeu_si128(hj, _mm_sub_epi32(_mm_loadu_si128(hj), nearMask));
        sh = _mm_sub_epi32(sh, nearMask);
        s0 = _mm_sub_epi32(s0, _mm_castps_si128(coincident));
      }
      alignas(16) float lx[4], ly[4], lz[4];
      alignas(16) std::int32_t lh[4], l0[4];
      _mm_store_ps(lx, sx);
      _mm_store_ps(ly, sy);
      _mm_store_ps(lz, sz);
      _mm_store_si128(reinterpret_cast<__m128i*>(lh), sh);
      _mm_store_si128(reinterpret_cast<__m128i*>(l0), s0);
      for (int l = 0; l < 4; ++l) {
        ax += lx[l];
        ay += ly[l];
        az += lz[l];
        ah += lh[l];
        zeros += l0[l];
      }
    }
#endif
    for (; j < e; ++j) {
      const float dx = x[j] - qx, dy = y[j] - qy, dz = z[j] - qz;
      const float d2 = dx * dx + dy * dy + dz * dz;
      zeros += d2 == 0.0f ? 1 : 0;
      float w;
      if (!mdeWeight(d2, md, md2, w)) continue;
      const float fx = dx * w, fy = dy * w, fz = dz * w;
      ax -= fx;
      ay -= fy;
      az -= fz;
      px[j] += fx;
      py[j] += fy;
      pz[j] += fz;
      ++hits[j];
      ++ah;
    }
    px[k] += ax;
    py[k] += ay;
    pz[k] += az;
    hits[k] += ah;
  }
  return zeros > 0;
}

}  // namespace swarmsim
