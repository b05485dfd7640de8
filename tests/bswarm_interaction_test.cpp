// BSwarm interaction force F_int (lib/models/bswarm/interaction.hpp): hand-worked
// values, the exact mode against a double-precision brute force, convergence and
// error of the far-field approximation, degenerate swarms, determinism across
// thread counts and instruction sets.
//
//   zone rep: 0 <= x < rRep (g = -1), ali: rRep <= x < rAli (g = 0), att: rAli <= x <= rAtt (g = +1)
//   F_i = sum_k lambda_k / N_k * sum_{j in zone k} (g_k r^_ji + (1 - |g_k|) v^_ji)
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <random>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "core/parallel.hpp"
#include "models/bswarm/interaction.hpp"
#include "spatial/uniform_grid.hpp"

using swarmsim::ForceError;
using swarmsim::InteractionForces;
using swarmsim::UniformGrid;
using swarmsim::ZoneParams;

namespace {

// the default theta documented in docs/models/bswarm.md
constexpr float kDefaultTheta = 2.0f;

struct Agents {
  std::vector<float> x, y, z, vx, vy, vz;
  void add(float px, float py, float pz, float ux, float uy, float uz) {
    x.push_back(px);
    y.push_back(py);
    z.push_back(pz);
    vx.push_back(ux);
    vy.push_back(uy);
    vz.push_back(uz);
  }
  std::size_t size() const { return x.size(); }
};

// the grid over the agents and their velocities in the grid's sorted order
struct Sorted {
  UniformGrid grid;
  std::vector<float> vx, vy, vz;
  Sorted(const Agents& a, float cell) {
    grid.build(a.x.data(), a.y.data(), a.z.data(), a.size(), cell);
    grid.gather(a.vx, vx);
    grid.gather(a.vy, vy);
    grid.gather(a.vz, vz);
  }
};

struct Forces {
  std::vector<float> x, y, z;
};

// F_int by original agent index
Forces compute(InteractionForces& f, const Sorted& s, const ZoneParams& zones, float theta) {
  const std::size_t n = s.grid.size();
  std::vector<float> fx(n), fy(n), fz(n);
  f.compute(s.grid, s.vx.data(), s.vy.data(), s.vz.data(), zones, theta, fx.data(), fy.data(), fz.data());
  Forces out{std::vector<float>(n), std::vector<float>(n), std::vector<float>(n)};
  for (std::size_t k = 0; k < n; ++k) {
    const std::uint32_t i = s.grid.order()[k];
    out.x[i] = fx[k];
    out.y[i] = fy[k];
    out.z[i] = fz[k];
  }
  return out;
}

Forces compute(const Agents& a, const ZoneParams& zones, float theta, float cell) {
  InteractionForces f;
  return compute(f, Sorted(a, cell), zones, theta);
}

// eq. 4 term by term, in double
void bruteForce(const Agents& a, const ZoneParams& p, std::size_t i, double f[3]) {
  double sum[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
  double count[3] = {0, 0, 0};
  for (std::size_t j = 0; j < a.size(); ++j) {
    if (j == i) continue;
    const double d[3] = {static_cast<double>(a.x[j]) - a.x[i], static_cast<double>(a.y[j]) - a.y[i],
                         static_cast<double>(a.z[j]) - a.z[i]};
    const double u[3] = {static_cast<double>(a.vx[j]) - a.vx[i], static_cast<double>(a.vy[j]) - a.vy[i],
                         static_cast<double>(a.vz[j]) - a.vz[i]};
    const double x = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    const double un = std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    int k;
    if (x < p.rRep) {
      k = 0;
    } else if (x < p.rAli) {
      k = 1;
    } else if (x <= p.rAtt) {
      k = 2;
    } else {
      continue;
    }
    count[k] += 1.0;
    for (int c = 0; c < 3; ++c) {
      const double rhat = x > 0.0 ? d[c] / x : 0.0, vhat = un > 0.0 ? u[c] / un : 0.0;
      const double g = k - 1.0;  // -1, 0, +1
      sum[k][c] += g * rhat + (1.0 - std::abs(g)) * vhat;
    }
  }
  const double lambda[3] = {p.lambdaRep, p.lambdaAli, p.lambdaAtt};
  for (int c = 0; c < 3; ++c) {
    f[c] = 0.0;
    for (int k = 0; k < 3; ++k) f[c] += count[k] > 0.0 ? lambda[k] / count[k] * sum[k][c] : 0.0;
  }
}

// agents uniformly in a box, velocities uniformly in [-1, 1]^3
Agents randomBox(std::size_t n, float ex, float ey, float ez, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f), v(-1.0f, 1.0f);
  Agents a;
  for (std::size_t i = 0; i < n; ++i) {
    // drawn in a fixed order (function arguments have none)
    const float px = u(rng), py = u(rng), pz = u(rng), ux = v(rng), uy = v(rng), uz = v(rng);
    a.add(px * ex, py * ey, pz * ez, ux, uy, uz);
  }
  return a;
}

// agents uniformly in a ball (a midge swarm), velocities uniformly in [-1, 1]^3
Agents randomBall(std::size_t n, float radius, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  Agents a;
  while (a.size() < n) {
    const float px = u(rng), py = u(rng), pz = u(rng);
    if (px * px + py * py + pz * pz > 1.0f) continue;
    const float ux = u(rng), uy = u(rng), uz = u(rng);
    a.add(px * radius, py * radius, pz * radius, ux, uy, uz);
  }
  return a;
}

// Gaussian clumps (sd 0.3 m) scattered over 10 x 5 x 2 m: density contrasts and cells cut by zone borders
Agents randomClumps(std::size_t n, std::size_t clumps, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> g(0.0f, 0.3f);
  std::uniform_real_distribution<float> u(0.0f, 1.0f), v(-1.0f, 1.0f);
  std::vector<float> c;
  for (std::size_t k = 0; k < clumps; ++k) c.insert(c.end(), {10.0f * u(rng), 5.0f * u(rng), 2.0f * u(rng)});
  Agents a;
  for (std::size_t i = 0; i < n; ++i) {
    const float* m = &c[3 * (i % clumps)];
    const float px = g(rng), py = g(rng), pz = g(rng), ux = v(rng), uy = v(rng), uz = v(rng);
    a.add(m[0] + px, m[1] + py, m[2] + pz, ux, uy, uz);
  }
  return a;
}

ZoneParams locustZones() {
  ZoneParams z;
  z.rRep = 0.2f;
  z.rAli = 0.2f;
  z.rAtt = 9.4f;
  z.lambdaRep = 3.0f;
  z.lambdaAli = 0.0f;
  z.lambdaAtt = 8.0f;
  return z;
}

ZoneParams midgeZones() {
  ZoneParams z;
  z.rRep = 0.17f;
  z.rAli = 0.17f;
  z.rAtt = 5.29f;
  z.lambdaRep = 5.61f;
  z.lambdaAli = 0.0f;
  z.lambdaAtt = 14.29f;
  return z;
}

// three zones, all weighted (distinct weights, so each term shows)
ZoneParams mixedZones() {
  ZoneParams z;
  z.rRep = 0.2f;
  z.rAli = 0.5f;
  z.rAtt = 1.0f;
  z.lambdaRep = 1.0f;
  z.lambdaAli = 0.7f;
  z.lambdaAtt = 1.3f;
  return z;
}

ForceError errorOf(const Agents& a, const ZoneParams& zones, float theta, float cell, std::size_t stride) {
  const Sorted s(a, cell);
  return approximationError(s.grid, s.vx.data(), s.vy.data(), s.vz.data(), zones, theta, stride);
}

// hand-worked zones: rRep 1, rAli 2, rAtt 3; lambda 2 (rep), 3 (ali), 5 (att)
ZoneParams handZones() {
  ZoneParams z;
  z.rRep = 1.0f;
  z.rAli = 2.0f;
  z.rAtt = 3.0f;
  z.lambdaRep = 2.0f;
  z.lambdaAli = 3.0f;
  z.lambdaAtt = 5.0f;
  return z;
}

void checkForce(const Forces& f, std::size_t i, double x, double y, double z) {
  INFO("agent " << i << ": (" << f.x[i] << ", " << f.y[i] << ", " << f.z[i] << ")");
  CHECK(f.x[i] == Approx(x).margin(1e-6));
  CHECK(f.y[i] == Approx(y).margin(1e-6));
  CHECK(f.z[i] == Approx(z).margin(1e-6));
}

}  // namespace

// both modes, grid cells smaller and larger than rAtt
template <typename F>
void forEachMode(F&& check) {
  for (const float theta : {0.0f, kDefaultTheta}) {
    for (const float cell : {0.4f, 3.0f}) {
      INFO("theta " << theta << ", cell " << cell);
      check(theta, cell);
    }
  }
}

TEST_CASE("BSwarm F_int: one neighbour in each zone, worked by hand", "[bswarm-int]") {
  forEachMode([](float theta, float cell) {
    // repulsion, x = 0.5 < rRep: r^_10 = (1,0,0); F_0 = 2/1 * -(1,0,0) = (-2,0,0), F_1 = (+2,0,0)
    Agents rep;
    rep.add(0, 0, 0, 1, 0, 0);
    rep.add(0.5f, 0, 0, 0, 1, 0);
    const Forces fr = compute(rep, handZones(), theta, cell);
    checkForce(fr, 0, -2, 0, 0);
    checkForce(fr, 1, 2, 0, 0);
    // alignment, x = 1.5 in [1, 2): v_1 - v_0 = (0,2,0), v^ = (0,1,0); F_0 = 3/1 * (0,1,0), F_1 = (0,-3,0)
    Agents ali;
    ali.add(0, 0, 0, 1, 0, 0);
    ali.add(1.5f, 0, 0, 1, 2, 0);
    const Forces fl = compute(ali, handZones(), theta, cell);
    checkForce(fl, 0, 0, 3, 0);
    checkForce(fl, 1, 0, -3, 0);
    // attraction, x = 2.5 in [2, 3]: r^_10 = (0,1,0); F_0 = 5/1 * (0,1,0), F_1 = (0,-5,0)
    Agents att;
    att.add(0, 0, 0, 1, 0, 0);
    att.add(0, 2.5f, 0, 1, 0, 0);
    const Forces fa = compute(att, handZones(), theta, cell);
    checkForce(fa, 0, 0, 5, 0);
    checkForce(fa, 1, 0, -5, 0);
  });
}

TEST_CASE("BSwarm F_int: x = rRep is ali, x = rAtt is att, beyond rAtt nothing", "[bswarm-int]") {
  // pair (0,1) at x = 1 exactly: ali, v_1 - v_0 = (0,0,2), v^ = (0,0,1): F_0 = (0,0,3), F_1 = (0,0,-3)
  // pair (2,3) at x = 3 exactly: att: F_2 = 5 * (0,0,1), F_3 = (0,0,-5)
  // agent 4 is more than 3 from every other agent: F_4 = 0
  Agents a;
  a.add(0, 0, 0, 0, 0, 0);
  a.add(1, 0, 0, 0, 0, 2);
  a.add(100, 0, 0, 0, 0, 0);
  a.add(100, 0, 3, 0, 0, 0);
  a.add(100, 3.5f, 0, 0, 0, 0);
  forEachMode([&](float theta, float cell) {
    const Forces f = compute(a, handZones(), theta, cell);
    checkForce(f, 0, 0, 0, 3);
    checkForce(f, 1, 0, 0, -3);
    checkForce(f, 2, 0, 0, 5);
    checkForce(f, 3, 0, 0, -5);
    checkForce(f, 4, 0, 0, 0);
  });
}

TEST_CASE("BSwarm F_int: zones mixed, coincident agents, equal velocities", "[bswarm-int]") {
  // agent 0 at the origin, v = (1,0,0); zones of handZones()
  //   1 at (0.6,0,0)          rep, r^ = (1,0,0)
  //   2 at (0,0.8,0)          rep, r^ = (0,1,0)
  //   5 at (0,0,0), v = v_0   rep (coincident): counts, adds a zero vector
  //   3 at (0,0,1.5), v = (1,0,1): ali, v^ = (0,0,1)
  //   4 at (-2.5,0,0)         att, r^ = (-1,0,0)
  // F_0 = 2/3 * -(1,1,0) + 3/1 * (0,0,1) + 5/1 * (-1,0,0) = (-5.666667, -0.666667, 3)
  // agent 5 sees the same neighbours (agent 0 in place of itself): F_5 = F_0.
  // agent 6, far away, has one ali neighbour 7 with its own velocity: N_ali = 1, zero vector, F = 0.
  Agents a;
  a.add(0, 0, 0, 1, 0, 0);
  a.add(0.6f, 0, 0, 0, 0, 0);
  a.add(0, 0.8f, 0, 0, 0, 0);
  a.add(0, 0, 1.5f, 1, 0, 1);
  a.add(-2.5f, 0, 0, 0, 0, 0);
  a.add(0, 0, 0, 1, 0, 0);
  a.add(50, 50, 50, 0.3f, 0.2f, 0.1f);
  a.add(51.5f, 50, 50, 0.3f, 0.2f, 0.1f);
  forEachMode([&](float theta, float cell) {
    const Forces f = compute(a, handZones(), theta, cell);
    checkForce(f, 0, -2.0 / 3.0 - 5.0, -2.0 / 3.0, 3.0);
    checkForce(f, 5, -2.0 / 3.0 - 5.0, -2.0 / 3.0, 3.0);
    checkForce(f, 6, 0, 0, 0);
    checkForce(f, 7, 0, 0, 0);
    for (std::size_t i = 0; i < a.size(); ++i) {
      CHECK(std::isfinite(f.x[i]));
      CHECK(std::isfinite(f.y[i]));
      CHECK(std::isfinite(f.z[i]));
    }
  });
}

TEST_CASE("BSwarm F_int exact mode equals a double-precision brute force", "[bswarm-int]") {
  Agents a = randomBox(400, 2.0f, 2.0f, 1.5f, 7);
  // coincident agents and equal velocities
  for (std::size_t i = 0; i < 10; ++i) a.add(a.x[i], a.y[i], a.z[i], a.vx[i], a.vy[i], a.vz[i]);
  for (std::size_t i = 10; i < 20; ++i) a.add(a.x[i] + 0.3f, a.y[i], a.z[i], a.vx[i], a.vy[i], a.vz[i]);
  ZoneParams noAli = mixedZones();
  noAli.rAli = noAli.rRep;
  ZoneParams noAtt = mixedZones();
  noAtt.rAli = noAtt.rAtt;
  ZoneParams repOnly = mixedZones();
  repOnly.lambdaAli = repOnly.lambdaAtt = 0.0f;
  ZoneParams aliUnweighted = mixedZones();  // the ali zone still keeps its agents out of att
  aliUnweighted.lambdaAli = 0.0f;
  const std::pair<const char*, ZoneParams> cases[] = {{"three zones", mixedZones()},
                                                      {"rRep = rAli", noAli},
                                                      {"rAli = rAtt", noAtt},
                                                      {"rep only", repOnly},
                                                      {"lambda ali = 0", aliUnweighted}};
  for (const auto& [name, zones] : cases) {
    // cells smaller than, equal to and larger than the swarm (one shared block)
    for (const float cell : {0.15f, zones.rAtt, 4.0f}) {
      INFO(name << ", cell " << cell);
      const Forces f = compute(a, zones, 0.0f, cell);
      double worst = 0.0;
      for (std::size_t i = 0; i < a.size(); ++i) {
        double ref[3];
        bruteForce(a, zones, i, ref);
        worst = std::max({worst, std::abs(f.x[i] - ref[0]), std::abs(f.y[i] - ref[1]), std::abs(f.z[i] - ref[2])});
      }
      CHECK(worst < 1e-5);
    }
  }
}

TEST_CASE("BSwarm F_int approximation converges to the exact force", "[bswarm-int]") {
  // a uniform slab and clumps, all three zones weighted (velocity-space test for ali, cut cells)
  const Agents box = randomBox(3000, 3.0f, 2.0f, 0.3f, 11);
  const Agents clumps = randomClumps(3000, 6, 12);
  ZoneParams wide = mixedZones();
  wide.rAtt = 4.0f;
  ZoneParams aliUnweighted = mixedZones();
  aliUnweighted.lambdaAli = 0.0f;
  for (const auto& [name, agents, zones] :
       {std::tuple<const char*, const Agents&, ZoneParams>{"slab", box, mixedZones()},
        {"clumps", clumps, wide},
        {"slab, lambda ali = 0", box, aliUnweighted}}) {
    for (const float cell : {0.2f, 1.0f}) {
      INFO(name << ", cell " << cell);
      // theta -> 0: every pair on its own, the exact force up to float rounding
      const ForceError tiny = errorOf(agents, zones, 0.01f, cell, 1);
      CHECK(tiny.samples > 2900);
      CHECK(tiny.p95 < 1e-5);
      const ForceError small = errorOf(agents, zones, 0.2f, cell, 1);
      const ForceError dflt = errorOf(agents, zones, kDefaultTheta, cell, 1);
      INFO("theta 0.2: median " << small.median << ", p95 " << small.p95);
      INFO("default theta: median " << dflt.median << ", p95 " << dflt.p95);
      CHECK(small.p95 < 2e-3);
      CHECK(small.p95 < dflt.p95);
      CHECK(dflt.p95 < 0.05);
    }
  }
}

TEST_CASE("BSwarm F_int approximation error at the default theta, 20,000 agents", "[bswarm-int]") {
  // the locust density (200,000 in 24 x 5 x 0.5 m: 3,333 per m^3) in a smaller slab, and a midge ball
  const Agents slab = randomBox(20000, 6.0f, 2.4f, 0.42f, 3);
  const ForceError locust = errorOf(slab, locustZones(), kDefaultTheta, 0.2f, 5);
  WARN("locust-like slab, 20,000 agents, theta " << kDefaultTheta << ": median " << locust.median << ", p95 "
                                                 << locust.p95 << " (" << locust.samples << " agents)");
  CHECK(locust.samples > 3900);
  CHECK(locust.p95 < 0.05);
  const Agents ball = randomBall(20000, 0.4f, 5);
  const ForceError midge = errorOf(ball, midgeZones(), kDefaultTheta, 0.17f, 5);
  WARN("midge-like ball, 20,000 agents, theta " << kDefaultTheta << ": median " << midge.median << ", p95 " << midge.p95
                                                << " (" << midge.samples << " agents)");
  CHECK(midge.p95 < 0.05);
  ZoneParams clumpZones = mixedZones();
  clumpZones.rAtt = 5.0f;
  const ForceError clumps = errorOf(randomClumps(20000, 10, 7), clumpZones, kDefaultTheta, 0.2f, 5);
  WARN("10 clumps, 20,000 agents, three zones, theta " << kDefaultTheta << ": median " << clumps.median << ", p95 "
                                                       << clumps.p95 << " (" << clumps.samples << " agents)");
  CHECK(clumps.p95 < 0.05);
}

TEST_CASE("BSwarm F_int degenerate swarms", "[bswarm-int]") {
  for (const float theta : {0.0f, kDefaultTheta}) {
    INFO("theta " << theta);
    // none, one
    CHECK(compute(Agents(), handZones(), theta, 1.0f).x.empty());
    Agents one;
    one.add(1, 2, 3, 1, 0, 0);
    checkForce(compute(one, handZones(), theta, 1.0f), 0, 0, 0, 0);
    // two groups of 50 coincident agents 2.5 apart (att): within a group 49 rep neighbours at distance 0 give
    // zero vectors; F = 5/50 * 50 * unit(other group - own group) = 5 * (+-1, 0, 0)
    Agents groups;
    for (int i = 0; i < 100; ++i) groups.add(i < 50 ? 0.0f : 2.5f, 1, 1, 0.1f * static_cast<float>(i), 0, 0);
    const Forces f = compute(groups, handZones(), theta, 0.3f);
    for (std::size_t i = 0; i < 100; ++i) checkForce(f, i, i < 50 ? 5.0 : -5.0, 0, 0);
    // no weights: no force
    ZoneParams none = handZones();
    none.lambdaRep = none.lambdaAli = none.lambdaAtt = 0.0f;
    const Forces g = compute(randomBox(500, 2, 2, 2, 3), none, theta, 0.5f);
    CHECK(*std::max_element(g.x.begin(), g.x.end()) == 0.0f);
    CHECK(*std::min_element(g.x.begin(), g.x.end()) == 0.0f);
  }
}

TEST_CASE("BSwarm F_int is bit-identical for 1 and 2 threads", "[bswarm-int][determinism]") {
  const Agents a = randomBox(12000, 4.0f, 3.0f, 0.5f, 21);
  const int before = swarmsim::threadCount();
  for (const float theta : {0.0f, kDefaultTheta}) {
    for (const float cell : {0.2f, 1.0f}) {
      INFO("theta " << theta << ", cell " << cell);
      const Sorted s(a, cell);
      InteractionForces f1, f2;
      swarmsim::setThreadCount(1);
      const Forces one = compute(f1, s, mixedZones(), theta);
      swarmsim::setThreadCount(2);
      const Forces two = compute(f2, s, mixedZones(), theta);
      const Forces again = compute(f2, s, mixedZones(), theta);  // scratch reused
      const std::size_t bytes = a.size() * sizeof(float);
      CHECK(std::memcmp(one.x.data(), two.x.data(), bytes) == 0);
      CHECK(std::memcmp(one.y.data(), two.y.data(), bytes) == 0);
      CHECK(std::memcmp(one.z.data(), two.z.data(), bytes) == 0);
      CHECK(std::memcmp(two.x.data(), again.x.data(), bytes) == 0);
      // the far field's work counts (docs/performance.md's flops): the same for any number of threads, summed
      // over calls, every agent evaluated once a call, each one's scan over whole blocks and short of all pairs
      const InteractionForces::Work &w1 = f1.work(), &w2 = f2.work();
      if (theta == 0.0f) {
        CHECK(w2.agents == 0);
        CHECK(w2.agentEntries + w2.pseudoEntries == 0);
        continue;
      }
      CHECK(w1.agents == a.size());
      CHECK(w2.agents == 2 * w1.agents);
      CHECK(w2.agentEntries == 2 * w1.agentEntries);
      CHECK(w2.pseudoEntries == 2 * w1.pseudoEntries);
      CHECK(w2.cuts == 2 * w1.cuts);
      CHECK(w1.agentEntries > w1.agents);  // each agent at least scans itself
      CHECK(w1.agentEntries + w1.pseudoEntries < w1.agents * a.size() / 4);
    }
  }
  swarmsim::setThreadCount(before);
}

TEST_CASE("BSwarm F_int is bit-identical with and without AVX", "[bswarm-int][determinism]") {
  // SWARMSIM_NO_AVX=1 forces the two-SSE-register lanes; both must give the same bits (on CPUs without AVX
  // both runs take that path)
  const Agents a = randomClumps(6000, 8, 31);
  ZoneParams zones = mixedZones();
  zones.rAtt = 3.0f;
  for (const float theta : {0.0f, kDefaultTheta}) {
    INFO("theta " << theta);
    const Sorted s(a, 0.3f);
    InteractionForces f;
    const Forces avx = compute(f, s, zones, theta);
    setenv("SWARMSIM_NO_AVX", "1", 1);
    const Forces sse = compute(f, s, zones, theta);
    unsetenv("SWARMSIM_NO_AVX");
    const std::size_t bytes = a.size() * sizeof(float);
    CHECK(std::memcmp(avx.x.data(), sse.x.data(), bytes) == 0);
    CHECK(std::memcmp(avx.y.data(), sse.y.data(), bytes) == 0);
    CHECK(std::memcmp(avx.z.data(), sse.z.data(), bytes) == 0);
  }
}

// timings and errors for docs/models/bswarm.md (hidden: run with "[.bench]"; minimum over repeats)
TEST_CASE("BSwarm F_int timings", "[.bench][bswarm-int-bench]") {
  const auto time = [](const Agents& a, const ZoneParams& zones, float theta, float cell, int reps) {
    const Sorted s(a, cell);
    InteractionForces f;
    std::vector<float> fx(a.size()), fy(a.size()), fz(a.size());
    double best = 1e30;
    for (int r = 0; r < reps + 1; ++r) {
      f.compute(s.grid, s.vx.data(), s.vy.data(), s.vz.data(), zones, theta, fx.data(), fy.data(), fz.data());
      if (r > 0) best = std::min(best, f.seconds());  // the first call sizes the scratch
    }
    return best * 1e3;
  };
  const Agents midges = randomBall(3000, 0.3f, 1);
  const Agents slab = randomBox(20000, 6.0f, 2.4f, 0.42f, 3);
  const Agents ball = randomBall(20000, 0.4f, 5);
  const Agents clumps = randomClumps(20000, 10, 7);
  const Agents locusts = randomBox(200000, 24.0f, 5.0f, 0.5f, 9);
  ZoneParams clumpZones = mixedZones();
  clumpZones.rAtt = 5.0f;
  WARN("midges 3,000 exact, cell 0.17 / cell r_att: " << time(midges, midgeZones(), 0.0f, 0.17f, 20) << " / "
                                                      << time(midges, midgeZones(), 0.0f, 5.29f, 20) << " ms");
  for (const float theta : {0.5f, 1.0f, 1.5f, 2.0f}) {
    std::ostringstream out;
    const ForceError em = errorOf(midges, midgeZones(), theta, 0.17f, 1);
    out << "theta " << theta << ": midges 3,000 " << time(midges, midgeZones(), theta, 0.17f, 20)
        << " ms, error median " << em.median << " p95 " << em.p95;
    for (const auto& [name, agents, zones, cell] :
         {std::tuple<const char*, const Agents&, ZoneParams, float>{"locust slab 20,000", slab, locustZones(), 0.2f},
          {"midge ball 20,000", ball, midgeZones(), 0.17f},
          {"clumps 20,000", clumps, clumpZones, 0.2f}}) {
      const ForceError e = errorOf(agents, zones, theta, cell, 5);
      out << "; " << name << " " << time(agents, zones, theta, cell, 3) << " ms, error median " << e.median << " p95 "
          << e.p95;
    }
    const ForceError e = errorOf(locusts, locustZones(), theta, 0.2f, 200);
    out << "; locusts 200,000 " << time(locusts, locustZones(), theta, 0.2f, 3) << " ms, error median " << e.median
        << " p95 " << e.p95;
    WARN(out.str());
  }
  WARN("exact: locust slab 20,000 " << time(slab, locustZones(), 0.0f, 0.2f, 2) << " ms; midge ball 20,000 "
                                    << time(ball, midgeZones(), 0.0f, 0.17f, 2) << " ms; clumps 20,000 "
                                    << time(clumps, clumpZones, 0.0f, 0.2f, 2) << " ms");
}
