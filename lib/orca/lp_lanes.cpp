#include "orca/lp_lanes.hpp"

#include "core/lanes.hpp"

#if SWARMSIM_X86_LANES
#include <immintrin.h>

namespace swarmsim::orca {

namespace {

// A 3-vector of eight lanes. Every operation below is the scalar code's (orca.cpp's F3 helpers), in its order:
// dot is (x x' + y y') + z z', a vector times a float multiplies each part, and std::min(a, b) / std::max(a, b)
// are _mm256_min_ps(b, a) / _mm256_max_ps(b, a) (the second operand on ties and NaN, as std:: returns a).
struct V3 {
  __m256 x, y, z;
};
SWARMSIM_AVX2 inline V3 add(V3 a, V3 b) {
  return {_mm256_add_ps(a.x, b.x), _mm256_add_ps(a.y, b.y), _mm256_add_ps(a.z, b.z)};
}
SWARMSIM_AVX2 inline V3 sub(V3 a, V3 b) {
  return {_mm256_sub_ps(a.x, b.x), _mm256_sub_ps(a.y, b.y), _mm256_sub_ps(a.z, b.z)};
}
SWARMSIM_AVX2 inline V3 scale(V3 a, __m256 s) {
  return {_mm256_mul_ps(a.x, s), _mm256_mul_ps(a.y, s), _mm256_mul_ps(a.z, s)};
}
SWARMSIM_AVX2 inline __m256 dot(V3 a, V3 b) {
  return _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(a.x, b.x), _mm256_mul_ps(a.y, b.y)), _mm256_mul_ps(a.z, b.z));
}
SWARMSIM_AVX2 inline V3 cross(V3 a, V3 b) {
  return {_mm256_sub_ps(_mm256_mul_ps(a.y, b.z), _mm256_mul_ps(a.z, b.y)),
          _mm256_sub_ps(_mm256_mul_ps(a.z, b.x), _mm256_mul_ps(a.x, b.z)),
          _mm256_sub_ps(_mm256_mul_ps(a.x, b.y), _mm256_mul_ps(a.y, b.x))};
}
// where m: b, else a
SWARMSIM_AVX2 inline V3 select(V3 a, V3 b, __m256 m) {
  return {_mm256_blendv_ps(a.x, b.x, m), _mm256_blendv_ps(a.y, b.y, m), _mm256_blendv_ps(a.z, b.z, m)};
}
SWARMSIM_AVX2 inline bool any(__m256 m) { return _mm256_movemask_ps(m) != 0; }

struct PlaneV {
  V3 n;
  __m256 b;
};
SWARMSIM_AVX2 inline PlaneV planeAt(const float* planes, std::size_t i) {
  const float* p = planes + i * kLpPlaneFloats;
  return {{_mm256_loadu_ps(p), _mm256_loadu_ps(p + kLpLanes), _mm256_loadu_ps(p + 2 * kLpLanes)},
          _mm256_loadu_ps(p + 3 * kLpLanes)};
}

// lineProgram on the lanes of m: the line p + t d, planes [0, count). Returns the lanes where it succeeds (v set
// there).
SWARMSIM_AVX2 __m256 lineLanes(const float* planes, std::size_t count, V3 p, V3 d, __m256 RR, V3 pref, __m256 m,
                               V3& v) {
  const __m256 zero = _mm256_setzero_ps(), tol = _mm256_set1_ps(kTolerance);
  const __m256 pd = dot(p, d);
  const __m256 disc = _mm256_sub_ps(_mm256_add_ps(_mm256_mul_ps(pd, pd), RR), dot(p, p));
  __m256 ok = _mm256_and_ps(m, _mm256_cmp_ps(disc, zero, _CMP_NLT_UQ));  // the line meets the speed ball
  if (!any(ok)) return ok;
  const __m256 s = _mm256_sqrt_ps(disc);
  const __m256 npd = _mm256_xor_ps(pd, _mm256_set1_ps(-0.0f));
  __m256 lo = _mm256_sub_ps(npd, s), hi = _mm256_add_ps(npd, s);
  const __m256 absMask = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff));
  const __m256 tiny = _mm256_set1_ps(1e-6f);
  for (std::size_t k = 0; k < count; ++k) {
    const PlaneV pk = planeAt(planes, k);
    const __m256 den = dot(pk.n, d), num = _mm256_sub_ps(pk.b, dot(pk.n, p));
    const __m256 parallel = _mm256_cmp_ps(_mm256_and_ps(den, absMask), tiny, _CMP_LT_OQ);
    ok = _mm256_andnot_ps(_mm256_and_ps(parallel, _mm256_cmp_ps(num, tol, _CMP_GT_OQ)), ok);
    const __m256 t = _mm256_div_ps(num, den);
    const __m256 update = _mm256_andnot_ps(parallel, ok);
    const __m256 positive = _mm256_cmp_ps(den, zero, _CMP_GT_OQ);
    lo = _mm256_blendv_ps(lo, _mm256_max_ps(t, lo), _mm256_and_ps(update, positive));
    hi = _mm256_blendv_ps(hi, _mm256_min_ps(t, hi), _mm256_andnot_ps(positive, update));
    ok = _mm256_andnot_ps(_mm256_and_ps(update, _mm256_cmp_ps(lo, _mm256_add_ps(hi, tol), _CMP_GT_OQ)), ok);
    if (!any(ok)) return ok;
  }
  const __m256 t = _mm256_max_ps(_mm256_min_ps(dot(sub(pref, p), d), hi), lo);
  v = select(v, add(p, scale(d, _mm256_max_ps(t, lo))), ok);
  return ok;
}

// planeProgram on the lanes of m: on plane i, planes [0, i). Returns the lanes where it succeeds (out set there).
SWARMSIM_AVX2 __m256 planeLanes(const float* planes, std::size_t i, __m256 RR, V3 pref, __m256 m, V3& out) {
  const __m256 zero = _mm256_setzero_ps(), tol = _mm256_set1_ps(kTolerance);
  const PlaneV pi = planeAt(planes, i);
  const V3 n = pi.n;
  const __m256 b = pi.b;
  const __m256 disc2 = _mm256_sub_ps(RR, _mm256_mul_ps(b, b));  // squared radius of the plane's disc in the ball
  __m256 ok = _mm256_and_ps(m, _mm256_cmp_ps(disc2, zero, _CMP_NLT_UQ));
  if (!any(ok)) return ok;
  const V3 c = scale(n, b);
  const V3 q = add(pref, scale(n, _mm256_sub_ps(b, dot(pref, n))));  // pref projected on the plane
  const V3 e = sub(q, c);
  const __m256 e2 = dot(e, e);
  V3 v = select(q, add(c, scale(e, _mm256_sqrt_ps(_mm256_div_ps(disc2, e2)))), _mm256_cmp_ps(e2, disc2, _CMP_GT_OQ));
  const __m256 one = _mm256_set1_ps(1.0f), tinyCross = _mm256_set1_ps(1e-12f);
  for (std::size_t j = 0; j < i; ++j) {
    const PlaneV pj = planeAt(planes, j);
    __m256 violated = _mm256_andnot_ps(_mm256_cmp_ps(dot(pj.n, v), _mm256_sub_ps(pj.b, tol), _CMP_GE_OQ), ok);
    if (!any(violated)) continue;
    const V3 cr = cross(n, pj.n);
    const __m256 cr2 = dot(cr, cr);
    const __m256 parallel = _mm256_and_ps(violated, _mm256_cmp_ps(cr2, tinyCross, _CMP_LT_OQ));
    ok = _mm256_andnot_ps(parallel, ok);
    violated = _mm256_andnot_ps(parallel, violated);
    if (!any(violated)) {
      if (!any(ok)) return ok;
      continue;
    }
    const __m256 crl = _mm256_sqrt_ps(cr2);
    const V3 d = scale(cr, _mm256_div_ps(one, crl));
    const __m256 along = _mm256_div_ps(_mm256_sub_ps(pj.b, _mm256_mul_ps(b, dot(n, pj.n))), crl);
    const V3 p = add(c, scale(cross(d, n), along));
    V3 w = v;
    const __m256 lineOk = lineLanes(planes, j, p, d, RR, pref, violated, w);
    ok = _mm256_andnot_ps(_mm256_andnot_ps(lineOk, violated), ok);
    v = select(v, w, lineOk);
    if (!any(ok)) return ok;
  }
  out = select(out, v, ok);
  return ok;
}

}  // namespace

SWARMSIM_AVX2 void ballProgramLanes(const float* planes, std::size_t count, float R, const float* pref, float* v,
                                    std::uint32_t* fail) {
  const __m256 RR = _mm256_set1_ps(R * R), tol = _mm256_set1_ps(kTolerance);
  const V3 want{_mm256_loadu_ps(pref), _mm256_loadu_ps(pref + kLpLanes), _mm256_loadu_ps(pref + 2 * kLpLanes)};
  const __m256 p2 = dot(want, want);
  V3 at = select(want, scale(want, _mm256_div_ps(_mm256_set1_ps(R), _mm256_sqrt_ps(p2))),
                 _mm256_cmp_ps(p2, RR, _CMP_GT_OQ));
  __m256 alive = _mm256_castsi256_ps(_mm256_set1_epi32(-1));
  for (std::size_t l = 0; l < kLpLanes; ++l) fail[l] = static_cast<std::uint32_t>(count);
  for (std::size_t i = 0; i < count; ++i) {
    const PlaneV pi = planeAt(planes, i);
    const __m256 violated = _mm256_andnot_ps(_mm256_cmp_ps(dot(pi.n, at), _mm256_sub_ps(pi.b, tol), _CMP_GE_OQ), alive);
    if (!any(violated)) continue;
    const __m256 ok = planeLanes(planes, i, RR, want, violated, at);
    const auto failed = static_cast<unsigned>(_mm256_movemask_ps(_mm256_andnot_ps(ok, violated)));
    if (failed == 0) continue;
    for (unsigned bits = failed; bits != 0; bits &= bits - 1) fail[__builtin_ctz(bits)] = static_cast<std::uint32_t>(i);
    alive = _mm256_andnot_ps(_mm256_andnot_ps(ok, violated), alive);
    if (!any(alive)) break;
  }
  _mm256_storeu_ps(v, at.x);
  _mm256_storeu_ps(v + kLpLanes, at.y);
  _mm256_storeu_ps(v + 2 * kLpLanes, at.z);
}

SWARMSIM_AVX2 void agentPlanesLanes(const float* rel, std::size_t T, const float* vi, float R, float invTau,
                                    float invDt, float* planes, std::uint8_t* degenerate) {
  const __m256 tiny = _mm256_set1_ps(1e-20f), zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f);
  const __m256 vR = _mm256_set1_ps(R), vR2 = _mm256_set1_ps(R * R), half = _mm256_set1_ps(0.5f);
  const __m256 vTau = _mm256_set1_ps(invTau), vDt = _mm256_set1_ps(invDt);
  const V3 v{_mm256_loadu_ps(vi), _mm256_loadu_ps(vi + kLpLanes), _mm256_loadu_ps(vi + 2 * kLpLanes)};
  for (std::size_t t = 0; t < T; ++t) {
    const float* in = rel + t * 6 * kLpLanes;
    const V3 p{_mm256_loadu_ps(in), _mm256_loadu_ps(in + kLpLanes), _mm256_loadu_ps(in + 2 * kLpLanes)};
    const V3 r{_mm256_loadu_ps(in + 3 * kLpLanes), _mm256_loadu_ps(in + 4 * kLpLanes),
               _mm256_loadu_ps(in + 5 * kLpLanes)};
    const __m256 dist2 = dot(p, p);
    const __m256 over = _mm256_cmp_ps(dist2, vR2, _CMP_NGT_UQ);  // !(dist2 > R2)
    const __m256 inv = _mm256_blendv_ps(vTau, vDt, over);
    const V3 w = sub(r, scale(p, inv));
    const __m256 w2 = dot(w, w), wp = dot(w, p);
    const __m256 cap =
        _mm256_or_ps(over, _mm256_and_ps(_mm256_cmp_ps(wp, zero, _CMP_LT_OQ),
                                         _mm256_cmp_ps(_mm256_mul_ps(wp, wp), _mm256_mul_ps(vR2, w2), _CMP_GT_OQ)));
    const __m256 wl = _mm256_sqrt_ps(w2);
    // maxOf(a, b) is a > b ? a : b, _mm256_max_ps(a, b)
    const __m256 iw = _mm256_div_ps(one, _mm256_max_ps(wl, tiny));
    const __m256 dist = _mm256_sqrt_ps(dist2);
    const __m256 id = _mm256_div_ps(one, _mm256_max_ps(dist, tiny));
    const V3 a = scale(p, id);
    const __m256 sinA = _mm256_mul_ps(vR, id);
    const __m256 cosA = _mm256_mul_ps(_mm256_sqrt_ps(_mm256_max_ps(_mm256_sub_ps(dist2, vR2), zero)), id);
    const __m256 s = dot(r, a);
    const V3 q = sub(r, scale(a, s));
    const __m256 q2 = dot(q, q);
    const __m256 iq = _mm256_div_ps(one, _mm256_sqrt_ps(_mm256_max_ps(q2, tiny)));
    const V3 c = sub(scale(scale(q, iq), cosA), scale(a, sinA));
    const __m256 coneAlong = _mm256_xor_ps(dot(r, c), _mm256_set1_ps(-0.0f));
    const V3 m = select(c, scale(w, iw), cap);
    const __m256 along = _mm256_blendv_ps(coneAlong, _mm256_sub_ps(_mm256_mul_ps(vR, inv), wl), cap);
    float* out = planes + t * kLpPlaneFloats;
    _mm256_storeu_ps(out, m.x);
    _mm256_storeu_ps(out + kLpLanes, m.y);
    _mm256_storeu_ps(out + 2 * kLpLanes, m.z);
    _mm256_storeu_ps(out + 3 * kLpLanes, _mm256_add_ps(dot(m, v), _mm256_mul_ps(half, along)));
    const __m256 defined = _mm256_cmp_ps(_mm256_blendv_ps(q2, w2, cap), tiny, _CMP_GT_OQ);
    degenerate[t] = static_cast<std::uint8_t>(~_mm256_movemask_ps(defined) & 0xff);
  }
}

}  // namespace swarmsim::orca

#else

namespace swarmsim::orca {
void ballProgramLanes(const float*, std::size_t, float, const float*, float*, std::uint32_t*) {}
void agentPlanesLanes(const float*, std::size_t, const float*, float, float, float, float*, std::uint8_t*) {}
}  // namespace swarmsim::orca

#endif
