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

// Σ_j e^{a + b |q − p_j|} over n points, eight at a time on SIMD lanes with the lanes' e^x, the lanes added in a
// fixed order at the end: every lane type gives the same bits (the eq. 4, 6 and 12 sums)
template <typename L>
inline float zoneSumLanes(float qx, float qy, float qz, const float* x, const float* y, const float* z,
                          std::size_t n, float a, float b) {
  using V = typename L::V;
  alignas(32) static constexpr float kIndex[kLanes] = {0, 1, 2, 3, 4, 5, 6, 7};
  const V vqx = L::set1(qx), vqy = L::set1(qy), vqz = L::set1(qz), va = L::set1(a), vb = L::set1(b);
  const auto lane = [&](V px, V py, V pz) __attribute__((always_inline)) {
    const V dx = L::sub(vqx, px), dy = L::sub(vqy, py), dz = L::sub(vqz, pz);
    const V d = L::sqrt(L::add(L::add(L::mul(dx, dx), L::mul(dy, dy)), L::mul(dz, dz)));
    return expLanes<L>(L::add(va, L::mul(vb, d)));
  };
  V acc = L::set1(0.0f);
  std::size_t j = 0;
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

#if SWARMSIM_X86_LANES
__attribute__((flatten)) float zoneSumSse(float qx, float qy, float qz, const float* x, const float* y, const float* z,
                                          std::size_t n, float a, float b) {
  return zoneSumLanes<SseLanes>(qx, qy, qz, x, y, z, n, a, b);
}
SWARMSIM_AVX __attribute__((flatten)) float zoneSumAvx(float qx, float qy, float qz, const float* x, const float* y,
                                                       const float* z, std::size_t n, float a, float b) {
  return zoneSumLanes<AvxLanes>(qx, qy, qz, x, y, z, n, a, b);
}
#endif

inline float zoneSum(bool avx, const Vec3& q, const float* x, const float* y, const float* z, std::size_t n, float a,
                     float b) {
#if SWARMSIM_X86_LANES
  return (avx ? zoneSumAvx : zoneSumSse)(q.x(), q.y(), q.z(), x, y, z, n, a, b);
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
                                std::size_t last, const EnergyParams& p, std::vector<float>& lower, float* best) {
  // the interaction energies at q = p (no move): each neighbour's distance changes by at most |v| Δt
  const bool avx = useAvx();
  float rep0 = 0.0f, oa0 = 0.0f;
  zoneTerms(avx, in, in.p, p, rep0, oa0);
  float danger0 = 0.0f;
  if (p.w.env > 0.0f && in.dangers > 0) {
    for (std::size_t j = 0; j < in.dangers; ++j) {
      const float d = (in.p - Vec3(in.dangerX[j], in.dangerY[j], in.dangerZ[j])).norm() - in.dangerR[j];
      danger0 += p.w.env * std::exp(p.rho * (1.0f - d / p.dDanger));
    }
  }
  // lower bounds: the own terms (on SIMD lanes, less a margin for their e^x and the order of the sums; the
  // rest exactly as energyTerms), the interaction bounded below
  lower.resize(last - first + kLanes);
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
  std::size_t start = first;
  float startBound = std::numeric_limits<float>::infinity();
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
    const float e = energyTermsWith(avx, in, c, k, p).total();
    if (e < least || (e == least && k < arg)) {  // the lowest index wins a tie, as in argminEnergy
      least = e;
      arg = k;
    }
  }
  if (best) *best = least;
  return arg;
}

}  // namespace swarmsim::fastswarm
