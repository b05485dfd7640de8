#include "models/boids/boids_update.hpp"

#include <algorithm>

namespace swarmsim {

namespace {

// the inputs of eight agents from index `first` on: p (0-2), u (3-5), v (6-8), the sums (9-17) and the jitter's
// uniforms (18-21), each as eight floats in memory (the row's own arrays for a whole eight; for a row's last
// agents, copies of them in `tail`, zeros in the lanes past them, whose results are not written)
constexpr int kInputs = 22;
struct Inputs {
  const float* in[kInputs];
};
struct Tail {
  alignas(32) float in[kInputs][kLanes];
};

// the row's arrays in that order (the jitter's null without it)
inline Inputs rowArrays(const BoidsUpdateRow& r) {
  Inputs a = {{r.px, r.py, r.pz, r.ux, r.uy, r.uz, r.vx, r.vy, r.vz}};
  for (int q = 0; q < 9; ++q) a.in[9 + q] = r.sums[q];
  for (int q = 0; q < 4; ++q) a.in[18 + q] = r.jitter[q];
  return a;
}

inline Inputs inputsAt(const Inputs& arrays, std::size_t first, std::size_t count, Tail& tail) {
  Inputs b;
  for (int q = 0; q < kInputs; ++q) {
    const float* a = arrays.in[q];
    if (!a) {
      b.in[q] = nullptr;
    } else if (count == kLanes) {
      b.in[q] = a + first;
    } else {
      std::fill(tail.in[q], tail.in[q] + kLanes, 0.0f);
      std::copy(a + first, a + first + count, tail.in[q]);
      b.in[q] = tail.in[q];
    }
  }
  return b;
}

// the new velocities of a block's eight agents, out[axis][lane]
template <typename L>
inline void updateEight(const Inputs& b, const BoidsUpdateParams& p, bool jitter, float out[3][kLanes]) {
  using V = typename L::V;
  const auto at = [&](int q) { return L::load(b.in[q]); };
  const V zero = L::set1(0.0f), one = L::set1(1.0f);
  V x[3], u[3], v[3];
  for (int a = 0; a < 3; ++a) {
    x[a] = at(a);
    u[a] = at(3 + a);
    v[a] = at(6 + a);
  }
  // cruise and the zones (the repulsion sum negated), added in the order of the equation
  V t[3];
  for (int a = 0; a < 3; ++a) {
    const V rep = L::sub(zero, at(9 + a)), ali = at(12 + a), att = at(15 + a);
    t[a] = L::add(L::add(L::add(L::mul(u[a], L::set1(p.smin)), L::mul(rep, L::set1(p.fr))), L::mul(ali, L::set1(p.fa))),
                  L::mul(att, L::set1(p.ft)));
  }
  // the centre pull: (c − x) min(1, |c − x| / R_c) / |c − x| (no minimum without a radius), none at the centre
  V dc[3];
  for (int a = 0; a < 3; ++a) dc[a] = L::sub(L::set1(p.center[a]), x[a]);
  const V d = L::sqrt(L::add(L::add(L::mul(dc[0], dc[0]), L::mul(dc[1], dc[1])), L::mul(dc[2], dc[2])));
  const V scale = p.invCr > 0.0f ? L::min(one, L::mul(d, L::set1(p.invCr))) : one;
  const V away = L::gt(d, zero);
  const V pull = L::band(away, L::div(scale, selectLanes<L>(away, d, one)));
  for (int a = 0; a < 3; ++a) t[a] = L::add(t[a], L::mul(L::mul(dc[a], pull), L::set1(p.fc)));
  // the soft walls, axis by axis: the depth inside the margin over the margin, inward
  const V margin = L::set1(p.margin);
  for (int a = 0; a < 3; ++a) {
    const V lo = L::sub(L::set1(p.lo[a] + p.margin), x[a]);
    const V hi = L::sub(x[a], L::set1(p.hi[a] - p.margin));
    const V wall = L::sub(L::band(L::gt(lo, zero), L::div(lo, margin)), L::band(L::gt(hi, zero), L::div(hi, margin)));
    t[a] = L::add(t[a], L::mul(wall, L::set1(p.fw)));
  }
  // the jitter: three standard normals (Box-Muller on two pairs of uniforms) times σ k
  if (jitter) {
    const V minus2 = L::set1(-2.0f);
    const V r1 = L::sqrt(L::mul(minus2, logUnitLanes<L>(L::sub(one, at(18)))));
    const V r2 = L::sqrt(L::mul(minus2, logUnitLanes<L>(L::sub(one, at(20)))));
    V c1, s1, c2, s2;
    cosSinTurnLanes<L>(at(19), c1, s1);
    cosSinTurnLanes<L>(at(21), c2, s2);
    const V normal[3] = {L::mul(r1, c1), L::mul(r1, s1), L::mul(r2, c2)};
    for (int a = 0; a < 3; ++a) t[a] = L::add(t[a], L::mul(normal[a], L::set1(p.noise)));
  }
  // the blend toward the target, then the speed limits
  V nv[3];
  for (int a = 0; a < 3; ++a) nv[a] = L::add(v[a], L::mul(L::sub(t[a], v[a]), L::set1(p.blend)));
  const V sp = L::sqrt(L::add(L::add(L::mul(nv[0], nv[0]), L::mul(nv[1], nv[1])), L::mul(nv[2], nv[2])));
  const V smax = L::set1(p.smax), smin = L::set1(p.smin);
  const V over = L::gt(sp, smax);
  const V under = L::andnot(over, L::lt(sp, smin));
  // below the cruise speed: along its own direction, else the old heading, else +x
  const V moving = L::gt(sp, L::set1(1e-12f));
  const V heading = L::gt(L::add(L::add(L::mul(u[0], u[0]), L::mul(u[1], u[1])), L::mul(u[2], u[2])), zero);
  const V safe = selectLanes<L>(moving, sp, one);
  const V down = L::div(smax, safe);
  for (int a = 0; a < 3; ++a) {
    const V fallback = selectLanes<L>(heading, u[a], a == 0 ? one : zero);
    const V dir = selectLanes<L>(moving, L::div(nv[a], safe), fallback);
    const V r = selectLanes<L>(over, L::mul(nv[a], down), selectLanes<L>(under, L::mul(dir, smin), nv[a]));
    L::store(out[a], r);
  }
}

template <typename L>
inline void updateRow(const BoidsUpdateRow& r, std::size_t m, const BoidsUpdateParams& p) {
  const bool jitter = r.jitter[0] != nullptr;
  const Inputs arrays = rowArrays(r);
  Tail tail;
  alignas(32) float out[3][kLanes];
  for (std::size_t first = 0; first < m; first += kLanes) {
    const std::size_t count = std::min(kLanes, m - first);
    updateEight<L>(inputsAt(arrays, first, count, tail), p, jitter, out);
    // (after every read of the eight: v is read and written in place)
    for (std::size_t l = 0; l < count; ++l) {
      r.vx[first + l] = out[0][l];
      r.vy[first + l] = out[1][l];
      r.vz[first + l] = out[2][l];
    }
  }
}

// normalizedOrZero of m velocities, eight at a time, with the same operations: the squared norm as
// x² + (y² + z²) (Eigen's unrolled sum splits three terms so), its square root, each component divided by it;
// zero where the squared norm is not above 1e-30
template <typename L>
inline void unitsOf(const float* vx, const float* vy, const float* vz, std::size_t m, float* ux, float* uy, float* uz) {
  using V = typename L::V;
  std::size_t i = 0;
  for (; i + kLanes <= m; i += kLanes) {
    const V x = L::load(vx + i), y = L::load(vy + i), z = L::load(vz + i);
    const V n2 = L::add(L::mul(x, x), L::add(L::mul(y, y), L::mul(z, z)));
    const V keep = L::lt(L::set1(1e-30f), n2);
    const V n = L::sqrt(n2);
    L::store(ux + i, L::band(keep, L::div(x, n)));
    L::store(uy + i, L::band(keep, L::div(y, n)));
    L::store(uz + i, L::band(keep, L::div(z, n)));
  }
  for (; i < m; ++i) {
    const Vec3 u = normalizedOrZero(Vec3(vx[i], vy[i], vz[i]));
    ux[i] = u.x();
    uy[i] = u.y();
    uz[i] = u.z();
  }
}

#if SWARMSIM_X86_LANES
SWARMSIM_AVX __attribute__((flatten)) void unitsAvx(const float* vx, const float* vy, const float* vz, std::size_t m,
                                                    float* ux, float* uy, float* uz) {
  unitsOf<AvxLanes>(vx, vy, vz, m, ux, uy, uz);
}
__attribute__((flatten)) void updateSse(const BoidsUpdateRow& r, std::size_t m, const BoidsUpdateParams& p) {
  updateRow<SseLanes>(r, m, p);
}
SWARMSIM_AVX __attribute__((flatten)) void updateAvx(const BoidsUpdateRow& r, std::size_t m,
                                                     const BoidsUpdateParams& p) {
  updateRow<AvxLanes>(r, m, p);
}
#endif

}  // namespace

void boidsUpdate(const BoidsUpdateRow& row, std::size_t m, const BoidsUpdateParams& p, LaneSet lanes) {
#if SWARMSIM_X86_LANES
  if (lanes == LaneSet::kSse) {
    updateSse(row, m, p);
  } else {
    updateAvx(row, m, p);
  }
#else
  (void)lanes;
  updateRow<ScalarLanes>(row, m, p);
#endif
}

void unitVelocities(const float* vx, const float* vy, const float* vz, std::size_t m, float* ux, float* uy, float* uz,
                    LaneSet lanes) {
#if SWARMSIM_X86_LANES
  if (lanes != LaneSet::kSse) {
    unitsAvx(vx, vy, vz, m, ux, uy, uz);
    return;
  }
#else
  (void)lanes;
#endif
  unitsOf<ScalarLanes>(vx, vy, vz, m, ux, uy, uz);
}

}  // namespace swarmsim
