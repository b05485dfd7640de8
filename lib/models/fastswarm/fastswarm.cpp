#include "models/fastswarm/fastswarm.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <filesystem>
#include <limits>
#include <utility>

#include "core/error.hpp"
#include "core/lanes.hpp"
#include "core/parallel.hpp"
#include "fields/curl_noise.hpp"
#include "fields/noise_field.hpp"
#include "geometry/obstacles.hpp"
#include "geometry/signed_distance.hpp"
#include "models/params_util.hpp"
#include "spatial/seen_agents.hpp"
#include "spatial/uniform_grid.hpp"

namespace swarmsim {

namespace fastswarm {

void candidateRange(const Reference& ref, double speed, std::int64_t k, std::size_t& first, std::size_t& last) {
  const auto groups = static_cast<std::int64_t>(ref.groups());
  const std::int64_t size = std::max<std::int64_t>(1, ref.groupSize);
  std::int64_t want = std::max<std::int64_t>(1, (k + size - 1) / size);  // whole groups holding >= k samples
  if (want % 2 == 0) ++want;                                              // as many on each side
  want = std::min(want, groups);
  const auto g = static_cast<std::int64_t>(ref.groupOfSpeed(speed));
  std::int64_t lo = g - (want - 1) / 2;
  lo = std::clamp<std::int64_t>(lo, 0, groups - want);
  first = static_cast<std::size_t>(ref.groupStart[static_cast<std::size_t>(lo)]);
  last = static_cast<std::size_t>(ref.groupStart[static_cast<std::size_t>(lo + want)]);
}

KeypointTask startTask(const KeypointCurve& curve, const Vec3& p, std::uint32_t id) {
  KeypointTask t;
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < curve.points.size(); ++k) {
    const double d = (curve.points[k] - p.cast<double>()).squaredNorm();
    if (d < best) {
      best = d;
      t.goal = static_cast<std::int32_t>(k);
    }
  }
  t.dir = curve.bidirectional && (id % 2 == 1) ? -1 : 1;
  return t;
}

void advanceTask(const KeypointCurve& curve, const Vec3& p, KeypointTask& t) {
  const auto n = static_cast<std::int32_t>(curve.points.size());
  if (t.goal < 0 || t.goal >= n) return;
  const double r = curve.radius;
  if ((curve.points[static_cast<std::size_t>(t.goal)] - p.cast<double>()).squaredNorm() > r * r) return;
  std::int32_t next = t.goal + t.dir;
  if (curve.closed) {
    next = (next % n + n) % n;
  } else if (next < 0 || next >= n) {  // an open curve: turn back at its ends
    t.dir = -t.dir;
    next = t.goal + t.dir;
  }
  t.goal = next;
}

}  // namespace fastswarm

namespace {

using fastswarm::AgentInput;
using fastswarm::Candidates;

class FastswarmConfig final : public ModelConfig {
 public:
  explicit FastswarmConfig(FastswarmParams p) : p_(std::move(p)) {}
  std::unique_ptr<Model> build(const World& world) const override { return makeFastswarm(p_, world); }

 private:
  FastswarmParams p_;
};

// per-thread scratch: one agent's neighbours (the zones' arrays hold nRep and nAtt entries; their sizes are
// capacity, with room for the packing kernels' whole-vector stores)
struct Scratch {
  std::vector<float> rx, ry, rz, ax, ay, az;
  std::size_t nRep = 0, nAtt = 0;
  std::vector<float> lx, ly, lz, dx, dy, dz, dr;  // stimuli: lures' directions, dangers' centres and radii
  std::vector<float> lower;  // the candidates' lower bounds
  std::vector<std::uint32_t> runs;  // the grid's runs [begin, end) of one agent's query
  std::size_t scanned = 0;  // points of the grid's runs read this step
  // room for `more` further entries in each zone, and a whole vector past them
  void reserveZones(std::size_t more) {
    const std::size_t need = std::max(nRep, nAtt) + more + 16;
    if (rx.size() >= need) return;
    for (auto* v : {&rx, &ry, &rz, &ax, &ay, &az}) v->resize(std::max(need, 2 * v->size()));
  }
};

// a neighbour at squared distance d2 into the agent's zones: repulsion (closer than d_rep) as its predicted
// position p + v dt, attraction (d_att,1 and beyond) as its position; between the two, neither
__attribute__((always_inline)) inline void addToZones(Scratch& sc, float d2, float rep2, float att12, float px, float py,
                                                      float pz, float vx, float vy, float vz, float dt) {
  if (d2 < rep2) {
    sc.reserveZones(1);
    sc.rx[sc.nRep] = px + vx * dt;
    sc.ry[sc.nRep] = py + vy * dt;
    sc.rz[sc.nRep] = pz + vz * dt;
    ++sc.nRep;
  } else if (d2 >= att12) {
    sc.reserveZones(1);
    sc.ax[sc.nAtt] = px;
    sc.ay[sc.nAtt] = py;
    sc.az[sc.nAtt] = pz;
    ++sc.nAtt;
  }
}

// the zones of the agent at sorted position `self` (q), gathered from one run [begin, end) of the grid's sorted
// points eight at a time: repulsion neighbours (d^2 < rep2) as predicted positions p + v dt, attraction
// neighbours (att12 <= d^2 <= r2) as positions, each in the run's order (the order of a plain loop)
struct ZoneInput {
  const float *sx, *sy, *sz, *vx, *vy, *vz;
  std::size_t n;
  std::uint32_t self;
  float qx, qy, qz, rep2, att12, r2, dt;
  bool clip;  // runs cut to the ball (UniformGrid::forEachRunInBall) rather than whole rows of the cube
};

// f(begin, end) for the grid's runs that can hold the agent's neighbours within r, their points counted into
// scanned: cut to the ball where that pays (z.clip: a dense swarm, where it skips a third of the points), else
// forEachRun's rows of the cube (a small or sparse swarm: the cuts' square roots cost more than they save)
template <typename F>
__attribute__((always_inline)) inline void forEachZoneRun(const UniformGrid& grid, const ZoneInput& z, float r,
                                                          std::size_t& scanned, F&& f) {
  const auto g = [&](std::uint32_t b, std::uint32_t e) __attribute__((always_inline)) {
    scanned += e - b;
    f(b, e);
  };
  if (z.clip) {
    grid.forEachRunInBall(z.qx, z.qy, z.qz, r, g);
  } else {
    grid.forEachRun(z.qx, z.qy, z.qz, r, g);
  }
}

// the points [j, end) one at a time (a run's last points, fewer than a vector before the grid's end)
__attribute__((always_inline)) inline void collectTail(const ZoneInput& z, std::uint32_t j, std::uint32_t end,
                                                       Scratch& sc) {
  for (; j < end; ++j) {
    const float dx = z.sx[j] - z.qx, dy = z.sy[j] - z.qy, dz = z.sz[j] - z.qz;
    const float d2 = dx * dx + dy * dy + dz * dz;
    if (d2 <= z.r2 && j != z.self) addToZones(sc, d2, z.rep2, z.att12, z.sx[j], z.sy[j], z.sz[j], z.vx[j], z.vy[j], z.vz[j], z.dt);
  }
}

template <typename L>
__attribute__((always_inline)) inline void collectRunLanes(const ZoneInput& z, std::uint32_t begin, std::uint32_t end,
                                                           Scratch& sc) {
  using V = typename L::V;
  alignas(32) static constexpr float kIndex[kLanes] = {0, 1, 2, 3, 4, 5, 6, 7};
  const V qx = L::set1(z.qx), qy = L::set1(z.qy), qz = L::set1(z.qz);
  const V rep2 = L::set1(z.rep2), att12 = L::set1(z.att12), r2 = L::set1(z.r2), index = L::load(kIndex);
  const auto take = [&](std::uint32_t k, float d2) __attribute__((always_inline)) {
    if (k != z.self) addToZones(sc, d2, z.rep2, z.att12, z.sx[k], z.sy[k], z.sz[k], z.vx[k], z.vy[k], z.vz[k], z.dt);
  };
  std::uint32_t j = begin;
  for (; j < end && j + kLanes <= z.n; j += kLanes) {
    const V dx = L::sub(L::load(z.sx + j), qx), dy = L::sub(L::load(z.sy + j), qy), dz = L::sub(L::load(z.sz + j), qz);
    const V d2 = L::add(L::add(L::mul(dx, dx), L::mul(dy, dy)), L::mul(dz, dz));
    const V inRun = L::lt(index, L::set1(static_cast<float>(end - j)));
    // in a zone: closer than d_rep, or from d_att,1 to d_att,2
    const V hit = L::band(inRun, L::band(L::le(d2, r2), L::bor(L::lt(d2, rep2), L::le(att12, d2))));
    unsigned m = L::mask(hit);
    if (m == 0) continue;
    float d[kLanes];
    L::store(d, d2);
    for (; m != 0; m &= m - 1) {
      const unsigned i = static_cast<unsigned>(__builtin_ctz(m));
      take(j + i, d[i]);
    }
  }
  collectTail(z, j, end, sc);
}

template <typename L>
__attribute__((always_inline)) inline void collectZonesLanes(const UniformGrid& grid, const ZoneInput& z, float r,
                                                             Scratch& sc) {
  // (always inlined: a lambda does not inherit the AVX target, and a call would not inline the lanes)
  forEachZoneRun(grid, z, r, sc.scanned, [&](std::uint32_t b, std::uint32_t e) __attribute__((always_inline)) {
    collectRunLanes<L>(z, b, e, sc);
  });
}

#if SWARMSIM_X86_LANES
__attribute__((flatten)) void collectZonesSse(const UniformGrid& grid, const ZoneInput& z, float r, Scratch& sc) {
  collectZonesLanes<SseLanes>(grid, z, r, sc);
}
SWARMSIM_AVX __attribute__((flatten)) void collectZonesAvx(const UniformGrid& grid, const ZoneInput& z, float r,
                                                           Scratch& sc) {
  collectZonesLanes<AvxLanes>(grid, z, r, sc);
}
#endif

#if SWARMSIM_X86_LANES
// The same zones, the same order and bits, with the hits of each block packed by vector permutes (AVX2: the
// lane-pack table) instead of one at a time
template <typename P>
__attribute__((always_inline)) inline void packRun(const ZoneInput& z, std::uint32_t begin, std::uint32_t end,
                                                   Scratch& sc) {
  using V = typename P::V;
  constexpr std::uint32_t w = P::kWidth;
  sc.reserveZones(end - begin);
  // (locals: the stores below could alias the inputs' and the scratch's fields, which would be reloaded)
  const float *sx = z.sx, *sy = z.sy, *sz = z.sz, *vx = z.vx, *vy = z.vy, *vz = z.vz;
  float *rx = sc.rx.data(), *ry = sc.ry.data(), *rz = sc.rz.data();
  float *ax = sc.ax.data(), *ay = sc.ay.data(), *az = sc.az.data();
  std::size_t nRep = sc.nRep, nAtt = sc.nAtt;
  const std::uint32_t self = z.self, n = static_cast<std::uint32_t>(z.n);
  const float r2 = z.r2, rep2 = z.rep2, att12 = z.att12;
  const V qx = P::set1(z.qx), qy = P::set1(z.qy), qz = P::set1(z.qz), dt = P::set1(z.dt);
  std::uint32_t j = begin;
  for (; j < end && j + w <= n; j += w) {
    const V px = P::load(sx + j), py = P::load(sy + j), pz = P::load(sz + j);
    const V dx = P::sub(px, qx), dy = P::sub(py, qy), dz = P::sub(pz, qz);
    const V d2 = P::add(P::add(P::mul(dx, dx), P::mul(dy, dy)), P::mul(dz, dz));
    unsigned live = firstLanes(end - j, w) & P::le(d2, r2);
    if (self - j < w) live &= ~(1u << (self - j));
    const unsigned rep = live & P::lt(d2, rep2), att = live & ~rep & P::ge(d2, att12);
    if (rep != 0) {  // predicted positions p + v dt
      const V ex = P::add(px, P::mul(P::load(vx + j), dt)), ey = P::add(py, P::mul(P::load(vy + j), dt));
      const V ez = P::add(pz, P::mul(P::load(vz + j), dt));
      P::pack(rx + nRep, ex, rep);
      P::pack(ry + nRep, ey, rep);
      P::pack(rz + nRep, ez, rep);
      nRep += static_cast<std::size_t>(__builtin_popcount(rep));
    }
    if (att != 0) {
      P::pack(ax + nAtt, px, att);
      P::pack(ay + nAtt, py, att);
      P::pack(az + nAtt, pz, att);
      nAtt += static_cast<std::size_t>(__builtin_popcount(att));
    }
  }
  sc.nRep = nRep;
  sc.nAtt = nAtt;
  collectTail(z, j, end, sc);
}

struct Avx2Pack : AvxLanes {
  static constexpr std::uint32_t kWidth = 8;
  SWARMSIM_AVX2 static unsigned le(V x, float y) { return mask(AvxLanes::le(x, set1(y))); }
  SWARMSIM_AVX2 static unsigned lt(V x, float y) { return mask(AvxLanes::lt(x, set1(y))); }
  SWARMSIM_AVX2 static unsigned ge(V x, float y) { return mask(AvxLanes::le(set1(y), x)); }
  // the lanes of `mask`, in order, to out (all eight lanes are written)
  SWARMSIM_AVX2 static void pack(float* out, V x, unsigned bits) {
    const __m256i pick = _mm256_load_si256(reinterpret_cast<const __m256i*>(kLanePack.lanes[bits]));
    _mm256_storeu_ps(out, _mm256_permutevar8x32_ps(x.a, pick));
  }
};
SWARMSIM_AVX2 __attribute__((flatten)) void collectZonesAvx2(const UniformGrid& grid, const ZoneInput& z, float r,
                                                             Scratch& sc) {
  forEachZoneRun(grid, z, r, sc.scanned,
                  [&](std::uint32_t b, std::uint32_t e) __attribute__((always_inline)) { packRun<Avx2Pack>(z, b, e, sc); });
}
// The same zones in the same order with AVX-512, with few branches: the runs are listed first (their total length
// bounds the hits, so the arrays grow once), then every run is read sixteen points at a time by masked loads (no
// tail loop, nothing past a run is read), and the attraction zone's hits are compressed and stored whether or not
// there are any: a run holds a few vectors of points, and the branches of a per-hit or per-tail path, taken at
// random, cost more than the stores they save (4 % of a 100,000-agent step on Zen 5). Repulsion hits are rare:
// their branch is predicted.
SWARMSIM_AVX512 __attribute__((flatten)) void collectZonesAvx512(const UniformGrid& grid, const ZoneInput& z,
                                                                        float r, Scratch& sc) {
  std::size_t runs = 0, total = 0;
  forEachZoneRun(grid, z, r, sc.scanned, [&](std::uint32_t b, std::uint32_t e) __attribute__((always_inline)) {
    if (2 * runs + 2 > sc.runs.size()) sc.runs.resize(2 * runs + 64);
    sc.runs[2 * runs] = b;
    sc.runs[2 * runs + 1] = e;
    ++runs;
    total += e - b;
  });
  sc.reserveZones(total);
  const float *sx = z.sx, *sy = z.sy, *sz = z.sz, *vx = z.vx, *vy = z.vy, *vz = z.vz;
  float *rx = sc.rx.data() + sc.nRep, *ry = sc.ry.data() + sc.nRep, *rz = sc.rz.data() + sc.nRep;
  float *ax = sc.ax.data() + sc.nAtt, *ay = sc.ay.data() + sc.nAtt, *az = sc.az.data() + sc.nAtt;
  const __m512 qx = _mm512_set1_ps(z.qx), qy = _mm512_set1_ps(z.qy), qz = _mm512_set1_ps(z.qz);
  const __m512 r2 = _mm512_set1_ps(z.r2), rep2 = _mm512_set1_ps(z.rep2), att12 = _mm512_set1_ps(z.att12);
  const __m512 dt = _mm512_set1_ps(z.dt);
  const std::uint32_t* run = sc.runs.data();
  for (std::size_t i = 0; i < runs; ++i) {
    const std::uint32_t b = run[2 * i], e = run[2 * i + 1];
    // one block even for an empty run (all lanes off): no branch on whether the run is empty, which a sparse
    // swarm's rows make at random; a run longer than a vector loops
    std::uint32_t j = b;
    do {
      const std::uint32_t left = e - j;
      __mmask16 live = static_cast<__mmask16>(left >= 16 ? 0xffffu : (1u << left) - 1u);
      const std::uint32_t self = z.self - j;
      live = static_cast<__mmask16>(live & ~(self < 16 ? 1u << self : 0u));
      const __m512 px = _mm512_maskz_loadu_ps(live, sx + j), py = _mm512_maskz_loadu_ps(live, sy + j);
      const __m512 pz = _mm512_maskz_loadu_ps(live, sz + j);
      const __m512 dx = _mm512_sub_ps(px, qx), dy = _mm512_sub_ps(py, qy), dz = _mm512_sub_ps(pz, qz);
      // the same rounding as the other lanes: (dx dx + dy dy) + dz dz, no fused multiply-add
      const __m512 d2 = _mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(dx, dx), _mm512_mul_ps(dy, dy)), _mm512_mul_ps(dz, dz));
      const __mmask16 hit = _mm512_mask_cmp_ps_mask(live, d2, r2, _CMP_LE_OQ);
      const __mmask16 rep = _mm512_mask_cmp_ps_mask(hit, d2, rep2, _CMP_LT_OQ);
      const __mmask16 att = _mm512_mask_cmp_ps_mask(static_cast<__mmask16>(hit & ~rep), d2, att12, _CMP_GE_OQ);
      if (rep != 0) {  // rare (d_rep is a sixth of d_att,2: about one in 200 of the points in the ball), so
                       // this branch is predicted
        // predicted positions p + v dt (as the other lanes round them: a product, then a sum)
        const __m512 ex = _mm512_add_ps(px, _mm512_mul_ps(_mm512_maskz_loadu_ps(rep, vx + j), dt));
        const __m512 ey = _mm512_add_ps(py, _mm512_mul_ps(_mm512_maskz_loadu_ps(rep, vy + j), dt));
        const __m512 ez = _mm512_add_ps(pz, _mm512_mul_ps(_mm512_maskz_loadu_ps(rep, vz + j), dt));
        _mm512_storeu_ps(rx, _mm512_maskz_compress_ps(rep, ex));
        _mm512_storeu_ps(ry, _mm512_maskz_compress_ps(rep, ey));
        _mm512_storeu_ps(rz, _mm512_maskz_compress_ps(rep, ez));
      }
      _mm512_storeu_ps(ax, _mm512_maskz_compress_ps(att, px));
      _mm512_storeu_ps(ay, _mm512_maskz_compress_ps(att, py));
      _mm512_storeu_ps(az, _mm512_maskz_compress_ps(att, pz));
      const auto nr = static_cast<unsigned>(__builtin_popcount(rep)), na = static_cast<unsigned>(__builtin_popcount(att));
      rx += nr, ry += nr, rz += nr;
      ax += na, ay += na, az += na;
      j += 16;
    } while (j < e);
  }
  sc.nRep = static_cast<std::size_t>(rx - sc.rx.data());
  sc.nAtt = static_cast<std::size_t>(ax - sc.ax.data());
}
#endif

void collectZones(LaneSet lanes, const UniformGrid& grid, const ZoneInput& z, float r, Scratch& sc) {
#if SWARMSIM_X86_LANES
  switch (lanes) {
    case LaneSet::kSse:
      return collectZonesSse(grid, z, r, sc);
    case LaneSet::kAvx:
      return collectZonesAvx(grid, z, r, sc);
    case LaneSet::kAvx2:
      return collectZonesAvx2(grid, z, r, sc);
    case LaneSet::kAvx512:
      return collectZonesAvx512(grid, z, r, sc);
  }
#else
  (void)lanes;
  collectZonesLanes<ScalarLanes>(grid, z, r, sc);
#endif
}

class Fastswarm final : public Model {
 public:
  Fastswarm(const FastswarmParams& p, const World& world) : p_(p) {
    const fastswarm::Reference& ref = *p_.reference;
    for (std::size_t i = 0; i < ref.size(); ++i) {
      cand_.add(Vec3(static_cast<float>(ref.v[3 * i]), static_cast<float>(ref.v[3 * i + 1]),
                     static_cast<float>(ref.v[3 * i + 2])),
                Vec3(static_cast<float>(ref.a[3 * i]), static_cast<float>(ref.a[3 * i + 1]),
                     static_cast<float>(ref.a[3 * i + 2])));
    }
    p_.energy.dt = static_cast<float>(world.dt);
    bounds_.build(cand_, p_.energy);
    // a startled agent's weights (its bounds are the same: they depend on dt and the radii only)
    danger_ = p_.energy;
    const auto set = [](float& w, const std::optional<float>& v) {
      if (v) w = *v;
    };
    set(danger_.w.rep, p_.dangerRep);
    set(danger_.w.oa, p_.dangerOa);
    set(danger_.w.cos, p_.dangerCos);
    set(danger_.w.dir, p_.dangerDir);
    set(danger_.w.acc, p_.dangerAcc);
    set(danger_.w.n, p_.dangerN);
    // f_N: the direction of curl noise (eq. 13), blended along obstacles and walls as everywhere in swarmsim
    const Obstacles& obs = *world.obstacles;
    const GridSpec spec =
        GridSpec::covering(world.domain.min, world.domain.max, cellsForEdge(world.domain, world.domain.extent().maxCoeff() / 64.0, 1e6));
    boundary_ = signedDistance(obs, spec);
    addBoxWalls(boundary_, world.domain);
    NoiseParams np;
    np.scale = 1.0;
    np.unit = p_.noiseScale;
    np.gain = 1.0;  // only the direction is used
    np.seeds = p_.seeds;
    np.d0 = 0.5 * p_.noiseScale;
    noise_ = NoiseField(NoiseFieldKind::kCurl, np, world.domain, obs, {0, 0, 0}, &boundary_);
  }

  void step(const World& world, SwarmState& s, const StepInfo& info) override {
    const std::size_t n = s.size();
    const float dAtt2 = static_cast<float>(p_.dAtt2);
    grid_.build(s.px.data(), s.py.data(), s.pz.data(), n, dAtt2 * 0.5f);
    seen_.build(info.seen, dAtt2);  // the other swarms' agents count as neighbours in E_rep and E_oa
    const auto& order = grid_.order();
    const float* sx = grid_.sortedX().data();
    const float* sy = grid_.sortedY().data();
    const float* sz = grid_.sortedZ().data();
    grid_.gather(s.vx, vx_);
    grid_.gather(s.vy, vy_);
    grid_.gather(s.vz, vz_);
    // the swarm centre of E_cos: fixed, or the centroid (summed in state order: the same for any thread count)
    Vec3 center = Vec3::Zero();
    if (p_.center) {
      center = p_.center->cast<float>();
    } else if (n > 0) {
      Vec3d sum = Vec3d::Zero();
      for (std::size_t i = 0; i < n; ++i) sum += Vec3d(s.px[i], s.py[i], s.pz[i]);
      center = (sum / static_cast<double>(n)).cast<float>();
    }
    // v̂^n: the noise's direction at each agent (eq. 1: f_N of the current state), and v̂^cd (eq. 15): toward
    // each agent's goal keypoint, the goal advanced first where the agent reached it. Blocks of 64 agents, on
    // all threads from 256 agents on (a few microseconds of work per block: below that, one thread)
    for (auto* a : {&nx_, &ny_, &nz_}) a->resize(n);
    const KeypointCurve* curve = p_.control ? &*p_.control : nullptr;
    if (curve) {
      if (tasks_.size() < n) tasks_.resize(n);  // by id: ids are [0, n) (core/swarm_state.hpp)
      for (auto* a : {&cx_, &cy_, &cz_}) a->resize(n);
    }
    constexpr std::size_t kBlock = 64;
    const auto directions = [&](std::size_t block) {
      const std::size_t first = block * kBlock, last = std::min(n, first + kBlock);
      noise_.evaluateBatch(sx + first, sy + first, sz + first, last - first, nx_.data() + first, ny_.data() + first,
                           nz_.data() + first);
      if (!curve) return;
      for (std::size_t k = first; k < last; ++k) {
        const Vec3 p(sx[k], sy[k], sz[k]);
        KeypointTask& t = tasks_[s.id[order[k]]];
        if (t.goal < 0) {
          t = fastswarm::startTask(*curve, p, s.id[order[k]]);
        } else {
          fastswarm::advanceTask(*curve, p, t);
        }
        const Vec3 d = fastswarm::unitOrZero(curve->points[static_cast<std::size_t>(t.goal)].cast<float>() - p);
        cx_[k] = d.x();
        cy_[k] = d.y();
        cz_[k] = d.z();
      }
    };
    const std::size_t blocks = (n + kBlock - 1) / kBlock;
    if (n >= 256) {
      parallelForDynamic(blocks, 1, directions);
    } else {
      for (std::size_t b = 0; b < blocks; ++b) directions(b);
    }
    if (p_.successors && current_.size() < n) current_.resize(n, -1);  // by id, -1: none yet
    // the stimuli's centres now
    stimulusAt_.clear();
    for (const FastswarmStimulus& st : p_.stimuli) stimulusAt_.push_back(st.path.at(info.time).cast<float>());
    if (scratch_.size() < static_cast<std::size_t>(threadCount())) scratch_.resize(static_cast<std::size_t>(threadCount()));
    next_.resizeStorage(n);
    const float dt = static_cast<float>(world.dt);
    const float rep2 = p_.energy.dRep * p_.energy.dRep, att12 = p_.energy.dAtt1 * p_.energy.dAtt1;
    const fastswarm::Reference& ref = *p_.reference;
    // per agent, dynamically scheduled: an agent's search (microseconds) outweighs its neighbour lookup, and a
    // dense swarm fills only a few grid cells, which would leave threads idle if the work went cell by cell
    const LaneSet laneKind = laneSet();
    const fastswarm::SearchLanes lanes = fastswarm::searchLanes(laneKind);
    const bool avx = laneKind != LaneSet::kSse;
    parallelForDynamic(n, 16, [&](std::size_t k) {
      Scratch& sc = scratch_[static_cast<std::size_t>(threadIndex())];
      sc.nRep = sc.nAtt = 0;
      // the zones, in the grid's (deterministic) order: repulsion within d_rep (predicted positions),
      // attraction from d_att,1 to d_att,2 (current positions)
      ZoneInput zin{sx, sy, sz, vx_.data(), vy_.data(), vz_.data(), n, static_cast<std::uint32_t>(k), sx[k], sy[k], sz[k],
                    rep2, att12, dAtt2 * dAtt2, dt, clipRuns_};
      collectZones(laneKind, grid_, zin, dAtt2, sc);
      seen_.forEachNear(sx[k], sy[k], sz[k], dAtt2, [&](float px, float py, float pz, float ux, float uy, float uz, float d2) {
        addToZones(sc, d2, rep2, att12, px, py, pz, ux, uy, uz, dt);
      });
      AgentInput in;
      in.p = Vec3(sx[k], sy[k], sz[k]);
      in.v = Vec3(vx_[k], vy_[k], vz_[k]);
      in.vhat = fastswarm::unitOrZero(in.v);
      in.center = fastswarm::unitOrZero(center - in.p);
      in.noise = fastswarm::unitOrZero(Vec3(nx_[k], ny_[k], nz_[k]));
      if (p_.control) in.control = Vec3(cx_[k], cy_[k], cz_[k]);
      // eq. 11-12: every attractor; the predators within d_danger startle the agent
      for (auto* a : {&sc.lx, &sc.ly, &sc.lz, &sc.dx, &sc.dy, &sc.dz, &sc.dr}) a->clear();
      for (std::size_t j = 0; j < p_.stimuli.size(); ++j) {
        const Vec3& c = stimulusAt_[j];
        if (!p_.stimuli[j].predator) {
          const Vec3 u = fastswarm::unitOrZero(c - in.p);
          sc.lx.push_back(u.x());
          sc.ly.push_back(u.y());
          sc.lz.push_back(u.z());
        } else if ((c - in.p).norm() - static_cast<float>(p_.stimuli[j].radius) < p_.energy.dDanger) {
          sc.dx.push_back(c.x());
          sc.dy.push_back(c.y());
          sc.dz.push_back(c.z());
          sc.dr.push_back(static_cast<float>(p_.stimuli[j].radius));
        }
      }
      in.lureX = sc.lx.data(), in.lureY = sc.ly.data(), in.lureZ = sc.lz.data(), in.lures = sc.lx.size();
      in.dangerX = sc.dx.data(), in.dangerY = sc.dy.data(), in.dangerZ = sc.dz.data(), in.dangerR = sc.dr.data();
      in.dangers = sc.dx.size();
      const fastswarm::EnergyParams& ep = in.dangers > 0 ? danger_ : p_.energy;
      in.repX = sc.rx.data();
      in.repY = sc.ry.data();
      in.repZ = sc.rz.data();
      in.rep = sc.nRep;
      in.attX = sc.ax.data();
      in.attY = sc.ay.data();
      in.attZ = sc.az.data();
      in.att = sc.nAtt;
      std::size_t first = 0, last = 0;
      fastswarm::candidateRange(ref, static_cast<double>(in.v.norm()), p_.candidates, first, last);
      float bestE = 0.0f;
      std::size_t c = fastswarm::argminEnergyBounded(in, cand_, bounds_, first, last, ep, sc.lower, &bestE, lanes);
      const std::uint32_t id = s.id[order[k]];
      if (p_.successors) {
        // the sample that followed the agent's current one in its real track, when outside the window
        const std::int64_t cur = current_[id];
        const std::int64_t nxt = cur >= 0 ? ref.next[static_cast<std::size_t>(cur)] : -1;
        // (inside the window with margin 1 the argmin already decided: its E is not below the least)
        const bool outside = nxt >= 0 && (static_cast<std::size_t>(nxt) < first || static_cast<std::size_t>(nxt) >= last);
        if (nxt >= 0 && static_cast<std::int64_t>(c) != nxt && (outside || p_.successorMargin > 1.0f) &&
            fastswarm::energyTermsWith(avx, in, cand_, static_cast<std::size_t>(nxt), ep).total() <
                p_.successorMargin * bestE) {
          c = static_cast<std::size_t>(nxt);
        }
        if (nxt >= 0 && static_cast<std::int64_t>(c) == nxt) followed_.fetch_add(1, std::memory_order_relaxed);
        current_[id] = static_cast<std::int64_t>(c);
      }
      const Vec3 v(cand_.vx[c], cand_.vy[c], cand_.vz[c]);
      next_.id[k] = id;
      next_.vx[k] = v.x();
      next_.vy[k] = v.y();
      next_.vz[k] = v.z();
      next_.px[k] = in.p.x() + v.x() * dt;
      next_.py[k] = in.p.y() + v.y() * dt;
      next_.pz[k] = in.p.z() + v.z() * dt;
    });
    s.swapStorage(next_);
    // the next step cuts the runs to the ball if this step read more than 400 points per agent (the same choice
    // for any thread count; either way the same zones in the same order)
    std::size_t scanned = 0;
    for (Scratch& x : scratch_) scanned += std::exchange(x.scanned, 0);
    clipRuns_ = static_cast<double>(scanned) > 400.0 * static_cast<double>(n);
    stepsAgents_ += n;
  }

  // with successors: the fraction of agent steps that went on to the successor sample (an integer count, so
  // the same for any thread count)
  std::vector<std::string> statNames() const override {
    return p_.successors ? std::vector<std::string>{"successor_fraction"} : std::vector<std::string>{};
  }
  void takeFrameStats(std::vector<double>& values) override {
    values.clear();
    if (!p_.successors) return;
    const std::uint64_t f = followed_.exchange(0);
    values.push_back(stepsAgents_ > 0 ? static_cast<double>(f) / static_cast<double>(stepsAgents_) : 0.0);
    stepsAgents_ = 0;
  }

  // the keypoint tasks and (with successors) each agent's current sample are the state carried from step to step
  void saveState(StateOut& out) const override {
    std::vector<std::int32_t> flat;
    for (const KeypointTask& t : tasks_) flat.insert(flat.end(), {t.goal, t.dir});
    out.putVector(flat);
    out.putVector(current_);
    out.putVector(std::vector<std::uint64_t>{followed_.load(), stepsAgents_});
  }
  void loadState(StateIn& in, const World&) override {
    const auto flat = in.getVector<std::int32_t>();
    if (flat.size() % 2 != 0) throw std::runtime_error("fastswarm state: odd task data");
    tasks_.assign(flat.size() / 2, {});
    for (std::size_t i = 0; i < tasks_.size(); ++i) tasks_[i] = {flat[2 * i], flat[2 * i + 1]};
    current_ = in.getVector<std::int64_t>();
    const auto counts = in.getVector<std::uint64_t>();
    if (counts.size() != 2) throw std::runtime_error("fastswarm state: bad statistics");
    followed_ = counts[0];
    stepsAgents_ = counts[1];
    for (const std::int64_t c : current_) {
      if (c < -1 || c >= static_cast<std::int64_t>(cand_.size())) throw std::runtime_error("fastswarm state: a sample outside the reference");
    }
  }

  Json facts() const override {
    const fastswarm::Reference& ref = *p_.reference;
    return {{"reference", p_.referencePath},
            {"reference_samples", ref.size()},
            {"reference_groups", ref.groups()},
            {"reference_dt", ref.dt}};
  }

 private:
  FastswarmParams p_;
  Candidates cand_;
  fastswarm::BoundFactors bounds_;
  fastswarm::EnergyParams danger_;  // the weights of a startled agent
  std::vector<Vec3> stimulusAt_;    // the stimuli's centres this step
  Grid3<float> boundary_;
  NoiseField noise_;
  UniformGrid grid_;
  SeenAgents seen_;  // the agents of the swarms this one sees, this step
  std::vector<float> vx_, vy_, vz_, nx_, ny_, nz_, cx_, cy_, cz_;  // by sorted position
  std::vector<KeypointTask> tasks_;                                // by agent id
  std::atomic<std::uint64_t> followed_{0};  // agent steps since the last frame that took their successor
  std::uint64_t stepsAgents_ = 0;           // agent steps since the last frame
  std::vector<std::int64_t> current_;  // by agent id: the sample it flies (successors only; -1: none yet)
  std::vector<Scratch> scratch_;
  bool clipRuns_ = false;  // the zones' runs cut to the ball (a dense swarm; set from the last step's reads)
  SwarmState next_;
};

}  // namespace

FastswarmParams readFastswarmParams(JsonReader& r, const ModelContext& context) {
  FastswarmParams p;
  p.referencePath = r.requireInputPath("reference");
  try {
    p.reference = std::make_shared<const fastswarm::Reference>(fastswarm::readReference(p.referencePath));
  } catch (const InputError& e) {
    r.fail("reference", e.what());
  }
  if (std::fabs(p.reference->dt - context.world.dt) > 1e-6 * p.reference->dt) {
    context.warnings.push_back(r.pathOf("reference") + ": the reference's samples are " +
                               std::to_string(p.reference->dt) + " s apart, the scenario's dt is " +
                               std::to_string(context.world.dt) + " s (eq. 10 compares accelerations over dt)");
  }
  fastswarm::EnergyParams& e = p.energy;
  const Range weight = Range::nonNegative().limited(0.0, 1e6);
  e.rho = static_cast<float>(r.number("rho", e.rho, Range::positive().limited(1e-6, 20.0)));
  e.w.rep = static_cast<float>(r.number("w_rep", e.w.rep, weight));
  e.w.oa = static_cast<float>(r.number("w_oa", e.w.oa, weight));
  e.w.cos = static_cast<float>(r.number("w_cos", e.w.cos, weight));
  e.w.dir = static_cast<float>(r.number("w_dir", e.w.dir, weight));
  e.w.acc = static_cast<float>(r.number("w_acc", e.w.acc, weight));
  e.w.n = static_cast<float>(r.number("w_n", e.w.n, weight));
  e.dRep = static_cast<float>(r.number("d_rep", e.dRep, Range::length()));
  e.dAtt1 = static_cast<float>(r.number("d_att1", e.dAtt1, Range::length()));
  p.dAtt2 = r.number("d_att2", p.dAtt2, Range::length());
  // compared as the model keeps them (d_att1 in float): equal values in the file are equal here too
  if (!(e.dAtt1 <= static_cast<float>(p.dAtt2))) r.fail("d_att2", "expected d_att1 <= d_att2");
  p.candidates = r.integer("candidates", p.candidates, 1, 100000000);
  p.successors = r.boolean("successors", p.successors);
  p.successorMargin = static_cast<float>(r.number("successor_margin", p.successorMargin, Range::closed(1.0, 1e6)));
  if (p.successorMargin != 1.0f && !p.successors) {
    r.fail("successor_margin", "applies to successors only (expected \"successors\": true, or no successor_margin)");
  }
  if (p.successors && p.reference->next.empty()) {
    r.fail("successors", p.referencePath + " has no successor table (format version 1): rebuild it with swarmsim reference build");
  }
  const Json* c = r.raw("center");
  if (c && c->is_string()) {
    if (c->get<std::string>() != "swarm") r.failExpected("center", "\"swarm\" or a point [x, y, z]", *c);
    r.resolve("center", "swarm");
  } else if (c) {
    p.center = r.vec3("center", Vec3d::Zero(), Range::coordinate());
  } else {
    r.resolve("center", "swarm");
  }
  if (r.has("control")) {
    JsonReader cr = r.object("control", true);
    KeypointCurve curve;
    const Json* pts = cr.raw("keypoints");
    if (!pts || !pts->is_array() || pts->size() < 2) {
      cr.failExpected("keypoints", "an array of at least 2 points [x, y, z]", pts ? *pts : Json());
    }
    for (std::size_t k = 0; k < pts->size(); ++k) {
      const Json& q = (*pts)[k];
      bool ok = q.is_array() && q.size() == 3;
      for (std::size_t a = 0; ok && a < 3; ++a) ok = q[a].is_number() && std::isfinite(q[a].get<double>()) && std::fabs(q[a].get<double>()) <= 1e9;
      if (!ok) cr.failExpected("keypoints[" + std::to_string(k) + "]", "a point [x, y, z] of numbers within 1e9", q);
      curve.points.emplace_back(q[0].get<double>(), q[1].get<double>(), q[2].get<double>());
    }
    curve.closed = cr.boolean("closed", curve.closed);
    curve.bidirectional = cr.boolean("bidirectional", curve.bidirectional);
    curve.radius = cr.number("radius", curve.radius, Range::length());
    cr.finish();
    p.control = curve;
  }
  for (JsonReader& st : r.objectArray("stimuli", false, 0)) {
    FastswarmStimulus x;
    const std::string type = st.choice("type", "", {"attractor", "predator"});
    if (type.empty()) st.failMissing("type", "\"attractor\" (attracted, eq. 12) or \"predator\" (startled)");
    x.predator = type == "predator";
    x.radius = st.number("radius", 0.0, Range::lengthOrZero());
    x.path = readPath(st, "a stimulus");
    st.finish();
    p.stimuli.push_back(x);
  }
  e.w.env = static_cast<float>(r.number("w_env", p.stimuli.empty() ? 0.0 : 1.0, weight));
  e.dDanger = static_cast<float>(r.number("d_danger", e.dDanger, Range::length()));
  // 0: Δt (the paper); docs/models/fastswarm.md#escaping says why a scenario may look further ahead
  e.dangerHorizon = static_cast<float>(r.number("danger_horizon", 0.0, Range::nonNegative().limited(0.0, 1e3)));
  if (r.has("in_danger")) {
    JsonReader dr = r.object("in_danger", true);
    const auto opt = [&](const char* key, std::optional<float>& v) {
      if (dr.has(key)) v = static_cast<float>(dr.number(key, 0.0, weight));
    };
    opt("w_rep", p.dangerRep);
    opt("w_oa", p.dangerOa);
    opt("w_cos", p.dangerCos);
    opt("w_dir", p.dangerDir);
    opt("w_acc", p.dangerAcc);
    opt("w_n", p.dangerN);
    dr.finish();
  }
  e.w.user = static_cast<float>(r.number("w_user", p.control ? 1.0 : 0.0, weight));
  if (e.w.user > 0.0f && !p.control) r.fail("w_user", "user control needs \"control\": {\"keypoints\": [...]}");
  {
    JsonReader nz = r.object("noise", false);
    p.noiseScale = nz.number("scale", p.noiseScale, Range::length());
    checkNoiseFrequency(nz, "scale", context.world.domain, 1.0, 1.0 / p.noiseScale);
    readSeeds(nz, "seeds", p.seeds);
    nz.finish();
  }
  return p;
}

std::shared_ptr<const ModelConfig> parseFastswarm(JsonReader& params, const ModelContext& context) {
  return std::make_shared<FastswarmConfig>(readFastswarmParams(params, context));
}

std::unique_ptr<Model> makeFastswarm(const FastswarmParams& params, const World& world) {
  return std::make_unique<Fastswarm>(params, world);
}

}  // namespace swarmsim
