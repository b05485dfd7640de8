#include "models/fastswarm/energy.hpp"

#include <limits>

#include "core/lanes.hpp"

namespace swarmsim::fastswarm {

void Candidates::add(const Vec3& v, const Vec3& a) {
  const Vec3 u = unitOrZero(v), b = unitOrZero(a);
  vx.push_back(v.x());
  vy.push_back(v.y());
  vz.push_back(v.z());
  ux.push_back(u.x());
  uy.push_back(u.y());
  uz.push_back(u.z());
  bx.push_back(b.x());
  by.push_back(b.y());
  bz.push_back(b.z());
  amag.push_back(a.norm());
}

namespace {

// the terms that do not depend on the neighbours (eq. 7, 9, 10, 13, 14) into e
inline void ownTerms(const AgentInput& in, const Candidates& c, std::size_t k, const EnergyParams& p, EnergyTerms& e) {
  const Vec3 v(c.vx[k], c.vy[k], c.vz[k]), u(c.ux[k], c.uy[k], c.uz[k]);
  const float rho = p.rho;
  // eq. 7: heading toward the swarm centre
  if (p.w.cos > 0.0f) e.cos = p.w.cos * std::exp(rho * (u - in.center).norm());
  // eq. 9: directional continuity
  if (p.w.dir > 0.0f) e.dir = p.w.dir * std::exp(rho * (u - in.vhat).norm());
  // eq. 10: continuity of the acceleration, a' = (v - v_t) / Δt against the sample's a
  if (p.w.acc > 0.0f) {
    const Vec3 a1 = (v - in.v) / p.dt;
    const float m = a1.norm();
    const Vec3 b1 = m > 0.0f ? Vec3(a1 / m) : Vec3::Zero();
    const Vec3 b(c.bx[k], c.by[k], c.bz[k]);
    e.adir = p.w.acc * std::exp(rho * (b1 - b).norm());
    e.amag = p.w.acc * std::fabs(m - c.amag[k]);
  }
  // eq. 13: the noise's direction
  if (p.w.n > 0.0f) e.n = p.w.n * std::exp(rho * (u - in.noise).norm());
  // eq. 14: the user's control direction
  if (p.w.user > 0.0f) e.user = p.w.user * std::exp(rho * (u - in.control).norm());
  // eq. 11-12, attracted: Ψ = |v̂ − v̂_{i,sti}| per attracting stimulus
  if (p.w.env > 0.0f) {
    for (std::size_t j = 0; j < in.lures; ++j) {
      e.lure += p.w.env * std::exp(rho * (u - Vec3(in.lureX[j], in.lureY[j], in.lureZ[j])).norm());
    }
  }
}

inline float ownTotal(const EnergyTerms& e) { return e.cos + e.dir + e.adir + e.amag + e.n + e.user + e.lure; }

// ownTotal of the candidates [first, first + 8 m) into out, eight at a time on SIMD lanes with the lanes' e^x
// (within about 2e-7 of std::exp): for the bounds only, which allow for that difference
template <typename L>
inline void ownTotalsLanes(const AgentInput& in, const Candidates& c, std::size_t first, std::size_t blocks,
                           const EnergyParams& p, float* out) {
  using V = typename L::V;
  const V rho = L::set1(p.rho), zero = L::set1(0.0f), one = L::set1(1.0f), sign = L::set1(-0.0f);
  const V invDt = L::set1(1.0f / p.dt);
  // (lambdas that take or return vectors are always inlined: a call would pass them with the caller's
  // instruction set's ABI, and clang's sanitized build does not inline them under flatten alone)
  const auto dist = [&](V x, V y, V z, float ax, float ay, float az) __attribute__((always_inline)) {
    const V dx = L::sub(x, L::set1(ax)), dy = L::sub(y, L::set1(ay)), dz = L::sub(z, L::set1(az));
    return L::sqrt(L::add(L::add(L::mul(dx, dx), L::mul(dy, dy)), L::mul(dz, dz)));
  };
  const auto term = [&](float w, V d) __attribute__((always_inline)) {
    return L::mul(L::set1(w), expLanes<L>(L::mul(rho, d)));
  };
  for (std::size_t b = 0; b < blocks; ++b) {
    const std::size_t k = first + b * kLanes;
    const V ux = L::load(c.ux.data() + k), uy = L::load(c.uy.data() + k), uz = L::load(c.uz.data() + k);
    V e = zero;
    if (p.w.cos > 0.0f) e = L::add(e, term(p.w.cos, dist(ux, uy, uz, in.center.x(), in.center.y(), in.center.z())));
    if (p.w.dir > 0.0f) e = L::add(e, term(p.w.dir, dist(ux, uy, uz, in.vhat.x(), in.vhat.y(), in.vhat.z())));
    if (p.w.acc > 0.0f) {
      const V ax = L::mul(L::sub(L::load(c.vx.data() + k), L::set1(in.v.x())), invDt);
      const V ay = L::mul(L::sub(L::load(c.vy.data() + k), L::set1(in.v.y())), invDt);
      const V az = L::mul(L::sub(L::load(c.vz.data() + k), L::set1(in.v.z())), invDt);
      const V m = L::sqrt(L::add(L::add(L::mul(ax, ax), L::mul(ay, ay)), L::mul(az, az)));
      const V inv = L::band(L::gt(m, zero), L::div(one, L::max(m, L::set1(1e-30f))));
      const V dx = L::sub(L::mul(ax, inv), L::load(c.bx.data() + k));
      const V dy = L::sub(L::mul(ay, inv), L::load(c.by.data() + k));
      const V dz = L::sub(L::mul(az, inv), L::load(c.bz.data() + k));
      const V d = L::sqrt(L::add(L::add(L::mul(dx, dx), L::mul(dy, dy)), L::mul(dz, dz)));
      e = L::add(e, term(p.w.acc, d));
      e = L::add(e, L::mul(L::set1(p.w.acc), L::andnot(sign, L::sub(m, L::load(c.amag.data() + k)))));
    }
    if (p.w.n > 0.0f) e = L::add(e, term(p.w.n, dist(ux, uy, uz, in.noise.x(), in.noise.y(), in.noise.z())));
    if (p.w.user > 0.0f) {
      e = L::add(e, term(p.w.user, dist(ux, uy, uz, in.control.x(), in.control.y(), in.control.z())));
    }
    if (p.w.env > 0.0f) {
      for (std::size_t j = 0; j < in.lures; ++j) e = L::add(e, term(p.w.env, dist(ux, uy, uz, in.lureX[j], in.lureY[j], in.lureZ[j])));
    }
    L::store(out + b * kLanes, e);
  }
}

#if SWARMSIM_X86_LANES
__attribute__((flatten)) void ownTotalsSse(const AgentInput& in, const Candidates& c, std::size_t first,
                                           std::size_t blocks, const EnergyParams& p, float* out) {
  ownTotalsLanes<SseLanes>(in, c, first, blocks, p, out);
}
SWARMSIM_AVX __attribute__((flatten)) void ownTotalsAvx(const AgentInput& in, const Candidates& c, std::size_t first,
                                                        std::size_t blocks, const EnergyParams& p, float* out) {
  ownTotalsLanes<AvxLanes>(in, c, first, blocks, p, out);
}
#endif

// candidate k with E e becomes the best unless it is worse, or tied with a lower index (as in argminEnergy,
// the lowest index of the least E wins)
inline void keepBest(float e, std::size_t k, float& least, std::size_t& arg) {
  if (e < least || (e == least && k < arg)) {
    least = e;
    arg = k;
  }
}

// a candidate's exact E on exact lanes (AVX: the same bits as SSE), kept out of the wide lanes' flattened entry
// points below so that none of it is compiled for their instruction sets
__attribute__((noinline)) float exactTotal(const AgentInput& in, const Candidates& c, std::size_t k,
                                           const EnergyParams& p) {
  return energyTermsWith(true, in, c, k, p).total();
}

#if SWARMSIM_X86_LANES
// The lower bounds of argminEnergyBounded on wide lanes with fused multiply-adds and refined reciprocal square
// roots: 16 candidates at a time (AVX-512) or 8 (AVX2 with FMA). Only the bounds use them, so their bits may
// differ from the exact terms' (and between the two): each bound is lowered by a margin that covers the
// difference (boundMargin), and the candidate chosen is the exact argmin whatever the lanes.
#define SWARMSIM_AVX2FMA __attribute__((target("avx2,fma")))

struct Avx512Bound : Avx512Lanes {
  static constexpr float kRsqrtBelow = 1.0f - 1.25e-4f;  // rsqrt14: relative error <= 2^-14
  SWARMSIM_AVX512 static __mmask16 live(std::size_t n) { return static_cast<__mmask16>(firstLanes(n, 16)); }
  // the first n (<= 16) floats at p, zero past them (nothing past them is read)
  SWARMSIM_AVX512 static V load(const float* p, std::size_t n) { return {_mm512_maskz_loadu_ps(live(n), p)}; }
  SWARMSIM_AVX512 static void store(float* p, V x, std::size_t n) { _mm512_mask_storeu_ps(p, live(n), x.a); }
  // lanes n and on set to x
  SWARMSIM_AVX512 static V fillFrom(V v, std::size_t n, float x) {
    return {_mm512_mask_blend_ps(live(n), _mm512_set1_ps(x), v.a)};
  }
  SWARMSIM_AVX512 static V fma(V x, V y, V z) { return {_mm512_fmadd_ps(x.a, y.a, z.a)}; }    // x y + z
  SWARMSIM_AVX512 static V fnma(V x, V y, V z) { return {_mm512_fnmadd_ps(x.a, y.a, z.a)}; }  // z − x y
  SWARMSIM_AVX512 static V abs(V x) {
    return {_mm512_castsi512_ps(_mm512_and_epi32(_mm512_castps_si512(x.a), _mm512_set1_epi32(0x7fffffff)))};
  }
  SWARMSIM_AVX512 static V rsqrt(V x) { return {_mm512_maskz_rsqrt14_ps(0xffff, x.a)}; }  // relative error <= 2^-14
  SWARMSIM_AVX512 static V round(V x) {
    return {_mm512_maskz_roundscale_ps(0xffff, x.a, _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC)};
  }
  SWARMSIM_AVX512 static V scale2(V x, V n) {  // x 2^n
    return {_mm512_maskz_scalef_ps(0xffff, x.a, n.a)};
  }
  // comparisons as bit masks of the first n lanes
  SWARMSIM_AVX512 static unsigned eq(V x, V y, std::size_t n) {
    return _mm512_mask_cmp_ps_mask(live(n), x.a, y.a, _CMP_EQ_OQ);
  }
  SWARMSIM_AVX512 static unsigned le(V x, V y, std::size_t n) {
    return _mm512_mask_cmp_ps_mask(live(n), x.a, y.a, _CMP_LE_OQ);
  }
  SWARMSIM_AVX512 static float minOf(V x) {
    alignas(64) float l[16];
    _mm512_store_ps(l, x.a);
    return *std::min_element(l, l + 16);
  }
};

struct Avx2Bound : AvxLanes {
  static constexpr std::size_t kWidth = 8;
  static constexpr float kRsqrtBelow = 1.0f - 5e-4f;  // rsqrt: relative error <= 1.5 2^-12
  SWARMSIM_AVX2FMA static __m256i live(std::size_t n) {
    return _mm256_cmpgt_epi32(_mm256_set1_epi32(static_cast<int>(std::min<std::size_t>(n, 8))),
                              _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
  }
  SWARMSIM_AVX2FMA static V load(const float* p, std::size_t n) {
    return {n >= 8 ? _mm256_loadu_ps(p) : _mm256_maskload_ps(p, live(n))};
  }
  SWARMSIM_AVX2FMA static void store(float* p, V x, std::size_t n) {
    if (n >= 8) {
      _mm256_storeu_ps(p, x.a);
    } else {
      _mm256_maskstore_ps(p, live(n), x.a);
    }
  }
  SWARMSIM_AVX2FMA static V fillFrom(V v, std::size_t n, float x) {
    return {_mm256_blendv_ps(_mm256_set1_ps(x), v.a, _mm256_castsi256_ps(live(n)))};
  }
  SWARMSIM_AVX2FMA static V fma(V x, V y, V z) { return {_mm256_fmadd_ps(x.a, y.a, z.a)}; }
  SWARMSIM_AVX2FMA static V fnma(V x, V y, V z) { return {_mm256_fnmadd_ps(x.a, y.a, z.a)}; }
  SWARMSIM_AVX2FMA static V abs(V x) { return andnot(set1(-0.0f), x); }
  SWARMSIM_AVX2FMA static V rsqrt(V x) { return {_mm256_rsqrt_ps(x.a)}; }  // relative error <= 1.5 2^-12
  SWARMSIM_AVX2FMA static V scale2(V x, V n) { return mul(x, pow2(n)); }  // x 2^n for integral n in [-126, 127]
  // comparisons as bit masks of the first n lanes
  SWARMSIM_AVX2FMA static unsigned eq(V x, V y, std::size_t n) {
    return static_cast<unsigned>(_mm256_movemask_ps(_mm256_cmp_ps(x.a, y.a, _CMP_EQ_OQ))) & firstLanes(n, 8);
  }
  SWARMSIM_AVX2FMA static unsigned le(V x, V y, std::size_t n) { return mask(AvxLanes::le(x, y)) & firstLanes(n, 8); }
  SWARMSIM_AVX2FMA static float minOf(V x) {
    float l[8];
    AvxLanes::store(l, x);
    return *std::min_element(l, l + 8);
  }
};

// the wide lanes' 2^t for t in [-126, 126]: 2^round(t) times the degree-5 Taylor polynomial of 2^f, f = t − round(t)
// in [-1/2, 1/2] (within 3.4e-6), as (1 + c1 f) + f² ((c2 + c3 f) + f² (c4 + c5 f)): a shorter chain than Horner's
template <typename L>
__attribute__((always_inline)) inline typename L::V pow2Wide(typename L::V t) {
  using V = typename L::V;
  const V k = L::round(t);
  const V g = L::sub(t, k);
  const V g2 = L::mul(g, g);
  const V lo = L::fma(L::set1(0.6931471805599453f), g, L::set1(1.0f));
  const V mid = L::fma(L::set1(5.550410866482158e-2f), g, L::set1(0.2402265069591007f));
  const V top = L::fma(L::set1(1.3333558146428443e-3f), g, L::set1(9.618129107628477e-3f));
  return L::scale2(L::fma(g2, L::fma(g2, top, mid), lo), k);
}

// 1 / sqrt(x) for x > 0 on the wide lanes: the reciprocal square root and one Newton step
template <typename L>
__attribute__((always_inline)) inline typename L::V invSqrtWide(typename L::V x) {
  const typename L::V r = L::rsqrt(x);
  return L::mul(r, L::fnma(L::mul(L::set1(0.5f), x), L::mul(r, r), L::set1(1.5f)));
}

// how far below the exact own terms the wide lanes' bound is put, relative to it: their e^x (degree-5 Taylor
// polynomial of 2^f for f in [-1/2, 1/2], within 3.4e-6; plus the rounding of x log2 e, below 4e-6 for x <= 40)
// and the order of the sums, with room to spare (the distances in the exponents are bounded below by themselves)
inline float boundMargin(const EnergyParams& p) { return 1e-4f + 4e-6f * p.rho; }

// the scratch of argminEnergyBounded for n candidates: their bounds (n rounded up to whole 16-float vectors, on a
// 64-byte boundary), then the wide lanes' table of exponents, up to nine rows of that length
constexpr std::size_t kBoundRows = 9;
inline std::size_t boundTableOffset(std::size_t n) { return (n + 31) / 16 * 16; }
inline std::size_t boundScratchSize(std::size_t n) { return boundTableOffset(n) * (1 + kBoundRows) + 16; }

// the lower bounds of the candidates [first, first + n) into out[0, n) and their least value: the own terms
// (eq. 7, 9, 10, 13, 14, the lures of eq. 11) less the margin, plus the interaction's bound (the factors f times
// the energies of no move rep0, oa0, danger0, as in argminEnergyBounded). What does not depend on the candidate
// is made once, before the loop: the terms toward a fixed unit vector (centre, heading, noise, control, lures)
// are one table, so a block of candidates costs about a hundred vector operations and no unpredictable branch.
template <typename L>
__attribute__((always_inline)) inline float boundsWide(const AgentInput& in, const Candidates& c,
                                                       const BoundFactors& f, std::size_t first, std::size_t n,
                                                       const EnergyParams& p, float rep0, float oa0, float danger0,
                                                       float* out, float* ts) {
  using V = typename L::V;
  constexpr float kLog2e = 1.44269504f;  // e^{ρ d} = 2^{ρ log2(e) d}
  // ρ log2(e) d <= 126 (the exponents scale2 takes) for every d <= 2.01, the longest distance between unit or
  // zero vectors with rounding; a larger ρ clamps
  const bool clamp = p.rho * kLog2e * 2.01f > 126.0f;
  const V keep = L::set1(1.0f - boundMargin(p));
  const V invDt = L::set1(1.0f / p.dt), tiny = L::set1(1e-30f);
  const V hi = L::set1(126.0f), zero = L::set1(0.0f);
  // ρ log2(e) times at most sqrt(x) for x >= 0 (x <= 0: about 0), from the reciprocal square root lowered by its
  // error bound
  const V rhoBelow = L::set1(p.rho * kLog2e * L::kRsqrtBelow);
  const auto scaledRoot = [&](V x2) __attribute__((always_inline)) {
    const V x = L::max(x2, tiny);
    return L::mul(x, L::mul(L::rsqrt(x), rhoBelow));
  };
  // w 2^t for t in [0, 126] (ρ log2(e) d), added to acc
  const auto term = [&](V w, V t, V acc) __attribute__((always_inline)) {
    if (clamp) t = L::min(t, hi);
    return L::fma(w, pow2Wide<L>(t), acc);
  };
  // the terms w e^{ρ |u − a|} toward fixed unit (or zero) vectors a: |u − a|² = |u|² + |a|² − 2 u·a, less 2e-6
  // for its rounding, as |u|² + C + u·A with A = −2 a and C = |a|² − 2e-6
  constexpr std::size_t kTable = 8;
  V tw[kTable], tx[kTable], ty[kTable], tz[kTable], tc[kTable];
  std::size_t terms = 0;
  const auto toward = [&](float w, float ax, float ay, float az) {
    tw[terms] = L::set1(w);
    tx[terms] = L::set1(-2.0f * ax);
    ty[terms] = L::set1(-2.0f * ay);
    tz[terms] = L::set1(-2.0f * az);
    tc[terms] = L::set1(ax * ax + ay * ay + az * az - 2e-6f);
    ++terms;
  };
  if (p.w.cos > 0.0f) toward(p.w.cos, in.center.x(), in.center.y(), in.center.z());
  if (p.w.dir > 0.0f) toward(p.w.dir, in.vhat.x(), in.vhat.y(), in.vhat.z());
  if (p.w.n > 0.0f) toward(p.w.n, in.noise.x(), in.noise.y(), in.noise.z());
  if (p.w.user > 0.0f) toward(p.w.user, in.control.x(), in.control.y(), in.control.z());
  std::size_t lureFrom = in.lures;  // the lures that did not fit the table: one by one in the loop
  if (p.w.env > 0.0f) {
    for (lureFrom = 0; lureFrom < in.lures && terms < kTable; ++lureFrom) {
      toward(p.w.env, in.lureX[lureFrom], in.lureY[lureFrom], in.lureZ[lureFrom]);
    }
  }
  const bool acc = p.w.acc > 0.0f;
  const V wAcc = L::set1(p.w.acc), slackAcc = L::set1(p.w.acc * 1e-6f);
  // a' = (v − v_t) / Δt, exactly zero where the exact terms' is (v = v_t): their â' is zero there
  const V bx = L::set1(in.v.x()), by = L::set1(in.v.y()), bz = L::set1(in.v.z());
  const V vRep = L::set1(rep0), vOa = L::set1(oa0), vDanger = L::set1(danger0);
  // Two passes over the candidates, each with a short chain of dependent operations per block, so that the
  // processor overlaps many blocks (one pass of the whole chain, about 30 operations deep, kept it waiting):
  // first every term's exponent into `ts` (a table of stride n rounded up to whole vectors) and what needs no
  // e^x (|a'| against the sample's |a|, the interaction's bound, less the slack) into out; then the sums of
  // w 2^t, the margin and the least bound.
  const std::size_t stride = (n + L::kWidth - 1) / L::kWidth * L::kWidth;
  const std::size_t slots = terms + (acc ? 1 : 0);
  for (std::size_t b = 0; b < n; b += L::kWidth) {
    const std::size_t k = first + b, m = n - b;
    const V ux = L::load(c.ux.data() + k, m), uy = L::load(c.uy.data() + k, m), uz = L::load(c.uz.data() + k, m);
    const V uu = L::fma(ux, ux, L::fma(uy, uy, L::mul(uz, uz)));
    for (std::size_t t = 0; t < terms; ++t) {
      const V d2 = L::fma(ux, tx[t], L::fma(uy, ty[t], L::fma(uz, tz[t], L::add(uu, tc[t]))));
      L::store(ts + t * stride + b, scaledRoot(d2), L::kWidth);
    }
    V rest = zero;
    for (std::size_t j = lureFrom; j < in.lures; ++j) {
      const float ax = in.lureX[j], ay = in.lureY[j], az = in.lureZ[j];
      const V d2 = L::fma(ux, L::set1(-2.0f * ax),
                          L::fma(uy, L::set1(-2.0f * ay),
                                 L::fma(uz, L::set1(-2.0f * az), L::add(uu, L::set1(ax * ax + ay * ay + az * az - 2e-6f)))));
      rest = term(L::set1(p.w.env), scaledRoot(d2), rest);
    }
    rest = L::mul(rest, keep);
    if (acc) {
      const V ax = L::mul(L::sub(L::load(c.vx.data() + k, m), bx), invDt);
      const V ay = L::mul(L::sub(L::load(c.vy.data() + k, m), by), invDt);
      const V az = L::mul(L::sub(L::load(c.vz.data() + k, m), bz), invDt);
      const V m2 = L::fma(ax, ax, L::fma(ay, ay, L::mul(az, az)));
      // 1 / |a'| from the reciprocal square root and one Newton step; |a'| = |a'|² / |a'| (zero for a' = 0)
      const V inv = invSqrtWide<L>(L::max(m2, tiny));
      const V mag = L::mul(m2, inv);
      const V dx = L::fnma(ax, inv, L::load(c.bx.data() + k, m));  // b − â' (its norm is the same)
      const V dy = L::fnma(ay, inv, L::load(c.by.data() + k, m));
      const V dz = L::fnma(az, inv, L::load(c.bz.data() + k, m));
      const V d2 = L::fma(dx, dx, L::fma(dy, dy, L::fma(dz, dz, L::set1(-2e-6f))));  // (2e-6: â' is rounded)
      L::store(ts + terms * stride + b, scaledRoot(d2), L::kWidth);
      // |a'| here is within a few units of rounding of the exact terms' (which divide by Δt and take a square
      // root): w_acc 1e-6 |a'| covers the difference
      rest = L::fma(L::mul(wAcc, keep), L::abs(L::sub(mag, L::load(c.amag.data() + k, m))), rest);
      rest = L::fnma(slackAcc, mag, rest);
    }
    rest = L::fma(L::load(f.rep.data() + k, m), vRep, rest);
    rest = L::fma(L::load(f.oa.data() + k, m), vOa, rest);
    rest = L::fma(L::load(f.danger.data() + k, m), vDanger, rest);
    L::store(out + b, rest, m);
  }
  V wk[kTable + 1];  // the weights with the margin
  for (std::size_t t = 0; t < terms; ++t) wk[t] = L::mul(tw[t], keep);
  if (acc) wk[terms] = L::mul(wAcc, keep);
  V least = L::set1(std::numeric_limits<float>::infinity());
  for (std::size_t b = 0; b < n; b += L::kWidth) {
    const std::size_t m = n - b;
    V lb = L::load(out + b, m);
    for (std::size_t t = 0; t < slots; ++t) lb = term(wk[t], L::load(ts + t * stride + b, L::kWidth), lb);
    L::store(out + b, lb, m);
    least = L::min(least, L::fillFrom(lb, m, std::numeric_limits<float>::infinity()));
  }
  return L::minOf(least);
}

// at most Σ_j e^{a + b |q − p_j|} over n points (a lower bound of the interaction sums, for the bounds only):
// the bounds' 2^t (degree-5 polynomial, within 3.4e-6) of an exponent from the refined reciprocal square root
// (|q − p_j| within about 1e-7 of itself, which moves e^x by at most 1e-7 |b| d), the lanes summed in any order,
// and the whole lowered by 2e-4 plus 1e-7 per sixteen points for all of that
template <typename L>
__attribute__((always_inline)) inline float zoneSumBelow(float qx, float qy, float qz, const float* x, const float* y,
                                                         const float* z, std::size_t n, float a, float b) {
  using V = typename L::V;
  constexpr float kLog2e = 1.44269504f;
  const V vqx = L::set1(qx), vqy = L::set1(qy), vqz = L::set1(qz);
  const V va = L::set1(a * kLog2e), vb = L::set1(b * kLog2e), tiny = L::set1(1e-30f);
  const V hi = L::set1(126.0f), lo = L::set1(-126.0f), zero = L::set1(0.0f), one = L::set1(1.0f);
  V acc = zero;
  for (std::size_t j = 0; j < n; j += L::kWidth) {
    const std::size_t m = n - j;
    const V dx = L::sub(L::load(x + j, m), vqx), dy = L::sub(L::load(y + j, m), vqy), dz = L::sub(L::load(z + j, m), vqz);
    const V d2 = L::fma(dx, dx, L::fma(dy, dy, L::mul(dz, dz)));
    const V t = L::fma(vb, L::mul(d2, invSqrtWide<L>(L::max(d2, tiny))), va);
    // below 2^-126, 2^-126 (t + 127) clamped to [0, 1], which is at most 2^t there; above 2^126, 2^126
    const V under = L::min(L::max(L::add(t, L::set1(127.0f)), zero), one);
    const V e = L::mul(pow2Wide<L>(L::min(L::max(t, lo), hi)), under);
    acc = L::add(acc, L::fillFrom(e, m, 0.0f));  // (lanes past n: zero)
  }
  float part[16];
  L::store(part, acc, L::kWidth);
  float sum = 0.0f;
  for (std::size_t l = 0; l < L::kWidth; ++l) sum += part[l];
  const float lower = 1.0f - 2e-4f - 1e-7f * static_cast<float>(n / 16 + 16);
  return sum * std::max(lower, 0.5f);
}

// the interaction terms of eq. 4 and 6 at the agent's position (no move), bounded below (zoneSumBelow)
template <typename L>
__attribute__((always_inline)) inline void zoneTermsBelow(const AgentInput& in, const EnergyParams& p, float& rep,
                                                          float& oa) {
  rep = oa = 0.0f;
  const float qx = in.p.x(), qy = in.p.y(), qz = in.p.z();
  if (p.w.rep > 0.0f && in.rep > 0) {
    rep = p.w.rep * zoneSumBelow<L>(qx, qy, qz, in.repX, in.repY, in.repZ, in.rep, p.rho, -p.rho / p.dRep) /
          static_cast<float>(in.rep);
  }
  if (p.w.oa > 0.0f && in.att > 0) {
    oa = p.w.oa * zoneSumBelow<L>(qx, qy, qz, in.attX, in.attY, in.attZ, in.att, -p.rho, p.rho / p.dAtt1) /
         static_cast<float>(in.att);
  }
}

// argminEnergyBounded on wide lanes: the bounds, the first candidate of the least bound, its exact E, then the
// exact E of every candidate whose bound is not above the best E so far
template <typename L>
__attribute__((always_inline)) inline std::size_t argminWide(const AgentInput& in, const Candidates& c,
                                                             const BoundFactors& f, std::size_t first,
                                                             std::size_t last, const EnergyParams& p,
                                                             float danger0, float* lower, float* best) {
  const std::size_t n = last - first;
  float rep0 = 0.0f, oa0 = 0.0f;  // the interaction at no move, bounded below on these lanes
  zoneTermsBelow<L>(in, p, rep0, oa0);
  // the exponents' table after the bounds (argminEnergyBounded sizes `lower` for both)
  float* ts = lower + boundTableOffset(n);
  const float startBound = boundsWide<L>(in, c, f, first, n, p, rep0, oa0, danger0, lower, ts);
  std::size_t start = 0;
  for (std::size_t b = 0; b < n; b += L::kWidth) {  // the first of the least
    const unsigned eq = L::eq(L::load(lower + b, n - b), L::set1(startBound), n - b);
    if (eq != 0) {
      start = b + static_cast<std::size_t>(__builtin_ctz(eq));
      break;
    }
  }
  std::size_t arg = first + start;
  float least = exactTotal(in, c, arg, p);
  for (std::size_t b = 0; b < n; b += L::kWidth) {
    unsigned m = L::le(L::load(lower + b, n - b), L::set1(least), n - b);
    for (; m != 0; m &= m - 1u) {
      const std::size_t i = b + static_cast<std::size_t>(__builtin_ctz(m));
      if (i == start || !(lower[i] <= least)) continue;
      const std::size_t k = first + i;
      keepBest(exactTotal(in, c, k, p), k, least, arg);
    }
  }
  if (best) *best = least;
  return arg;
}

__attribute__((flatten)) SWARMSIM_AVX512 std::size_t argminAvx512(const AgentInput& in, const Candidates& c,
                                                                   const BoundFactors& f, std::size_t first,
                                                                   std::size_t last, const EnergyParams& p,
                                                                   float danger0, float* lower, float* best) {
  return argminWide<Avx512Bound>(in, c, f, first, last, p, danger0, lower, best);
}
__attribute__((flatten)) SWARMSIM_AVX2FMA std::size_t argminAvx2(const AgentInput& in, const Candidates& c,
                                                                 const BoundFactors& f, std::size_t first,
                                                                 std::size_t last, const EnergyParams& p,
                                                                 float danger0, float* lower, float* best) {
  return argminWide<Avx2Bound>(in, c, f, first, last, p, danger0, lower, best);
}
#endif

// Σ_j e^{a + b |q − p_j|} over n points, eight at a time on SIMD lanes with the lanes' e^x, the lanes added in a
// fixed order at the end: every lane type gives the same bits (the eq. 4, 6 and 12 sums). zoneSumFrom starts at
// point j with the lanes' sums acc of the points before.
template <typename L>
__attribute__((always_inline)) inline float zoneSumFrom(float qx, float qy, float qz, const float* x, const float* y,
                                                        const float* z, std::size_t n, float a, float b,
                                                        std::size_t j, typename L::V acc) {
  using V = typename L::V;
  alignas(32) static constexpr float kIndex[kLanes] = {0, 1, 2, 3, 4, 5, 6, 7};
  const V vqx = L::set1(qx), vqy = L::set1(qy), vqz = L::set1(qz), va = L::set1(a), vb = L::set1(b);
  const auto lane = [&](V px, V py, V pz) __attribute__((always_inline)) {
    const V dx = L::sub(vqx, px), dy = L::sub(vqy, py), dz = L::sub(vqz, pz);
    const V d = L::sqrt(L::add(L::add(L::mul(dx, dx), L::mul(dy, dy)), L::mul(dz, dz)));
    return expLanes<L>(L::add(va, L::mul(vb, d)));
  };
  for (; j + kLanes <= n; j += kLanes) acc = L::add(acc, lane(L::load(x + j), L::load(y + j), L::load(z + j)));
  if (j < n) {  // the tail through a padded copy (the caller's arrays end at n), masked off past n
    float tx[kLanes] = {}, ty[kLanes] = {}, tz[kLanes] = {};
    for (std::size_t i = 0; j + i < n; ++i) tx[i] = x[j + i], ty[i] = y[j + i], tz[i] = z[j + i];
    const V keep = L::lt(L::load(kIndex), L::set1(static_cast<float>(n - j)));
    acc = L::add(acc, L::band(keep, lane(L::load(tx), L::load(ty), L::load(tz))));
  }
  float part[kLanes];
  L::store(part, acc);
  float sum = 0.0f;
  for (const float v : part) sum += v;
  return sum;
}
template <typename L>
inline float zoneSumLanes(float qx, float qy, float qz, const float* x, const float* y, const float* z,
                          std::size_t n, float a, float b) {
  return zoneSumFrom<L>(qx, qy, qz, x, y, z, n, a, b, 0, L::set1(0.0f));
}

#if SWARMSIM_X86_LANES
__attribute__((flatten)) float zoneSumSse(float qx, float qy, float qz, const float* x, const float* y, const float* z,
                                          std::size_t n, float a, float b) {
  return zoneSumLanes<SseLanes>(qx, qy, qz, x, y, z, n, a, b);
}
SWARMSIM_AVX __attribute__((flatten)) float zoneSumAvx(float qx, float qy, float qz, const float* x, const float* y,
                                                       const float* z, std::size_t n, float a, float b) {
  return zoneSumLanes<AvxLanes>(qx, qy, qz, x, y, z, n, a, b);
}

// zoneSumAvx's sum (the same bits): e^x of sixteen points at a time, their two halves added to the eight lanes'
// sums one after the other, as the eight-lane loop adds them; the last block too (no scalar tail)
SWARMSIM_AVX512 __attribute__((flatten)) float zoneSumAvx512(float qx, float qy, float qz, const float* x,
                                                              const float* y, const float* z, std::size_t n, float a,
                                                              float b) {
  using W = Avx512Lanes;
  const W::V vqx = W::set1(qx), vqy = W::set1(qy), vqz = W::set1(qz), va = W::set1(a), vb = W::set1(b);
  AvxLanes::V acc = AvxLanes::set1(0.0f);
  for (std::size_t j = 0; j < n; j += 16) {
    // the last block by masked loads, its lanes past n zero: adding zero to a (non-negative) sum changes no bit,
    // so this is the eight-lane loop's sum, its padded tail included
    const __mmask16 live = static_cast<__mmask16>(firstLanes(n - j, 16));
    const W::V px = {_mm512_maskz_loadu_ps(live, x + j)}, py = {_mm512_maskz_loadu_ps(live, y + j)};
    const W::V pz = {_mm512_maskz_loadu_ps(live, z + j)};
    const W::V dx = W::sub(vqx, px), dy = W::sub(vqy, py), dz = W::sub(vqz, pz);
    const W::V d = W::sqrt(W::add(W::add(W::mul(dx, dx), W::mul(dy, dy)), W::mul(dz, dz)));
    const W::V e = {_mm512_maskz_mov_ps(live, expLanes<W>(W::add(va, W::mul(vb, d))).a)};
    AvxLanes::V lo, hi;
    W::halves(e, lo, hi);
    acc = AvxLanes::add(AvxLanes::add(acc, lo), hi);
  }
  float part[kLanes];
  AvxLanes::store(part, acc);
  float sum = 0.0f;
  for (const float v : part) sum += v;
  return sum;
}

// AVX-512 for the sums where laneSet() takes it (as the environment was when first asked: they run many times per
// agent, and every lane type gives the same bits)
inline bool sumsOnAvx512() {
  static const bool yes = laneSet() == LaneSet::kAvx512;
  return yes;
}
#endif

inline float zoneSum(bool avx, const Vec3& q, const float* x, const float* y, const float* z, std::size_t n, float a,
                     float b) {
#if SWARMSIM_X86_LANES
  return (avx ? (sumsOnAvx512() ? zoneSumAvx512 : zoneSumAvx) : zoneSumSse)(q.x(), q.y(), q.z(), x, y, z, n, a, b);
#else
  (void)avx;
  return zoneSumLanes<ScalarLanes>(q.x(), q.y(), q.z(), x, y, z, n, a, b);
#endif
}

// the interaction terms of eq. 4 and 6 at the agent's position q
inline void zoneTerms(bool avx, const AgentInput& in, const Vec3& q, const EnergyParams& p, float& rep, float& oa) {
  rep = oa = 0.0f;
  if (p.w.rep > 0.0f && in.rep > 0) {
    rep = p.w.rep * zoneSum(avx, q, in.repX, in.repY, in.repZ, in.rep, p.rho, -p.rho / p.dRep) /
          static_cast<float>(in.rep);
  }
  if (p.w.oa > 0.0f && in.att > 0) {
    oa = p.w.oa * zoneSum(avx, q, in.attX, in.attY, in.attZ, in.att, -p.rho, p.rho / p.dAtt1) /
         static_cast<float>(in.att);
  }
}

}  // namespace

EnergyTerms energyTerms(const AgentInput& in, const Candidates& c, std::size_t k, const EnergyParams& p) {
  return energyTermsWith(useAvx(), in, c, k, p);
}

EnergyTerms energyTermsWith(bool avx, const AgentInput& in, const Candidates& c, std::size_t k, const EnergyParams& p) {
  EnergyTerms e;
  const Vec3 v(c.vx[k], c.vy[k], c.vz[k]);
  const float rho = p.rho;
  // eq. 4: repulsion from the predicted positions (agent i with v, neighbour j with its own velocity); eq. 6:
  // attraction toward the neighbours' current positions
  zoneTerms(avx, in, in.p + v * p.dt, p, e.rep, e.oa);
  // eq. 11-12, startled: Ψ = 1 − |p' − p_sti| / d_danger per predator that startles the agent (the distance to
  // a sphere's surface)
  if (p.w.env > 0.0f && in.dangers > 0) {
    const Vec3 q = in.p + v * p.dangerAhead();
    for (std::size_t j = 0; j < in.dangers; ++j) {
      const float d = (q - Vec3(in.dangerX[j], in.dangerY[j], in.dangerZ[j])).norm() - in.dangerR[j];
      e.danger += p.w.env * std::exp(rho * (1.0f - d / p.dDanger));
    }
  }
  ownTerms(in, c, k, p, e);
  return e;
}

SearchLanes searchLanes() { return searchLanes(laneSet()); }

SearchLanes searchLanes(LaneSet set) {
  switch (set) {
    case LaneSet::kSse:
      return SearchLanes::kSse;
    case LaneSet::kAvx:
      return SearchLanes::kAvx;
    case LaneSet::kAvx2:
    case LaneSet::kAvx512:
      break;
  }
#if SWARMSIM_X86_LANES
  static const bool fma = __builtin_cpu_supports("fma");
  if (!fma) return SearchLanes::kAvx;
  return set == LaneSet::kAvx512 ? SearchLanes::kAvx512 : SearchLanes::kAvx2Fma;
#else
  return SearchLanes::kSse;
#endif
}

std::size_t argminEnergy(const AgentInput& in, const Candidates& c, std::size_t first, std::size_t last,
                         const EnergyParams& p, float* best) {
  std::size_t arg = first;
  float least = std::numeric_limits<float>::infinity();
  for (std::size_t k = first; k < last; ++k) {
    const float e = energyTerms(in, c, k, p).total();
    if (e < least) {  // strict: the lowest index wins a tie
      least = e;
      arg = k;
    }
  }
  if (best) *best = least;
  return arg;
}

void BoundFactors::build(const Candidates& c, const EnergyParams& p) {
  rep.resize(c.size());
  oa.resize(c.size());
  danger.resize(c.size());
  for (std::size_t k = 0; k < c.size(); ++k) {
    const float step = std::sqrt(c.vx[k] * c.vx[k] + c.vy[k] * c.vy[k] + c.vz[k] * c.vz[k]) * p.dt;
    // a little below the exact factor: float rounding of the sums must not lift the bound above E
    rep[k] = std::exp(-p.rho * step / p.dRep) * (1.0f - 1e-3f);
    oa[k] = std::exp(-p.rho * step / p.dAtt1) * (1.0f - 1e-3f);
    danger[k] = std::exp(-p.rho * step / p.dt * p.dangerAhead() / p.dDanger) * (1.0f - 1e-3f);
  }
}

std::size_t argminEnergyBounded(const AgentInput& in, const Candidates& c, const BoundFactors& f, std::size_t first,
                                std::size_t last, const EnergyParams& p, std::vector<float>& lower, float* best,
                                SearchLanes lanes) {
  // the interaction energies at q = p (no move): each neighbour's distance changes by at most |v| Δt
  const bool avx = lanes != SearchLanes::kSse;
  float danger0 = 0.0f;
  if (p.w.env > 0.0f && in.dangers > 0) {
    for (std::size_t j = 0; j < in.dangers; ++j) {
      const float d = (in.p - Vec3(in.dangerX[j], in.dangerY[j], in.dangerZ[j])).norm() - in.dangerR[j];
      danger0 += p.w.env * std::exp(p.rho * (1.0f - d / p.dDanger));
    }
  }
  lower.resize(boundScratchSize(last - first));
#if SWARMSIM_X86_LANES
  if (lanes == SearchLanes::kAvx512) return argminAvx512(in, c, f, first, last, p, danger0, lower.data(), best);
  if (lanes == SearchLanes::kAvx2Fma) return argminAvx2(in, c, f, first, last, p, danger0, lower.data(), best);
#endif
  float rep0 = 0.0f, oa0 = 0.0f;
  zoneTerms(avx, in, in.p, p, rep0, oa0);
  // lower bounds: the own terms (on SIMD lanes, less a margin for their e^x and the order of the sums; the
  // rest exactly as energyTerms), the interaction bounded below
  std::size_t start = first;
  float startBound = std::numeric_limits<float>::infinity();
  const std::size_t blocks = (last - first) / kLanes;
#if SWARMSIM_X86_LANES
  (avx ? ownTotalsAvx : ownTotalsSse)(in, c, first, blocks, p, lower.data());
#else
  ownTotalsLanes<ScalarLanes>(in, c, first, blocks, p, lower.data());
#endif
  for (std::size_t i = 0; i < blocks * kLanes; ++i) lower[i] *= 1.0f - 1e-5f;
  for (std::size_t k = first + blocks * kLanes; k < last; ++k) {
    EnergyTerms e;
    ownTerms(in, c, k, p, e);
    lower[k - first] = ownTotal(e);
  }
  for (std::size_t k = first; k < last; ++k) {
    const float lb = lower[k - first] + f.rep[k] * rep0 + f.oa[k] * oa0 + f.danger[k] * danger0;
    lower[k - first] = lb;
    if (lb < startBound) {
      startBound = lb;
      start = k;
    }
  }
  // the exact E where the bound is least, then wherever the bound could still beat the best so far
  std::size_t arg = start;
  float least = energyTermsWith(avx, in, c, start, p).total();
  for (std::size_t k = first; k < last; ++k) {
    if (k == start || !(lower[k - first] <= least)) continue;
    keepBest(energyTermsWith(avx, in, c, k, p).total(), k, least, arg);
  }
  if (best) *best = least;
  return arg;
}

}  // namespace swarmsim::fastswarm
