#include "models/bswarm/interaction.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>

#include "core/lanes.hpp"
#include "core/parallel.hpp"

namespace swarmsim {
namespace {

using Block = InteractionForces::Block;
using Node = InteractionForces::Node;
using Expansion = InteractionForces::Expansion;
using CutModel = InteractionForces::CutModel;
using Work = InteractionForces::Work;

// The scan works on the 8 logical lanes of core/lanes.hpp (AVX, or two SSE registers): the same bits either way.
constexpr std::size_t kBlock = 2 * kLanes;     // entries per step of the scan: blocks are padded to it
constexpr float kTiny = 1e-30f;                // floor of squared distances: products of two stay normal
constexpr float kFar = 1e18f;                  // padding position: beyond every radius, its square still finite
constexpr std::size_t kSerialWorkBelow = 256;  // fewer queries run on the calling thread

// The tree (binary, over Morton codes) and its walk. Tuned on 200,000 locusts (docs/models/bswarm.md).
constexpr std::uint32_t kLevels = 10;        // bits per axis of the Morton code
constexpr std::uint32_t kLeafSize = 16;      // a node with more agents is split (unless its agents coincide)
constexpr std::uint32_t kBatchSize = 64;     // agents sharing one list of sources
constexpr std::uint32_t kWholeCell = 32;     // near cells this small are scanned whole rather than opened
constexpr std::uint32_t kExpandMin = 256;    // expansions for targets of this many agents (else pseudo-agents)
constexpr float kCutTheta = 0.5f;            // cells that straddle a zone border: theta_cut = kCutTheta theta
constexpr float kUnevenCut2 = 1.0f / 16.0f;  // ... and (theta_cut / 4)^2 for cells not evenly filled
// zone borders with a little slack: a cell lies in one zone only if it does so with a margin
constexpr float kLo = 1.0f - 1e-5f, kHi = 1.0f + 1e-5f;

// the zone borders (squared) and which terms can be nonzero
struct Zones {
  float rep2, ali2, att2;
  float reach2;  // squared outer radius of the zones with lambda != 0: nothing beyond it matters
  bool ali;      // the alignment term can be nonzero
  bool any;      // some term can be nonzero
  double lRep, lAli, lAtt;
  double rRep, rAli, rAtt;
};

Zones makeZones(const ZoneParams& p) {
  Zones z;
  z.rep2 = p.rRep * p.rRep;
  z.ali2 = p.rAli * p.rAli;
  z.att2 = p.rAtt * p.rAtt;
  z.lRep = p.lambdaRep;
  z.lAli = p.lambdaAli;
  z.lAtt = p.lambdaAtt;
  z.rRep = p.rRep;
  z.rAli = p.rAli;
  z.rAtt = p.rAtt;
  z.ali = p.lambdaAli != 0.0f && p.rAli > p.rRep;
  // zone att includes its outer border, so it is never empty (rAli = rAtt: the sphere at rAtt)
  z.reach2 = p.lambdaAtt != 0.0f ? z.att2 : z.ali ? z.ali2 : p.lambdaRep != 0.0f ? z.rep2 : 0.0f;
  z.any = z.reach2 > 0.0f;
  return z;
}

// squared distance to zone: 0 rep, 1 ali, 2 att, 3 beyond
inline int zoneOf(const Zones& z, float d2) { return d2 < z.rep2 ? 0 : d2 < z.ali2 ? 1 : d2 <= z.att2 ? 2 : 3; }

// runs serially when small: waking the team costs more than it saves
template <typename F>
void forEachQuery(std::size_t n, std::size_t chunk, F&& body) {
  if (n < kSerialWorkBelow) {
    for (std::size_t i = 0; i < n; ++i) body(i);
  } else {
    parallelForDynamic(n, chunk, body);
  }
}


double now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

void reserve(Block& b, std::size_t n) {
  if (b.x.size() >= n) return;
  const std::size_t cap = n + n / 2 + 16;  // grows rarely; reused across steps
  for (auto* v : {&b.x, &b.y, &b.z, &b.vx, &b.vy, &b.vz, &b.w}) v->resize(cap);
}

inline void push(Block& b, float x, float y, float z, float vx, float vy, float vz, float w) {
  reserve(b, b.size + 1);
  const std::size_t i = b.size++;
  b.x[i] = x;
  b.y[i] = y;
  b.z[i] = z;
  b.vx[i] = vx;
  b.vy[i] = vy;
  b.vz[i] = vz;
  b.w[i] = w;
}

// appends entries [first, last) of the given arrays (weights not set: for unweighted scans)
void append(Block& b, const float* x, const float* y, const float* z, const float* vx, const float* vy, const float* vz,
            std::size_t first, std::size_t last, bool velocities) {
  reserve(b, b.size + (last - first) + kBlock);
  const std::size_t at = b.size;
  std::copy(x + first, x + last, b.x.data() + at);
  std::copy(y + first, y + last, b.y.data() + at);
  std::copy(z + first, z + last, b.z.data() + at);
  if (velocities) {
    std::copy(vx + first, vx + last, b.vx.data() + at);
    std::copy(vy + first, vy + last, b.vy.data() + at);
    std::copy(vz + first, vz + last, b.vz.data() + at);
  }
  b.size += last - first;
}

// fill up to whole scan blocks with entries that lie in no zone and weigh nothing
void pad(Block& b) {
  while (b.size % kBlock != 0) push(b, kFar, kFar, kFar, 0.0f, 0.0f, 0.0f, 0.0f);
}

// one agent's sums over its neighbours: per zone, the sum of the unit vectors (weighted) and of the weights
struct Sums {
  double rep[3] = {0, 0, 0}, ali[3] = {0, 0, 0}, att[3] = {0, 0, 0};
  double nRep = 0, nAli = 0, nAtt = 0;
};

template <typename L>
struct Acc {
  typename L::V rx, ry, rz, lx, ly, lz, ax, ay, az, nr, nl, na;  // n*: weighted counts
  int cRep = 0, cAli = 0, cAtt = 0;                              // unweighted counts (exact integers)
};

// Adds query q's (position, velocity) sums over block b to the lanes: each entry j is classified by its
// distance, rep: d2 < rep2, ali: rep2 <= d2 < ali2, att: ali2 <= d2 <= att2, and adds w_j * unit(p_j - q)
// (rep, att) or w_j * unit(v_j - v_q) (ali) and w_j to its zone. Branch-free; entry j goes to lane j % kLanes.
// kWeighted: w is read from the block (else 1); kAli: the alignment zone is summed.
template <typename L, bool kWeighted, bool kAli>
inline void accumulate(Acc<L>& s, const Block& b, const float q[6], const Zones& z) {
  using V = typename L::V;
  const std::size_t n = b.size;  // a multiple of kBlock
  alignas(32) float inv[kBlock], invu[kBlock];
  for (std::size_t j = 0; j < n; j += kBlock) {
    // reciprocal distances first, one division for two vectors: 1/r0 = r1 / (r0 r1). The differences are
    // recomputed below rather than kept: fewer live registers.
    {
      const V qx = L::set1(q[0]), qy = L::set1(q[1]), qz = L::set1(q[2]), tiny = L::set1(kTiny);
      V r[2], ru[2];
#pragma GCC unroll 2
      for (std::size_t h = 0; h < 2; ++h) {
        const std::size_t at = j + kLanes * h;
        const V dx = L::sub(L::load(b.x.data() + at), qx);
        const V dy = L::sub(L::load(b.y.data() + at), qy);
        const V dz = L::sub(L::load(b.z.data() + at), qz);
        // d2 = 0 (the agent itself, or a coincident one) gives a zero vector, never 0 * inf
        r[h] = L::sqrt(L::max(L::add(L::add(L::mul(dx, dx), L::mul(dy, dy)), L::mul(dz, dz)), tiny));
        if (kAli) {
          const V ux = L::sub(L::load(b.vx.data() + at), L::set1(q[3]));
          const V uy = L::sub(L::load(b.vy.data() + at), L::set1(q[4]));
          const V uz = L::sub(L::load(b.vz.data() + at), L::set1(q[5]));
          ru[h] = L::sqrt(L::max(L::add(L::add(L::mul(ux, ux), L::mul(uy, uy)), L::mul(uz, uz)), tiny));
        }
      }
      const V p = L::div(L::set1(1.0f), L::mul(r[0], r[1]));
      L::store(inv, L::mul(r[1], p));
      L::store(inv + kLanes, L::mul(r[0], p));
      if (kAli) {
        const V pu = L::div(L::set1(1.0f), L::mul(ru[0], ru[1]));
        L::store(invu, L::mul(ru[1], pu));
        L::store(invu + kLanes, L::mul(ru[0], pu));
      }
    }
#pragma GCC unroll 2
    for (std::size_t h = 0; h < 2; ++h) {
      const std::size_t at = j + kLanes * h;
      const V dx = L::sub(L::load(b.x.data() + at), L::set1(q[0]));
      const V dy = L::sub(L::load(b.y.data() + at), L::set1(q[1]));
      const V dz = L::sub(L::load(b.z.data() + at), L::set1(q[2]));
      const V d2 = L::add(L::add(L::mul(dx, dx), L::mul(dy, dy)), L::mul(dz, dz));
      const V inRep = L::lt(d2, L::set1(z.rep2));
      const V inNear = L::lt(d2, L::set1(z.ali2));  // rep or ali (ali keeps its agents out of att even unweighted)
      const V inAtt = L::andnot(inNear, L::le(d2, L::set1(z.att2)));
      const V wi = kWeighted ? L::mul(L::load(b.w.data() + at), L::load(inv + kLanes * h)) : L::load(inv + kLanes * h);
      const V wr = L::band(inRep, wi), wa = L::band(inAtt, wi);
      s.rx = L::add(s.rx, L::mul(dx, wr));
      s.ry = L::add(s.ry, L::mul(dy, wr));
      s.rz = L::add(s.rz, L::mul(dz, wr));
      s.ax = L::add(s.ax, L::mul(dx, wa));
      s.ay = L::add(s.ay, L::mul(dy, wa));
      s.az = L::add(s.az, L::mul(dz, wa));
      // counts of unit entries go to integers: fewer vector registers in the hot loop
      if (kWeighted) {
        const V w = L::load(b.w.data() + at);
        s.nr = L::add(s.nr, L::band(inRep, w));
        s.na = L::add(s.na, L::band(inAtt, w));
      } else {
        s.cRep += L::count(inRep);
        s.cAtt += L::count(inAtt);
      }
      if (kAli) {
        const V inAli = L::andnot(inRep, inNear);
        const V ux = L::sub(L::load(b.vx.data() + at), L::set1(q[3]));
        const V uy = L::sub(L::load(b.vy.data() + at), L::set1(q[4]));
        const V uz = L::sub(L::load(b.vz.data() + at), L::set1(q[5]));
        const V iu = L::load(invu + kLanes * h);
        const V wl = L::band(inAli, kWeighted ? L::mul(L::load(b.w.data() + at), iu) : iu);
        s.lx = L::add(s.lx, L::mul(ux, wl));
        s.ly = L::add(s.ly, L::mul(uy, wl));
        s.lz = L::add(s.lz, L::mul(uz, wl));
        if (kWeighted) {
          s.nl = L::add(s.nl, L::band(inAli, L::load(b.w.data() + at)));
        } else {
          s.cAli += L::count(inAli);
        }
      }
    }
  }
}

// the sums of q over agents (unweighted) and, if given, pseudo-agents (weighted); out: per sum (rep xyz, ali
// xyz, att xyz, nRep, nAli, nAtt) 4 partial sums (lane i + lane i+4), counts: the unweighted counts
template <typename L, bool kAli>
inline void scanLanes(const Block& agents, const Block* pseudo, const float q[6], const Zones& z, float out[12][4],
                      int counts[3]) {
  Acc<L> s;
  s.rx = s.ry = s.rz = s.lx = s.ly = s.lz = s.ax = s.ay = s.az = s.nr = s.nl = s.na = L::set1(0.0f);
  accumulate<L, false, kAli>(s, agents, q, z);
  if (pseudo) accumulate<L, true, kAli>(s, *pseudo, q, z);
  const typename L::V acc[12] = {s.rx, s.ry, s.rz, s.lx, s.ly, s.lz, s.ax, s.ay, s.az, s.nr, s.nl, s.na};
  for (int a = 0; a < 12; ++a) L::fold4(acc[a], out[a]);
  counts[0] = s.cRep;
  counts[1] = s.cAli;
  counts[2] = s.cAtt;
}

#if SWARMSIM_X86_LANES
// entry points, one per instruction set (flatten: the lane operations inline into them)
template <bool kAli>
__attribute__((flatten)) void scanSse(const Block& agents, const Block* pseudo, const float q[6], const Zones& z,
                                      float out[12][4], int counts[3]) {
  scanLanes<SseLanes, kAli>(agents, pseudo, q, z, out, counts);
}
template <bool kAli>
SWARMSIM_AVX __attribute__((flatten)) void scanAvx(const Block& agents, const Block* pseudo, const float q[6],
                                                   const Zones& z, float out[12][4], int counts[3]) {
  scanLanes<AvxLanes, kAli>(agents, pseudo, q, z, out, counts);
}
#endif

// adds the scan of `agents` and `pseudo` (may be null; both padded) to s; the lanes are added in a fixed order
void scan(const Block& agents, const Block* pseudo, const float q[6], const Zones& z, bool avx, Sums& s) {
  alignas(16) float lane[12][4];
  int counts[3];
#if SWARMSIM_X86_LANES
  if (avx) {
    z.ali ? scanAvx<true>(agents, pseudo, q, z, lane, counts) : scanAvx<false>(agents, pseudo, q, z, lane, counts);
  } else {
    z.ali ? scanSse<true>(agents, pseudo, q, z, lane, counts) : scanSse<false>(agents, pseudo, q, z, lane, counts);
  }
#else
  (void)avx;
  z.ali ? scanLanes<ScalarLanes, true>(agents, pseudo, q, z, lane, counts)
        : scanLanes<ScalarLanes, false>(agents, pseudo, q, z, lane, counts);
#endif
  float t[12];
  for (int a = 0; a < 12; ++a) t[a] = (lane[a][0] + lane[a][1]) + (lane[a][2] + lane[a][3]);
  for (int a = 0; a < 3; ++a) {
    s.rep[a] += t[a];
    s.ali[a] += t[3 + a];
    s.att[a] += t[6 + a];
  }
  s.nRep += static_cast<double>(t[9]) + counts[0];
  s.nAli += static_cast<double>(t[10]) + counts[1];
  s.nAtt += static_cast<double>(t[11]) + counts[2];
}

// F_int from the zone sums; the agent itself was counted in zone rep (at distance 0, a zero vector)
inline void assemble(const Sums& s, const Zones& z, float* fx, float* fy, float* fz) {
  // counts can be fractional (addCut): a zone is empty below a tiny count
  constexpr double kNone = 1e-9;
  const double nRep = s.nRep - 1.0;
  // rep: away from the neighbours (the sums point toward them)
  const double cRep = nRep > kNone ? -z.lRep / nRep : 0.0;
  const double cAli = z.ali && s.nAli > kNone ? z.lAli / s.nAli : 0.0;
  const double cAtt = s.nAtt > kNone ? z.lAtt / s.nAtt : 0.0;
  *fx = static_cast<float>(cRep * s.rep[0] + cAli * s.ali[0] + cAtt * s.att[0]);
  *fy = static_cast<float>(cRep * s.rep[1] + cAli * s.ali[1] + cAtt * s.att[1]);
  *fz = static_cast<float>(cRep * s.rep[2] + cAli * s.ali[2] + cAtt * s.att[2]);
}

// every sorted point in one padded block
void fillAll(const UniformGrid& grid, const float* vx, const float* vy, const float* vz, Block& b) {
  b.size = 0;
  append(b, grid.sortedX().data(), grid.sortedY().data(), grid.sortedZ().data(), vx, vy, vz, 0, grid.size(), true);
  pad(b);
}

// Morton code: the bits of x, y, z (kLevels each) interleaved, x lowest
inline std::uint32_t spread3(std::uint32_t v) {
  v &= 0x3ffu;
  v = (v | (v << 16)) & 0x030000ffu;
  v = (v | (v << 8)) & 0x0300f00fu;
  v = (v | (v << 4)) & 0x030c30c3u;
  v = (v | (v << 2)) & 0x09249249u;
  return v;
}

// squared smallest and largest distances between points of two boxes
inline void boxDistances(const float alo[3], const float ahi[3], const float blo[3], const float bhi[3], float& dmin2,
                         float& dmax2) {
  dmin2 = dmax2 = 0.0f;
  for (int a = 0; a < 3; ++a) {
    const float gap = std::max(std::max(blo[a] - ahi[a], alo[a] - bhi[a]), 0.0f);
    const float span = std::max(bhi[a] - alo[a], ahi[a] - blo[a]);
    dmin2 += gap * gap;
    dmax2 += span * span;
  }
}

inline void clearExpansion(Expansion& e, const Node& t) {
  std::memset(&e, 0, sizeof e);
  for (int a = 0; a < 3; ++a) {
    e.c[a] = t.c[a];
    e.v[a] = t.v[a];
  }
}

// the parent's expansion, moved to the centre of child t
inline void shiftExpansion(const Expansion& parent, const Node& t, Expansion& e) {
  e = parent;
  for (int k = 0; k < 3; ++k) {
    const double* centre = k == 1 ? parent.v : parent.c;  // ali lives in velocity space
    const float* to = k == 1 ? t.v : t.c;
    const double d[3] = {to[0] - centre[0], to[1] - centre[1], to[2] - centre[2]};
    for (int a = 0; a < 3; ++a) {
      e.s[k][a] += e.g[k][3 * a] * d[0] + e.g[k][3 * a + 1] * d[1] + e.g[k][3 * a + 2] * d[2];
    }
  }
  for (int a = 0; a < 3; ++a) {
    e.c[a] = t.c[a];
    e.v[a] = t.v[a];
  }
}

// cell c as `count` agents at its centroid (mean velocity for ali) in zone k, to first order about the
// expansion's centre x0: unit(p - x) = u - (I - u u^T) (x - x0) / d + O(|x - x0|^2 / d^2), u = unit(p - x0)
inline void addToExpansion(Expansion& e, const Node& c, int k) {
  const double count = static_cast<double>(c.end - c.begin);
  const float* p = k == 1 ? c.v : c.c;
  const double* x0 = k == 1 ? e.v : e.c;
  const double d[3] = {p[0] - x0[0], p[1] - x0[1], p[2] - x0[2]};
  const double d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
  e.n[k] += count;
  if (!(d2 > 0.0)) return;
  const double inv = 1.0 / std::sqrt(d2), u[3] = {d[0] * inv, d[1] * inv, d[2] * inv}, w = count * inv;
  for (int a = 0; a < 3; ++a) {
    e.s[k][a] += count * u[a];
    for (int b = 0; b < 3; ++b) e.g[k][3 * a + b] -= w * ((a == b ? 1.0 : 0.0) - u[a] * u[b]);
  }
}

inline void addExpansion(const Expansion& e, const float q[6], Sums& s) {
  double* sums[3] = {s.rep, s.ali, s.att};
  for (int k = 0; k < 3; ++k) {
    const double* x0 = k == 1 ? e.v : e.c;
    const float* x = k == 1 ? q + 3 : q;
    const double d[3] = {x[0] - x0[0], x[1] - x0[1], x[2] - x0[2]};
    for (int a = 0; a < 3; ++a) {
      sums[k][a] += e.s[k][a] + e.g[k][3 * a] * d[0] + e.g[k][3 * a + 1] * d[1] + e.g[k][3 * a + 2] * d[2];
    }
  }
  s.nRep += e.n[0];
  s.nAli += e.n[1];
  s.nAtt += e.n[2];
}

// P(a + b + c <= t) for independent uniforms on [0, wa], [0, wb], [0, wc] (all > 0)
inline double uniformSumCdf(double t, double wa, double wb, double wc) {
  if (t <= 0.0) return 0.0;
  if (t >= wa + wb + wc) return 1.0;
  const auto cube = [](double x) { return x > 0.0 ? x * x * x : 0.0; };
  const double v = cube(t) - cube(t - wa) - cube(t - wb) - cube(t - wc) + cube(t - wa - wb) + cube(t - wa - wc) +
                   cube(t - wb - wc) - cube(t - wa - wb - wc);
  return std::clamp(v / (6.0 * wa * wb * wc), 0.0, 1.0);
}

// A cell that straddles zone borders: its agents are split between the zones by the fraction of them inside
// each border sphere. Their positions along u (toward the centroid) are modelled as the projection of the
// cell's box filled uniformly (a sum of three uniforms), rescaled to the cell's own variance u.Cov.u and
// centred on the centroid: exact for a uniformly filled box, close for a clump. The sphere of radius R is
// replaced by the plane u.(x - q) = R - rho^2 / (2R), rho^2 = tr(Cov) - u.Cov.u the agents' mean squared
// distance from the line q + s u. The model's shape depends on u only, and u hardly changes across a batch
// (the cell is far from it): it is set up once per batch (CutModel), with u toward the batch's centroid.
CutModel cutModel(const Node& c, const float from[3]) {
  CutModel m{};
  const double d[3] = {c.c[0] - from[0], c.c[1] - from[1], c.c[2] - from[2]};
  const double r = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  if (!(r > 0.0)) return m;
  const double u[3] = {d[0] / r, d[1] / r, d[2] / r};
  double cv[6];
  for (int a = 0; a < 6; ++a) cv[a] = c.cov[a];
  const double var = std::max(u[0] * u[0] * cv[0] + u[1] * u[1] * cv[3] + u[2] * u[2] * cv[5] +
                                  2.0 * (u[0] * u[1] * cv[1] + u[0] * u[2] * cv[2] + u[1] * u[2] * cv[4]),
                              0.0);
  double w[3], wsum = 0.0, boxVar = 0.0;
  for (int a = 0; a < 3; ++a) {
    w[a] = std::abs(u[a]) * (static_cast<double>(c.hi[a]) - c.lo[a]);
    wsum += w[a];
  }
  for (double& x : w) {
    x = std::max(x, 1e-3 * wsum + 1e-12);  // flat boxes: a small width keeps the formula finite
    boxVar += x * x / 12.0;
  }
  const double scale = std::sqrt(var / boxVar);
  for (int a = 0; a < 3; ++a) m.w[a] = static_cast<float>(w[a] * scale);
  m.lateral = static_cast<float>(std::max(cv[0] + cv[3] + cv[5] - var, 0.0));
  return m;
}

// cell c, split by the zone borders around agent q (model m)
inline void addCut(const Node& c, const CutModel& m, const float q[6], const Zones& z, Sums& s) {
  const double count = static_cast<double>(c.end - c.begin);
  const double d[3] = {c.c[0] - q[0], c.c[1] - q[1], c.c[2] - q[2]};
  const double r = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  if (!(r > 0.0)) return;
  const double u[3] = {d[0] / r, d[1] / r, d[2] / r};
  const double w[3] = {m.w[0], m.w[1], m.w[2]}, start = r - 0.5 * (w[0] + w[1] + w[2]);
  const bool spread = w[0] > 0.0;
  const auto inside = [&](double radius) {
    const double border = radius - m.lateral / (2.0 * radius);
    return spread ? uniformSumCdf(border - start, w[0], w[1], w[2]) : (border >= r ? 1.0 : 0.0);
  };
  const double fRep = inside(z.rRep), fAli = std::max(inside(z.rAli), fRep), fAtt = std::max(inside(z.rAtt), fAli);
  const double nRep = count * fRep, nAli = count * (fAli - fRep), nAtt = count * (fAtt - fAli);
  for (int a = 0; a < 3; ++a) {
    s.rep[a] += nRep * u[a];
    s.att[a] += nAtt * u[a];
  }
  s.nRep += nRep;
  s.nAtt += nAtt;
  if (z.ali && nAli > 0.0) {
    const double dv[3] = {c.v[0] - q[3], c.v[1] - q[4], c.v[2] - q[5]};
    const double rv = std::sqrt(dv[0] * dv[0] + dv[1] * dv[1] + dv[2] * dv[2]);
    if (rv > 0.0) {
      for (int a = 0; a < 3; ++a) s.ali[a] += nAli * dv[a] / rv;
    }
    s.nAli += nAli;
  }
}

// whether the agents of cell c fill its box about evenly, as addCut's model takes them to: the spread of
// their positions (trace of the covariance) within 30 % of that of a uniformly filled box
inline bool evenlyFilled(const Node& c) {
  const float ex = c.hi[0] - c.lo[0], ey = c.hi[1] - c.lo[1], ez = c.hi[2] - c.lo[2];
  const float box = (ex * ex + ey * ey + ez * ez) / 12.0f;
  const float spread = c.cov[0] + c.cov[3] + c.cov[5];
  return spread > 0.7f * box && spread < 1.3f * box;
}

// what a walk needs besides the tree
struct WalkParams {
  Zones z;
  float theta2;     // squared theta
  float cut2;       // squared theta for cells that straddle zone borders
  float reach2;     // squared reach, with slack
  bool matters[4];  // zones whose term can be nonzero
  bool avx;
  float *fx, *fy, *fz;
};

}  // namespace

void InteractionForces::compute(const UniformGrid& grid, const float* vx, const float* vy, const float* vz,
                                const ZoneParams& zones, float theta, float* fx, float* fy, float* fz) {
  const double t0 = now();
  scratch_.resize(static_cast<std::size_t>(threadCount()));
  const std::size_t n = grid.size();
  if (!makeZones(zones).any) {
    parallelFor(n, [&](std::size_t k) { fx[k] = fy[k] = fz[k] = 0.0f; });
  } else if (theta > 0.0f) {
    computeApprox(grid, vx, vy, vz, zones, theta, fx, fy, fz);
  } else {
    computeExact(grid, vx, vy, vz, zones, fx, fy, fz);
  }
  seconds_ = now() - t0;
}

void InteractionForces::computeExact(const UniformGrid& grid, const float* vx, const float* vy, const float* vz,
                                     const ZoneParams& zp, float* fx, float* fy, float* fz) {
  const std::size_t n = grid.size();
  const Zones z = makeZones(zp);
  const bool avx = useAvx();
  const float* sx = grid.sortedX().data();
  const float* sy = grid.sortedY().data();
  const float* sz = grid.sortedZ().data();
  // cells whose points can be within reach of cell c: the gap between the cells along each axis is
  // (|offset| - 1) cell edges; a little slack covers rounding of the binning and of d2
  const double reach2 = static_cast<double>(z.reach2) * (1.0 + 1e-5);
  const int dims[3] = {grid.dim(0), grid.dim(1), grid.dim(2)};
  double edge[3], gapAll2 = 0.0;
  int span[3];
  for (int a = 0; a < 3; ++a) {
    edge[a] = grid.cellSize(a);
    span[a] = static_cast<int>(std::floor(std::sqrt(reach2) / edge[a])) + 1;
    const double g = std::max(dims[a] - 2, 0) * edge[a];
    gapAll2 += g * g;
  }
  if (gapAll2 <= reach2) {
    // every cell reaches every other (e.g. rAtt spans the swarm): one shared block, no gathering
    fillAll(grid, vx, vy, vz, all_);
    forEachQuery(n, 16, [&](std::size_t k) {
      const float q[6] = {sx[k], sy[k], sz[k], vx[k], vy[k], vz[k]};
      Sums s;
      scan(all_, nullptr, q, z, avx, s);
      assemble(s, z, fx + k, fy + k, fz + k);
    });
    return;
  }
  // per cell: gather the cells within reach once (a ball of cells, row by row), then scan them for each of
  // the cell's points
  const auto cellWork = [&](std::size_t c) {
    const std::uint32_t a0 = grid.cellBegin(c), a1 = grid.cellEnd(c);
    if (a0 == a1) return;
    Block& b = scratch_[static_cast<std::size_t>(threadIndex())].list;
    b.size = 0;
    const std::size_t d0 = static_cast<std::size_t>(dims[0]), d1 = static_cast<std::size_t>(dims[1]);
    const int cx = static_cast<int>(c % d0), cy = static_cast<int>((c / d0) % d1), cz = static_cast<int>(c / (d0 * d1));
    for (int oz = -span[2]; oz <= span[2]; ++oz) {
      const int iz = cz + oz;
      if (iz < 0 || iz >= dims[2]) continue;
      const double gz = std::max(std::abs(oz) - 1, 0) * edge[2];
      for (int oy = -span[1]; oy <= span[1]; ++oy) {
        const int iy = cy + oy;
        if (iy < 0 || iy >= dims[1]) continue;
        const double gy = std::max(std::abs(oy) - 1, 0) * edge[1];
        const double rest = reach2 - gz * gz - gy * gy;
        if (rest < 0.0) continue;
        const int sxr = static_cast<int>(std::floor(std::sqrt(rest) / edge[0])) + 1;
        const std::size_t row = (static_cast<std::size_t>(iz) * d1 + static_cast<std::size_t>(iy)) * d0;
        const std::uint32_t b0 = grid.cellBegin(row + static_cast<std::size_t>(std::max(cx - sxr, 0)));
        const std::uint32_t b1 = grid.cellEnd(row + static_cast<std::size_t>(std::min(cx + sxr, dims[0] - 1)));
        append(b, sx, sy, sz, vx, vy, vz, b0, b1, z.ali);
      }
    }
    pad(b);
    for (std::uint32_t k = a0; k < a1; ++k) {
      const float q[6] = {sx[k], sy[k], sz[k], vx[k], vy[k], vz[k]};
      Sums s;
      scan(b, nullptr, q, z, avx, s);
      assemble(s, z, fx + k, fy + k, fz + k);
    }
  };
  const std::size_t cells = grid.cellCount();
  if (n < kSerialWorkBelow) {
    for (std::size_t c = 0; c < cells; ++c) cellWork(c);
  } else {
    const std::size_t chunk = std::clamp<std::size_t>(cells / (16 * scratch_.size()), 1, 64);
    parallelForDynamic(cells, chunk, cellWork);
  }
}

void InteractionForces::buildTree(const UniformGrid& grid, const float* vx, const float* vy, const float* vz) {
  const std::size_t n = grid.size();
  const float* sx = grid.sortedX().data();
  const float* sy = grid.sortedY().data();
  const float* sz = grid.sortedZ().data();
  // the bounding cube: per-chunk min/max, combined (exact, so the order does not matter)
  const std::size_t chunks = static_cast<std::size_t>(chunkCount(n));
  boxPart_.resize(6 * chunks);
  parallelChunks(n, [&](std::size_t first, std::size_t last, int t) {
    float* r = &boxPart_[6 * static_cast<std::size_t>(t)];
    for (int a = 0; a < 3; ++a) {
      r[a] = std::numeric_limits<float>::max();
      r[3 + a] = -std::numeric_limits<float>::max();
    }
    for (std::size_t k = first; k < last; ++k) {
      const float p[3] = {sx[k], sy[k], sz[k]};
      for (int a = 0; a < 3; ++a) {
        r[a] = std::min(r[a], p[a]);
        r[3 + a] = std::max(r[3 + a], p[a]);
      }
    }
  });
  float lo[3], hi[3];
  for (std::size_t a = 0; a < 3; ++a) {
    lo[a] = boxPart_[a];
    hi[a] = boxPart_[3 + a];
    for (std::size_t t = 1; t < chunks; ++t) {
      lo[a] = std::min(lo[a], boxPart_[6 * t + a]);
      hi[a] = std::max(hi[a], boxPart_[6 * t + 3 + a]);
    }
  }
  double side = 0.0;
  for (int a = 0; a < 3; ++a) side = std::max(side, static_cast<double>(hi[a]) - lo[a]);
  const double scale = side > 0.0 ? static_cast<double>(1u << kLevels) / (side * (1.0 + 1e-6)) : 0.0;
  for (auto* v : {&code_, &mk_, &tmpCode_, &tmpK_}) v->resize(n);
  const auto quant = [&](float v, int a) {
    const double t = (static_cast<double>(v) - lo[a]) * scale;
    return static_cast<std::uint32_t>(std::min(std::max(t, 0.0), static_cast<double>((1u << kLevels) - 1)));
  };
  parallelFor(n, [&](std::size_t k) {
    tmpCode_[k] = spread3(quant(sx[k], 0)) | (spread3(quant(sy[k], 1)) << 1) | (spread3(quant(sz[k], 2)) << 2);
    tmpK_[k] = static_cast<std::uint32_t>(k);
  });
  // LSD radix sort of (code, k), 10 bits a pass: stable, so ties stay in grid order. Each chunk counts and
  // places its own contiguous range; chunks are in index order, so the result equals the serial sort.
  constexpr std::size_t kDigits = 1u << 10;
  bucket_.resize(kDigits * chunks);
  for (int pass = 0; pass < 3; ++pass) {
    const int shift = 10 * pass;
    std::fill(bucket_.begin(), bucket_.end(), 0u);
    parallelChunks(n, [&](std::size_t first, std::size_t last, int t) {
      std::uint32_t* count = &bucket_[kDigits * static_cast<std::size_t>(t)];
      for (std::size_t i = first; i < last; ++i) ++count[(tmpCode_[i] >> shift) & (kDigits - 1)];
    });
    std::uint32_t sum = 0;
    for (std::size_t d = 0; d < kDigits; ++d) {
      for (std::size_t t = 0; t < chunks; ++t) {
        std::uint32_t& slot = bucket_[kDigits * t + d];
        const std::uint32_t c = slot;
        slot = sum;
        sum += c;
      }
    }
    parallelChunks(n, [&](std::size_t first, std::size_t last, int t) {
      std::uint32_t* next = &bucket_[kDigits * static_cast<std::size_t>(t)];
      for (std::size_t i = first; i < last; ++i) {
        const std::uint32_t slot = next[(tmpCode_[i] >> shift) & (kDigits - 1)]++;
        code_[slot] = tmpCode_[i];
        mk_[slot] = tmpK_[i];
      }
    });
    if (pass < 2) {
      code_.swap(tmpCode_);
      mk_.swap(tmpK_);
    }
  }
  for (auto* v : {&mx_, &my_, &mz_, &mvx_, &mvy_, &mvz_}) v->resize(n);
  parallelFor(n, [&](std::size_t m) {
    const std::uint32_t k = mk_[m];
    mx_[m] = sx[k];
    my_[m] = sy[k];
    mz_[m] = sz[k];
    mvx_[m] = vx[k];
    mvy_[m] = vy[k];
    mvz_[m] = vz[k];
  });

  // Nodes level by level (breadth first, children consecutive). A node splits on the highest Morton bit in
  // which its agents differ (codes are sorted, so it is the highest bit of first ^ last): cells halve along
  // x, y, z in turn, halves without agents skipped. Each level is built in parallel, numbered in order.
  nodes_.resize(1);
  depth_.resize(1);
  parent_.resize(1);
  nodes_[0] = Node{};
  nodes_[0].end = static_cast<std::uint32_t>(n);
  depth_[0] = parent_[0] = 0;
  levelStart_.assign(1, 0);
  for (std::size_t ls = 0, le = 1; ls < le;) {
    split_.resize(le);
    parallelFor(le - ls, [&](std::size_t j) {
      const std::size_t i = ls + j;
      const std::uint32_t b0 = nodes_[i].begin, e0 = nodes_[i].end;
      const std::uint32_t diff = code_[b0] ^ code_[e0 - 1];
      split_[i] = 0;  // a leaf
      if (e0 - b0 <= kLeafSize || diff == 0) return;
      std::uint32_t bit = 31;
      while (!(diff >> bit)) --bit;
      split_[i] = static_cast<std::uint32_t>(std::partition_point(code_.begin() + b0, code_.begin() + e0,
                                                                  [&](std::uint32_t c) { return !((c >> bit) & 1u); }) -
                                             code_.begin());
    });
    std::size_t next = le;
    for (std::size_t i = ls; i < le; ++i) {
      nodes_[i].firstChild = split_[i] ? static_cast<std::uint32_t>(next) : 0;
      nodes_[i].childCount = split_[i] ? 2 : 0;
      next += split_[i] ? 2 : 0;
    }
    nodes_.resize(next);
    depth_.resize(next);
    parent_.resize(next);
    parallelFor(le - ls, [&](std::size_t j) {
      const std::size_t i = ls + j;
      if (!split_[i]) return;
      const std::uint32_t c = nodes_[i].firstChild;
      const std::uint32_t bounds[3] = {nodes_[i].begin, split_[i], nodes_[i].end};
      for (std::uint32_t h = 0; h < 2; ++h) {
        nodes_[c + h] = Node{};
        nodes_[c + h].begin = bounds[h];
        nodes_[c + h].end = bounds[h + 1];
        depth_[c + h] = depth_[i] + 1;
        parent_[c + h] = static_cast<std::uint32_t>(i);
      }
    });
    ls = le;
    le = next;
    levelStart_.push_back(static_cast<std::uint32_t>(ls));
  }
  // aggregates, deepest level first, each level in parallel (sums in double, in a fixed order)
  constexpr std::size_t kSums = 12;  // x y z, vx vy vz, xx xy xz yy yz zz
  sums_.resize(kSums * nodes_.size());
  for (std::size_t l = levelStart_.size() - 1; l-- > 0;) {
    const std::size_t ls = levelStart_[l], le = levelStart_[l + 1];
    parallelFor(le - ls, [&](std::size_t j) {
      const std::size_t i = ls + j;
      Node& nd = nodes_[i];
      double* s = &sums_[kSums * i];
      std::fill(s, s + kSums, 0.0);
      for (int a = 0; a < 3; ++a) {
        nd.lo[a] = nd.vlo[a] = std::numeric_limits<float>::max();
        nd.hi[a] = nd.vhi[a] = -std::numeric_limits<float>::max();
      }
      if (nd.childCount == 0) {
        for (std::uint32_t m = nd.begin; m < nd.end; ++m) {
          const float p[6] = {mx_[m], my_[m], mz_[m], mvx_[m], mvy_[m], mvz_[m]};
          for (int a = 0; a < 3; ++a) {
            nd.lo[a] = std::min(nd.lo[a], p[a]);
            nd.hi[a] = std::max(nd.hi[a], p[a]);
            nd.vlo[a] = std::min(nd.vlo[a], p[3 + a]);
            nd.vhi[a] = std::max(nd.vhi[a], p[3 + a]);
          }
          for (int a = 0; a < 6; ++a) s[a] += p[a];
          const double x = p[0], y = p[1], zz = p[2];
          s[6] += x * x;
          s[7] += x * y;
          s[8] += x * zz;
          s[9] += y * y;
          s[10] += y * zz;
          s[11] += zz * zz;
        }
      } else {
        for (std::uint32_t c = nd.firstChild; c < nd.firstChild + nd.childCount; ++c) {
          const Node& ch = nodes_[c];
          for (int a = 0; a < 3; ++a) {
            nd.lo[a] = std::min(nd.lo[a], ch.lo[a]);
            nd.hi[a] = std::max(nd.hi[a], ch.hi[a]);
            nd.vlo[a] = std::min(nd.vlo[a], ch.vlo[a]);
            nd.vhi[a] = std::max(nd.vhi[a], ch.vhi[a]);
          }
          for (std::size_t a = 0; a < kSums; ++a) s[a] += sums_[kSums * c + a];
        }
      }
      const double inv = 1.0 / static_cast<double>(nd.end - nd.begin);
      nd.diag2 = nd.vdiag2 = 0.0f;
      for (int a = 0; a < 3; ++a) {
        nd.c[a] = static_cast<float>(s[a] * inv);
        nd.v[a] = static_cast<float>(s[3 + a] * inv);
        nd.diag2 += (nd.hi[a] - nd.lo[a]) * (nd.hi[a] - nd.lo[a]);
        nd.vdiag2 += (nd.vhi[a] - nd.vlo[a]) * (nd.vhi[a] - nd.vlo[a]);
      }
      const double m[3] = {s[0] * inv, s[1] * inv, s[2] * inv};
      const int pairs[6][2] = {{0, 0}, {0, 1}, {0, 2}, {1, 1}, {1, 2}, {2, 2}};
      for (int a = 0; a < 6; ++a) {
        const int u = pairs[a][0], v = pairs[a][1];
        const double cov = s[6 + a] * inv - m[u] * m[v];
        nd.cov[a] = static_cast<float>(u == v ? std::max(cov, 0.0) : cov);
      }
    });
  }
  // tasks: the largest subtrees of at most taskSize agents. Their size depends on n only, never on the
  // number of threads: a task's walk starts at the root, so the partition shapes the arithmetic.
  const std::uint32_t taskSize = static_cast<std::uint32_t>(std::clamp<std::size_t>(n / 128, 64, 2048));
  tasks_.clear();
  for (std::size_t i = 0; i < nodes_.size(); ++i) {
    const Node& nd = nodes_[i];
    const bool small = nd.childCount == 0 || nd.end - nd.begin <= taskSize;
    const Node& up = nodes_[parent_[i]];
    if (small && (i == 0 || up.end - up.begin > taskSize)) tasks_.push_back(static_cast<std::uint32_t>(i));
  }
}

// The walk of target node t, a dual-tree walk (targets and sources are both tree cells). The sources in
// cand[candBegin, candEnd) are those t's parent left undecided; for each source c:
//  - no agent of c within reach of an agent of t, or only zones without weight: nothing;
//  - c's diameter below theta times the distance between their boxes (in velocity space too for zone ali) and
//    every pair in one zone: c is a pseudo-agent (count, centroid, mean velocity) for every agent of t; if t
//    is large and also small against that distance, c goes into t's expansion instead (first order about
//    t's centroid, shared by all of t's agents and passed on to t's children);
//  - c straddles a zone border but is below theta_cut times the distance: c is split between the zones per
//    agent (addCut);
//  - otherwise the larger of the two is opened: c's children are examined, or c is left to t's children.
// At a batch (at most kBatchSize agents, or a leaf) the remaining sources are scanned agent by agent.
template <typename Walk>
void InteractionForces::walk(std::uint32_t t, std::size_t candBegin, std::size_t candEnd, std::size_t level,
                             Scratch& sc, const Walk& w) const {
  const Node& T = nodes_[t];
  const std::uint32_t countT = T.end - T.begin;
  const bool batch = T.childCount == 0 || countT <= kBatchSize;
  // an expansion costs some 60 flops per source, a pseudo-agent one SIMD lane per agent of t
  const bool expand = countT >= kExpandMin;
  const Zones& z = w.z;
  Expansion& e = sc.exp[level];
  const std::size_t deferBegin = sc.cand.size(), cutMark = sc.cut.size(), farMark = sc.far.size;
  if (batch) sc.near.clear();
  for (std::size_t i = candBegin; i < candEnd; ++i) {
    sc.open.push_back(sc.cand[i]);
    while (!sc.open.empty()) {
      const std::uint32_t ci = sc.open.back();
      sc.open.pop_back();
      const Node& C = nodes_[ci];
      float dmin2, dmax2;
      boxDistances(T.lo, T.hi, C.lo, C.hi, dmin2, dmax2);
      if (dmin2 > w.reach2) continue;
      const int zlo = zoneOf(z, dmin2 * kLo), zhi = zoneOf(z, dmax2 * kHi);
      bool useful = false, ali = false;
      for (int k = zlo; k <= zhi; ++k) {
        useful = useful || w.matters[k];
        ali = ali || (k == 1 && z.ali);
      }
      if (!useful) continue;
      const std::uint32_t count = C.end - C.begin;
      const bool leafC = C.childCount == 0;
      const bool farC = C.diag2 < w.theta2 * dmin2;
      bool velC = true, velT = true;  // far enough in velocity space (only zone ali needs it)
      if (ali) {
        float v2min, v2max;
        boxDistances(T.vlo, T.vhi, C.vlo, C.vhi, v2min, v2max);
        velC = C.vdiag2 < w.theta2 * v2min;
        velT = T.vdiag2 < w.theta2 * v2min;
      }
      const auto open = [&]() {
        for (std::uint32_t c = C.firstChild + C.childCount; c-- > C.firstChild;) sc.open.push_back(c);
      };
      if (zlo == zhi && farC && velC && count > 1) {
        if (expand && T.diag2 < w.theta2 * dmin2 && velT) {
          addToExpansion(e, C, zlo);
        } else {
          push(sc.far, C.c[0], C.c[1], C.c[2], C.v[0], C.v[1], C.v[2], static_cast<float>(count));
        }
      } else if (zlo != zhi && !leafC && C.diag2 < w.cut2 * (evenlyFilled(C) ? 1.0f : kUnevenCut2) * dmin2 && velC) {
        sc.cut.push_back(ci);
      } else if (batch) {
        // small cells go in whole: a contiguous copy costs less than examining their children
        if (leafC || count <= kWholeCell) {
          sc.near.push_back(ci);
        } else {
          open();
        }
      } else if (!leafC && C.diag2 > T.diag2) {
        open();
      } else {
        sc.cand.push_back(ci);  // for t's children
      }
    }
  }
  if (batch) {
    evaluateBatch(T, e, sc, w);
  } else {
    const std::size_t deferEnd = sc.cand.size();
    for (std::uint32_t c = T.firstChild; c < T.firstChild + T.childCount; ++c) {
      shiftExpansion(e, nodes_[c], sc.exp[level + 1]);
      walk(c, deferBegin, deferEnd, level + 1, sc, w);
    }
  }
  sc.cand.resize(deferBegin);
  sc.cut.resize(cutMark);
  sc.far.size = farMark;
}

// The agents of batch t, leaf by leaf (a leaf: at most kLeafSize agents in a small box). The near cells of t
// (sc.near) are examined again for each leaf: a cell far enough from the leaf and in one zone becomes one
// pseudo-agent, the agents of the others are copied into one list (contiguous runs of the Morton order).
// Each agent of the leaf scans that list and the pseudo-agents (sc.far), then adds the expansion and the cut
// cells of t and its ancestors.
template <typename Walk>
void InteractionForces::evaluateBatch(const Node& T, const Expansion& e, Scratch& sc, const Walk& w) const {
  const Zones& z = w.z;
  std::sort(sc.near.begin(), sc.near.end(),
            [&](std::uint32_t a, std::uint32_t b) { return nodes_[a].begin < nodes_[b].begin; });
  // the leaves of t
  sc.leaves.clear();
  sc.open.assign(1, static_cast<std::uint32_t>(&T - nodes_.data()));
  while (!sc.open.empty()) {
    const std::uint32_t id = sc.open.back();
    sc.open.pop_back();
    const Node& nd = nodes_[id];
    if (nd.childCount == 0) {
      sc.leaves.push_back(id);
    } else {
      for (std::uint32_t c = nd.firstChild + nd.childCount; c-- > nd.firstChild;) sc.open.push_back(c);
    }
  }
  sc.cutModels.resize(sc.cut.size());
  for (std::size_t i = 0; i < sc.cut.size(); ++i) sc.cutModels[i] = cutModel(nodes_[sc.cut[i]], T.c);
  Block& list = sc.list;
  for (const std::uint32_t si : sc.leaves) {
    const Node& S = nodes_[si];
    const std::size_t farSize = sc.far.size;
    list.size = 0;
    std::uint32_t first = 0, last = 0;  // the pending run of agents
    const auto flush = [&]() {
      append(list, mx_.data(), my_.data(), mz_.data(), mvx_.data(), mvy_.data(), mvz_.data(), first, last, z.ali);
    };
    for (const std::uint32_t ci : sc.near) {
      const Node& C = nodes_[ci];
      float dmin2, dmax2;
      boxDistances(S.lo, S.hi, C.lo, C.hi, dmin2, dmax2);
      if (dmin2 > w.reach2) continue;
      const int zlo = zoneOf(z, dmin2 * kLo), zhi = zoneOf(z, dmax2 * kHi);
      bool pseudo = C.end - C.begin > 1 && zlo == zhi && C.diag2 < w.theta2 * dmin2;
      if (pseudo && zlo == 1 && z.ali) {
        float v2min, v2max;
        boxDistances(S.vlo, S.vhi, C.vlo, C.vhi, v2min, v2max);
        pseudo = C.vdiag2 < w.theta2 * v2min;
      }
      if (pseudo) {
        if (w.matters[zlo]) {
          push(sc.far, C.c[0], C.c[1], C.c[2], C.v[0], C.v[1], C.v[2], static_cast<float>(C.end - C.begin));
        }
      } else if (C.begin == last) {
        last = C.end;
      } else {
        flush();
        first = C.begin;
        last = C.end;
      }
    }
    flush();
    pad(list);
    pad(sc.far);
    const std::uint64_t agents = S.end - S.begin;
    sc.work += Work{agents, agents * list.size, agents * sc.far.size, agents * sc.cut.size()};
    for (std::uint32_t m = S.begin; m < S.end; ++m) {
      const float q[6] = {mx_[m], my_[m], mz_[m], mvx_[m], mvy_[m], mvz_[m]};
      Sums s;
      scan(list, &sc.far, q, z, w.avx, s);
      addExpansion(e, q, s);
      for (std::size_t i = 0; i < sc.cut.size(); ++i) addCut(nodes_[sc.cut[i]], sc.cutModels[i], q, z, s);
      const std::uint32_t k = mk_[m];
      assemble(s, z, w.fx + k, w.fy + k, w.fz + k);
    }
    sc.far.size = farSize;
  }
}

void InteractionForces::computeApprox(const UniformGrid& grid, const float* vx, const float* vy, const float* vz,
                                      const ZoneParams& zp, float theta, float* fx, float* fy, float* fz) {
  if (grid.size() == 0) return;
  buildTree(grid, vx, vy, vz);
  WalkParams w;
  w.z = makeZones(zp);
  w.theta2 = theta * theta;
  w.cut2 = kCutTheta * kCutTheta * w.theta2;
  w.reach2 = w.z.reach2 * kHi;
  w.matters[0] = w.z.lRep != 0.0;
  w.matters[1] = w.z.ali;
  w.matters[2] = w.z.lAtt != 0.0;
  w.matters[3] = false;
  w.avx = useAvx();
  w.fx = fx;
  w.fy = fy;
  w.fz = fz;
  for (Scratch& sc : scratch_) sc.work = Work();
  // tasks are heavy (hundreds of agents each): worth the team from two on
  parallelForDynamic(tasks_.size(), 1, [&](std::size_t ti) {
    Scratch& sc = scratch_[static_cast<std::size_t>(threadIndex())];
    sc.exp.resize(3 * kLevels + 2);  // one per level of the tree
    sc.cand.assign(1, 0);            // the root
    sc.cut.clear();
    sc.far.size = 0;
    const std::uint32_t t = tasks_[ti];
    clearExpansion(sc.exp[depth_[t]], nodes_[t]);
    walk(t, 0, 1, depth_[t], sc, w);
  });
  for (const Scratch& sc : scratch_) work_ += sc.work;
}

ForceError approximationError(const UniformGrid& grid, const float* vx, const float* vy, const float* vz,
                              const ZoneParams& zones, float theta, std::size_t stride) {
  const std::size_t n = grid.size();
  stride = std::max<std::size_t>(stride, 1);
  ForceError out;
  if (n == 0) return out;
  std::vector<float> ax(n), ay(n), az(n);
  InteractionForces forces;
  forces.compute(grid, vx, vy, vz, zones, theta, ax.data(), ay.data(), az.data());
  // the exact force of each sampled agent, by a scan over the whole swarm
  const Zones z = makeZones(zones);
  const bool avx = useAvx();
  Block all;
  fillAll(grid, vx, vy, vz, all);
  const std::size_t samples = (n + stride - 1) / stride;
  std::vector<double> err(samples, -1.0);
  const float* sx = grid.sortedX().data();
  const float* sy = grid.sortedY().data();
  const float* sz = grid.sortedZ().data();
  // "tiny": below 1e-6 of the largest possible force
  const double tiny = 1e-6 * (std::abs(zones.lambdaRep) + std::abs(zones.lambdaAli) + std::abs(zones.lambdaAtt));
  forEachQuery(samples, 4, [&](std::size_t i) {
    const std::size_t k = i * stride;
    const float q[6] = {sx[k], sy[k], sz[k], vx[k], vy[k], vz[k]};
    Sums s;
    scan(all, nullptr, q, z, avx, s);
    float e[3];
    assemble(s, z, e, e + 1, e + 2);
    const double ex = e[0], ey = e[1], ez = e[2];
    const double norm = std::sqrt(ex * ex + ey * ey + ez * ez);
    if (!(norm > tiny)) return;
    const double dx = ax[k] - ex, dy = ay[k] - ey, dz = az[k] - ez;
    err[i] = std::sqrt(dx * dx + dy * dy + dz * dz) / norm;
  });
  err.erase(std::remove(err.begin(), err.end(), -1.0), err.end());
  out.samples = err.size();
  if (err.empty()) return out;
  std::sort(err.begin(), err.end());
  // quantile with linear interpolation between order statistics
  const auto quantile = [&](double p) {
    const double pos = p * static_cast<double>(err.size() - 1);
    const std::size_t i0 = static_cast<std::size_t>(std::floor(pos));
    const std::size_t i1 = std::min(i0 + 1, err.size() - 1);
    return err[i0] + (err[i1] - err[i0]) * (pos - static_cast<double>(i0));
  };
  out.median = quantile(0.5);
  out.p95 = quantile(0.95);
  return out;
}

}  // namespace swarmsim
