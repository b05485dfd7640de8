// 3-D ORCA (lib/orca): the k-nearest search against brute force, the linear
// program against sampling, and whole runs: no overlaps between agents or with
// obstacles, finite velocities when infeasible, identical results for 1 and 2
// threads.
#include "orca/orca.hpp"

#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <numeric>
#include <random>
#include <stdexcept>
#include <vector>

#include "core/parallel.hpp"
#include "geometry/obstacles.hpp"
#include "geometry/signed_distance.hpp"
#include "spatial/uniform_grid.hpp"
#include "test_util.hpp"

using swarmsim::UniformGrid;
using swarmsim::Vec3;
using swarmsim::Vec3d;
using swarmsim::orca::Params;
using swarmsim::orca::Plane;
using swarmsim::orca::Solver;

namespace {

// A crowd flying to fixed goals. Each step: bin the agents (minCell =
// neighborDistance, as a model would), preferred velocity = maxSpeed towards the
// goal (slower in the last step before it), ORCA, x += v dt. The arrays are kept
// in the grid's order, with id[] following the agents.
struct Crowd {
  std::vector<float> x, y, z, vx, vy, vz, gx, gy, gz;
  std::vector<std::uint32_t> id;
  UniformGrid grid;
  Solver solver;
  std::vector<float> px, py, pz, ox, oy, oz, tmp;
  std::vector<std::uint32_t> tmpId;

  void add(const Vec3& p, const Vec3& goal, const Vec3& v = Vec3::Zero()) {
    id.push_back(static_cast<std::uint32_t>(x.size()));
    x.push_back(p.x());
    y.push_back(p.y());
    z.push_back(p.z());
    vx.push_back(v.x());
    vy.push_back(v.y());
    vz.push_back(v.z());
    gx.push_back(goal.x());
    gy.push_back(goal.y());
    gz.push_back(goal.z());
  }
  std::size_t size() const { return x.size(); }
  Vec3 position(std::size_t k) const { return {x[k], y[k], z[k]}; }
  Vec3 velocity(std::size_t k) const { return {vx[k], vy[k], vz[k]}; }
  // slot of the agent with this id
  std::size_t slotOf(std::uint32_t agent) const {
    return static_cast<std::size_t>(std::find(id.begin(), id.end(), agent) - id.begin());
  }

  void permute(std::vector<float>& v) {
    const auto& order = grid.order();
    tmp.resize(v.size());
    for (std::size_t k = 0; k < v.size(); ++k) tmp[k] = v[order[k]];
    v.swap(tmp);
  }

  // bins, sorts and solves (no move); the new velocities are in ox/oy/oz
  void solve(const Params& p, const swarmsim::orca::Obstacles& obstacles, float dt) {
    const std::size_t n = size();
    grid.build(x.data(), y.data(), z.data(), n, std::max(p.neighborDistance, 1e-3f));
    x.assign(grid.sortedX().begin(), grid.sortedX().begin() + static_cast<std::ptrdiff_t>(n));
    y.assign(grid.sortedY().begin(), grid.sortedY().begin() + static_cast<std::ptrdiff_t>(n));
    z.assign(grid.sortedZ().begin(), grid.sortedZ().begin() + static_cast<std::ptrdiff_t>(n));
    for (auto* v : {&vx, &vy, &vz, &gx, &gy, &gz}) permute(*v);
    tmpId.resize(n);
    for (std::size_t k = 0; k < n; ++k) tmpId[k] = id[grid.order()[k]];
    id.swap(tmpId);
    px.resize(n);
    py.resize(n);
    pz.resize(n);
    ox.assign(n, std::numeric_limits<float>::quiet_NaN());
    oy = ox;
    oz = ox;
    for (std::size_t k = 0; k < n; ++k) {
      const Vec3 d(gx[k] - x[k], gy[k] - y[k], gz[k] - z[k]);
      const float dist = d.norm();
      const float speed = std::min(p.maxSpeed, dist / dt);
      const Vec3 v = dist > 0.0f ? Vec3(d * (speed / dist)) : Vec3::Zero();
      px[k] = v.x();
      py[k] = v.y();
      pz[k] = v.z();
    }
    solver.solve(grid, vx.data(), vy.data(), vz.data(), px.data(), py.data(), pz.data(), p, obstacles, dt, ox.data(),
                 oy.data(), oz.data());
  }

  void step(const Params& p, const swarmsim::orca::Obstacles& obstacles, float dt) {
    solve(p, obstacles, dt);
    for (std::size_t k = 0; k < size(); ++k) {
      vx[k] = ox[k];
      vy[k] = oy[k];
      vz[k] = oz[k];
      x[k] += vx[k] * dt;
      y[k] += vy[k] * dt;
      z[k] += vz[k] * dt;
    }
  }

  // smallest distance between two agents (grid search, pairs closer than `within`)
  float minPairDistance(float within) const {
    UniformGrid g;
    g.build(x.data(), y.data(), z.data(), size(), within);
    float best = std::numeric_limits<float>::infinity();
    for (std::size_t k = 0; k < size(); ++k) {
      g.forEachNeighbor(g.sortedX()[k], g.sortedY()[k], g.sortedZ()[k], within,
                        [&](std::uint32_t o, float, float, float, float d2) {
                          if (o != k) best = std::min(best, std::sqrt(d2));
                        });
    }
    return best;
  }
};

Params paramsFor(float radius) {
  Params p;
  p.radius = radius;
  p.neighborDistance = 5.0f;
  p.maxNeighbors = 10;
  p.timeHorizon = 2.0f;
  p.timeHorizonObstacle = 1.0f;
  p.maxSpeed = 2.0f;
  return p;
}

float boxDistance(const Vec3& p, const Vec3& lo, const Vec3& hi) {
  const Vec3 c = (lo + hi) * 0.5f, h = (hi - lo) * 0.5f;
  const Vec3 q = (p - c).cwiseAbs() - h;
  return q.cwiseMax(0.0f).norm() + std::min(q.maxCoeff(), 0.0f);
}

float maxViolation(const std::vector<Plane>& planes, std::size_t from, std::size_t to, const Vec3& v) {
  float worst = -std::numeric_limits<float>::infinity();
  for (std::size_t i = from; i < to; ++i) {
    worst = std::max(worst, planes[i].b - (planes[i].nx * v.x() + planes[i].ny * v.y() + planes[i].nz * v.z()));
  }
  return worst;
}

std::uint32_t bitsOf(float f) {
  std::uint32_t u;
  std::memcpy(&u, &f, sizeof u);
  return u;
}

Vec3 randomUnit(std::mt19937& rng) {
  std::normal_distribution<float> g(0.0f, 1.0f);
  for (;;) {
    const Vec3 v(g(rng), g(rng), g(rng));
    if (v.norm() > 1e-3f) return v.normalized();
  }
}

Vec3 randomInBall(std::mt19937& rng, float radius) {
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (;;) {
    const Vec3 v(u(rng), u(rng), u(rng));
    if (v.squaredNorm() <= 1.0f) return v * radius;
  }
}

}  // namespace

TEST_CASE("orca: an agent without neighbours or obstacles gets its preferred velocity", "[orca]") {
  const Params p = paramsFor(0.5f);
  Crowd c;
  // three agents farther apart than neighborDistance (the search runs and finds nobody)
  c.add(Vec3(0, 0, 0), Vec3(10, 5, -2));
  c.add(Vec3(20, 0, 0), Vec3(20, 0.1f, 0));
  c.add(Vec3(0, 30, 0), Vec3(0, 30, 0));
  c.vx = {1.0f, -2.0f, 0.3f};
  c.solve(p, {}, 0.1f);
  for (std::size_t k = 0; k < c.size(); ++k) {
    INFO("agent " << c.id[k]);
    CHECK(c.ox[k] == c.px[k]);
    CHECK(c.oy[k] == c.py[k]);
    CHECK(c.oz[k] == c.pz[k]);
    std::size_t count = 99;
    c.solver.neighbors(k, count);
    CHECK(count == 0);
  }
  CHECK(c.solver.infeasibleCount() == 0);
  const std::size_t slow = c.slotOf(1);  // 0.1 m from its goal: 1 m/s, below maxSpeed
  CHECK(c.px[slow] == 0.0f);
  CHECK(c.py[slow] == Approx(1.0f));

  // faster than maxSpeed: clamped to the ball, same direction
  Crowd one;
  one.add(Vec3(0, 0, 0), Vec3(0, 0, 0));
  one.grid.build(one.x.data(), one.y.data(), one.z.data(), 1, 5.0f);
  const float pref[3] = {3.0f, 4.0f, 0.0f}, zero = 0.0f;
  float out[3];
  one.solver.solve(one.grid, &zero, &zero, &zero, &pref[0], &pref[1], &pref[2], p, {}, 0.1f, &out[0], &out[1], &out[2]);
  CHECK(out[0] == Approx(1.2f).epsilon(1e-6));
  CHECK(out[1] == Approx(1.6f).epsilon(1e-6));
  CHECK(out[2] == 0.0f);
}

TEST_CASE("orca: k nearest neighbours match brute force, ties by index", "[orca]") {
  std::mt19937 rng(12);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  // a lattice (many exact ties), two dense clusters, a sparse halo and a few loners
  std::vector<Vec3> pts;
  for (int i = 0; i < 12; ++i) {
    for (int j = 0; j < 12; ++j) {
      for (int k = 0; k < 12; ++k)
        pts.push_back(Vec3(static_cast<float>(2 * i), static_cast<float>(2 * j), static_cast<float>(2 * k)));
    }
  }
  for (int i = 0; i < 1500; ++i) pts.push_back(Vec3(40, 5, 5) + randomInBall(rng, 3.0f));
  for (int i = 0; i < 800; ++i) pts.push_back(Vec3(5, 40, 5) + randomInBall(rng, 1.0f));
  for (int i = 0; i < 120; ++i) pts.push_back(Vec3(20, 20, 20) + randomInBall(rng, 40.0f));
  pts.emplace_back(-60, 0, 0);
  pts.emplace_back(-60, 0, 1);
  const std::size_t n = pts.size();
  std::vector<float> x(n), y(n), z(n), zero(n, 0.0f), out(3 * n);
  for (std::size_t i = 0; i < n; ++i) {
    x[i] = pts[i].x();
    y[i] = pts[i].y();
    z[i] = pts[i].z();
  }
  UniformGrid grid;
  grid.build(x.data(), y.data(), z.data(), n, 6.0f);
  const float* sx = grid.sortedX().data();
  const float* sy = grid.sortedY().data();
  const float* sz = grid.sortedZ().data();
  // the selection on AVX-512 or AVX2 lanes (rank counts, up to 64 hits, up to 32 without a branch) and without
  // (SWARMSIM_NO_AVX2): the same lists
  for (const int mode : {0, 1, 2}) {
    const bool noAvx2 = mode == 2;
    const swarmsim_test::EnvGuard lanes512("SWARMSIM_NO_AVX512", mode == 1 ? "1" : nullptr);
    const swarmsim_test::EnvGuard lanes("SWARMSIM_NO_AVX2", noAvx2 ? "1" : nullptr);
    for (const int K : {1, 10, 25}) {
      Params p = paramsFor(0.1f);
      p.maxNeighbors = K;
      p.neighborDistance = 6.0f;
      Solver solver;
      // the first solve guesses the search cell from the density, the second adapts it
      std::size_t widened = 0;
      for (int round = 0; round < 2; ++round) {
        solver.solve(grid, zero.data(), zero.data(), zero.data(), zero.data(), zero.data(), zero.data(), p, {}, 0.1f,
                     out.data(), out.data() + n, out.data() + 2 * n);
        INFO("K " << K << " round " << round << " lanes " << mode << " cell " << solver.searchCell() << " widened "
                  << solver.widenedSearches());
        std::size_t mismatches = 0;
        std::vector<std::pair<float, std::uint32_t>> all;
        for (std::size_t k = 0; k < n; ++k) {
          all.clear();
          for (std::size_t o = 0; o < n; ++o) {
            if (o == k) continue;
            const float dx = sx[o] - sx[k], dy = sy[o] - sy[k], dz = sz[o] - sz[k];
            const float d2 = dx * dx + dy * dy + dz * dz;
            if (d2 < p.neighborDistance * p.neighborDistance) all.emplace_back(d2, static_cast<std::uint32_t>(o));
          }
          std::sort(all.begin(), all.end());
          all.resize(std::min(all.size(), static_cast<std::size_t>(K)));
          std::size_t count = 0;
          const std::uint32_t* nb = solver.neighbors(k, count);
          bool same = count == all.size();
          for (std::size_t t = 0; same && t < count; ++t) same = nb[t] == all[t].second;
          if (!same) ++mismatches;
        }
        CHECK(mismatches == 0);
        widened += solver.widenedSearches();
      }
      CHECK(widened > 0);  // the halo and the loners needed wider searches
    }
  }
}

TEST_CASE("orca: a neighbour's half-space touches its velocity obstacle at the closest point", "[orca]") {
  // VO = {w : |w t - p| < R for some t in (0, tau]} = union over s >= 1/tau of the balls B(s p, s R).
  // The distance from w outside VO to it is min over s of |w - s p| - s R (a convex function of s).
  const float radius = 0.5f, R = 1.0f, tau = 2.0f, dt = 0.1f;
  const auto gap = [&](const Vec3& w, const Vec3& p) {
    float best = std::numeric_limits<float>::infinity();
    for (int i = 0; i <= 40000; ++i) {
      const float s = 1.0f / tau + 0.0005f * static_cast<float>(i);  // up to s = 20.5
      best = std::min(best, (w - s * p).norm() - s * R);
    }
    return best;  // < 0: inside
  };
  std::mt19937 rng(17);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  int outside = 0, inside = 0;
  for (int it = 0; it < 1500; ++it) {
    const Vec3 p = randomInBall(rng, 6.0f), vi = randomInBall(rng, 2.0f);
    if (p.norm() < 1.05f * R) continue;
    // every other one heading roughly at the neighbour, mostly inside VO
    const Vec3 rv = it % 2 ? randomInBall(rng, 3.0f) : Vec3(p * (0.3f + u(rng)) + randomInBall(rng, 0.4f));
    const Vec3 vj = vi - rv;
    const Plane h = swarmsim::orca::agentHalfSpace(p, vi, vj, radius, tau, dt);
    const Vec3 n(h.nx, h.ny, h.nz);
    INFO("p " << p.transpose() << " rv " << rv.transpose());
    REQUIRE(n.norm() == Approx(1.0f).epsilon(1e-5));
    const float along = 2.0f * (h.b - n.dot(vi));  // u . n, u parallel to n
    const Vec3 boundary = rv + along * n;
    CHECK(gap(boundary + 0.01f * n, p) > 0.0f);  // n points out of VO at the boundary point
    CHECK(gap(boundary - 0.01f * n, p) < 0.0f);
    const float g = gap(rv, p);
    if (g > 0.0f) {
      ++outside;
      CHECK(-along == Approx(g).margin(2e-3));  // u is the shortest way to VO
    } else {
      ++inside;
      CHECK(along >= -1e-4f);
    }
  }
  CHECK(outside > 300);
  CHECK(inside > 100);

  // overlapping: leave the ball of centre p/dt, radius R/dt; exactly head-on: opposite sidesteps
  const Plane over = swarmsim::orca::agentHalfSpace(Vec3(0.5f, 0, 0), Vec3::Zero(), Vec3::Zero(), radius, tau, dt);
  CHECK(over.nx == Approx(-1.0f));
  CHECK(over.b == Approx(0.5f * (R - 0.5f) / dt));
  const Plane a = swarmsim::orca::agentHalfSpace(Vec3(4, 0, 0), Vec3(1, 0, 0), Vec3(-1, 0, 0), radius, tau, dt);
  const Plane b = swarmsim::orca::agentHalfSpace(Vec3(-4, 0, 0), Vec3(-1, 0, 0), Vec3(1, 0, 0), radius, tau, dt);
  CHECK(a.nx < 0.0f);
  CHECK(b.nx > 0.0f);
  CHECK(a.ny == -b.ny);
  CHECK(a.nz == -b.nz);
  CHECK(std::abs(a.ny) + std::abs(a.nz) > 0.5f);
}

TEST_CASE("orca: the linear program finds the closest feasible velocity", "[orca]") {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const float R = 2.0f;
  std::vector<Plane> planes, scratch;
  int checked = 0;
  for (int instance = 0; instance < 300; ++instance) {
    // planes through the neighbourhood of a point v0 inside the ball, all containing it
    const Vec3 v0 = randomInBall(rng, 0.9f * R);
    const auto count = static_cast<std::size_t>(1 + instance % 12);
    planes.clear();
    for (std::size_t i = 0; i < count; ++i) {
      const Vec3 n = randomUnit(rng);
      planes.push_back({n.x(), n.y(), n.z(), n.dot(v0) - 0.5f * u(rng)});
    }
    scratch.resize(count);
    const Vec3 pref = randomInBall(rng, 1.5f * R);
    std::vector<Plane> work = planes;
    Vec3 v;
    const bool fallback = swarmsim::orca::solveVelocity(work.data(), count, 0, pref, R, scratch.data(), v);
    INFO("instance " << instance);
    REQUIRE_FALSE(fallback);
    CHECK(v.norm() <= R * (1.0f + 1e-6f));
    CHECK(maxViolation(planes, 0, count, v) <= 1e-4f);
    // no feasible sample is closer to pref
    const float dist = (v - pref).norm();
    for (int s = 0; s < 3000; ++s) {
      const Vec3 w = randomInBall(rng, R);
      if (maxViolation(planes, 0, count, w) > 0.0f) continue;
      ++checked;
      if ((w - pref).norm() < dist - 1e-4f) FAIL("sample " << w.transpose() << " is closer than " << v.transpose());
    }
  }
  CHECK(checked > 10000);
}

TEST_CASE("orca: infeasible programs minimise the worst violation, obstacle planes first", "[orca]") {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const float R = 2.0f;
  std::vector<Plane> planes, scratch;
  int infeasible = 0;
  for (int instance = 0; instance < 300; ++instance) {
    const auto hard = static_cast<std::size_t>(instance % 3);
    const auto count = hard + static_cast<std::size_t>(3 + instance % 10);
    planes.clear();
    // hard planes: containing a common point h0; soft ones: far out, pointing inwards
    const Vec3 h0 = randomInBall(rng, 0.8f * R);
    for (std::size_t i = 0; i < hard; ++i) {
      const Vec3 n = randomUnit(rng);
      planes.push_back({n.x(), n.y(), n.z(), n.dot(h0) - 0.3f * u(rng)});
    }
    for (std::size_t i = hard; i < count; ++i) {
      const Vec3 n = randomUnit(rng);
      planes.push_back({n.x(), n.y(), n.z(), R * (0.2f + 1.5f * u(rng))});
    }
    scratch.resize(count);
    std::vector<Plane> work = planes;
    Vec3 v;
    const Vec3 pref = randomInBall(rng, R);
    const bool fallback = swarmsim::orca::solveVelocity(work.data(), count, hard, pref, R, scratch.data(), v);
    if (!fallback) continue;
    ++infeasible;
    INFO("instance " << instance << " hard " << hard);
    REQUIRE(std::isfinite(v.x()));
    CHECK(v.norm() <= R * (1.0f + 1e-6f));
    if (hard > 0) CHECK(maxViolation(planes, 0, hard, v) <= 1e-3f);
    const float worst = maxViolation(planes, hard, count, v);
    CHECK(worst > 0.0f);
    for (int s = 0; s < 4000; ++s) {
      const Vec3 w = randomInBall(rng, R);
      if (hard > 0 && maxViolation(planes, 0, hard, w) > 0.0f) continue;
      if (maxViolation(planes, hard, count, w) < worst - 2e-3f) {
        FAIL("sample " << w.transpose() << " violates less than " << v.transpose() << " (" << worst << ")");
      }
    }
  }
  CHECK(infeasible > 100);

  // obstacle planes that conflict among themselves (inside an obstacle, the way out
  // faster than maxSpeed): their least worst violation wins over the agent planes
  std::vector<Plane> conflict = {{1, 0, 0, 2.5f}, {0, 0, 1, 0.0f}, {0, 1, 0, 1.0f}};
  scratch.resize(conflict.size());
  Vec3 v;
  CHECK(swarmsim::orca::solveVelocity(conflict.data(), 3, 2, Vec3(-1, -1, 0), R, scratch.data(), v));
  CHECK(v.x() > 0.999f * R);  // x >= 2.5 is out of reach: as far along x as possible
  CHECK(v.z() >= -1e-4f);
  CHECK(v.y() > 0.0f);  // and then towards the agent plane, as far as the obstacles allow
  CHECK(v.y() < 0.05f);
}

TEST_CASE("orca: the programs of eight agents on lanes give solveVelocity's bits, on every lane set", "[orca]") {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const float R = 2.0f;
  const std::size_t stride = 30;
  std::size_t infeasible = 0, compared = 0, subProblems = 0;
  for (int instance = 0; instance < 400; ++instance) {
    // groups of 1 to 19 agents (more than one lane group), each with its own count of planes, some of them
    // obstacles; the mixes give feasible programs, programs that need the plane and line sub-problems, and
    // infeasible ones (the fallback), with parallel and coincident planes now and then
    const auto agents = static_cast<std::size_t>(1 + instance % 19);
    std::vector<Plane> planes(agents * stride), scratch(stride);
    std::vector<std::size_t> count(agents), hard(agents);
    std::vector<Vec3> pref(agents);
    for (std::size_t a = 0; a < agents; ++a) {
      count[a] = static_cast<std::size_t>(rng() % 25);
      hard[a] = std::min(count[a], static_cast<std::size_t>(rng() % 3));
      const Vec3 v0 = randomInBall(rng, 0.9f * R);
      const float spread = instance % 4 == 0 ? 3.0f * R : 0.6f;
      for (std::size_t i = 0; i < count[a]; ++i) {
        Vec3 n = randomUnit(rng);
        if (i > 0 && rng() % 8 == 0) {
          const Plane& o = planes[a * stride + i - 1];
          n = Vec3(o.nx, o.ny, o.nz) * (rng() % 2 ? 1.0f : -1.0f);  // parallel to the one before
        }
        planes[a * stride + i] = {n.x(), n.y(), n.z(), n.dot(v0) - spread * (u(rng) - 0.3f)};
      }
      pref[a] = randomInBall(rng, 1.5f * R);
    }
    std::vector<Vec3> want(agents);
    std::vector<char> wantInfeasible(agents);
    for (std::size_t a = 0; a < agents; ++a) {
      std::vector<Plane> work(planes.begin() + static_cast<std::ptrdiff_t>(a * stride),
                              planes.begin() + static_cast<std::ptrdiff_t>(a * stride + count[a]));
      wantInfeasible[a] =
          swarmsim::orca::solveVelocity(work.data(), count[a], hard[a], pref[a], R, scratch.data(), want[a]);
      infeasible += wantInfeasible[a] ? 1 : 0;
      // the preferred velocity (in the ball) violates a plane: the program goes into its sub-problems
      const std::vector<Plane> own(planes.begin() + static_cast<std::ptrdiff_t>(a * stride),
                                   planes.begin() + static_cast<std::ptrdiff_t>(a * stride + count[a]));
      const Vec3 p = pref[a].norm() > R ? Vec3(pref[a] * (R / pref[a].norm())) : pref[a];
      subProblems += maxViolation(own, 0, count[a], p) > 1e-5f ? 1 : 0;
    }
    for (const auto lanes :
         {swarmsim::LaneSet::kSse, swarmsim::LaneSet::kAvx, swarmsim::LaneSet::kAvx2, swarmsim::LaneSet::kAvx512}) {
      if (lanes > swarmsim::laneSet()) continue;
      std::vector<Plane> work = planes;
      std::vector<Vec3> got(agents);
      std::unique_ptr<bool[]> gotInfeasible(new bool[agents]);
      std::vector<float> lanesScratch;
      const std::size_t n =
          swarmsim::orca::solveVelocities(work.data(), stride, count.data(), hard.data(), pref.data(), agents, R,
                                          scratch.data(), lanesScratch, got.data(), gotInfeasible.get(), lanes);
      std::size_t expected = 0;
      for (std::size_t a = 0; a < agents; ++a) {
        INFO("instance " << instance << ", lanes " << static_cast<int>(lanes) << ", agent " << a << " of " << agents
                         << ", " << count[a] << " planes");
        CHECK(static_cast<char>(gotInfeasible[a]) == wantInfeasible[a]);
        for (int c = 0; c < 3; ++c) CHECK(bitsOf(got[a][c]) == bitsOf(want[a][c]));
        expected += wantInfeasible[a] ? 1 : 0;
        ++compared;
      }
      CHECK(n == expected);
    }
  }
  CHECK(infeasible > 200);
  CHECK(subProblems > 1000);
  CHECK(compared > 4000);
}

TEST_CASE("orca: two agents head-on never overlap and pass each other", "[orca]") {
  const Params p = paramsFor(0.5f);
  const float dt = 0.05f;
  for (const float offset : {0.0f, 0.05f, 0.3f}) {
    Crowd c;
    c.add(Vec3(-5, 0, 0), Vec3(5, offset, 0));
    c.add(Vec3(5, offset, 0), Vec3(-5, 0, 0));
    float closest = std::numeric_limits<float>::infinity();
    for (int s = 0; s < 300; ++s) {
      c.step(p, {}, dt);
      closest = std::min(closest, (c.position(0) - c.position(1)).norm());
    }
    INFO("lateral offset " << offset << ": closest " << closest);
    CHECK(closest >= 2.0f * p.radius * (1.0f - 1e-4f));
    // exactly head-on too: the cone's normal is then taken across the axis in a direction
    // odd in the axis, so the two agents sidestep opposite ways
    CHECK(c.x[c.slotOf(0)] > 5.0f - 0.01f);
    CHECK(c.x[c.slotOf(1)] < -5.0f + 0.01f);
  }
}

TEST_CASE("orca: a dense ball of 1,000 agents keeps every pair apart", "[orca]") {
  // 1,000 agents of radius 0.5 m in a ball of radius 10 m (13% of its volume), each to a
  // random goal in the ball at up to 2 m/s, maxNeighbors 10: agents are often squeezed
  // (the LP infeasible) and then the least violation allows small overlaps, which shrink
  // with dt (measured: 0.9862 m at dt 0.02 s, 0.9936 m at dt 0.01 s; docs/orca.md)
  const Params p = paramsFor(0.5f);
  const float dt = 0.01f, ballRadius = 10.0f;
  std::mt19937 rng(21);
  Crowd c;
  std::vector<Vec3> placed;
  while (placed.size() < 1000) {  // random sequential placement, 1.1 diameters apart
    const Vec3 q = randomInBall(rng, ballRadius);
    bool ok = true;
    for (const Vec3& o : placed) ok = ok && (o - q).squaredNorm() >= 1.21f;
    if (!ok) continue;
    placed.push_back(q);
    c.add(q, randomInBall(rng, ballRadius));
  }
  const auto meanToGoal = [&] {
    double sum = 0.0;
    for (std::size_t k = 0; k < c.size(); ++k) sum += Vec3(c.gx[k] - c.x[k], c.gy[k] - c.y[k], c.gz[k] - c.z[k]).norm();
    return sum / static_cast<double>(c.size());
  };
  const double before = meanToGoal();
  float closest = std::numeric_limits<float>::infinity();
  std::size_t infeasible = 0;
  for (int s = 0; s < 500; ++s) {
    c.step(p, {}, dt);
    closest = std::min(closest, c.minPairDistance(2.0f * p.radius));
    infeasible += c.solver.infeasibleCount();
  }
  const double after = meanToGoal();
  WARN("1,000 agents, 500 steps of " << dt << " s: minimum pair distance " << closest
                                     << " m (2r = 1 m); infeasible agent-steps " << infeasible
                                     << "; mean distance to the goal " << before << " -> " << after << " m");
  CHECK(closest >= 0.99f * 2.0f * p.radius);
  CHECK(after < 0.6 * before);  // they do get somewhere
}

TEST_CASE("orca: agents do not enter a sphere obstacle and get around it", "[orca]") {
  Params p = paramsFor(0.3f);
  const float dt = 0.05f;
  swarmsim::orca::Obstacles obstacles;
  obstacles.spheres.push_back({Vec3(0, 0, 0), 2.0f});
  Crowd c;
  // a 5 x 5 block aimed through the sphere (one of them at its centre), goals 16 m on
  for (int i = -2; i <= 2; ++i) {
    for (int j = -2; j <= 2; ++j)
      c.add(Vec3(-8.0f, 0.8f * static_cast<float>(i), 0.8f * static_cast<float>(j)),
            Vec3(8.0f, 0.8f * static_cast<float>(i), 0.8f * static_cast<float>(j)));
  }
  float clearance = std::numeric_limits<float>::infinity();
  for (int s = 0; s < 600; ++s) {
    c.step(p, obstacles, dt);
    for (std::size_t k = 0; k < c.size(); ++k) clearance = std::min(clearance, c.position(k).norm() - 2.0f);
  }
  INFO("closest approach of an agent centre to the surface " << clearance << " (radius " << p.radius << ")");
  CHECK(clearance >= p.radius - 1e-3f);
  const std::size_t centre = c.slotOf(12);  // aimed at the centre: no side to slide to; stops
  CHECK(c.x[centre] < -2.0f);
  CHECK(c.velocity(centre).norm() < 0.05f);
  for (std::size_t k = 0; k < c.size(); ++k) {
    if (k == centre) continue;
    INFO("agent " << c.id[k] << " at " << c.position(k).transpose());
    CHECK(c.x[k] > 2.0f + p.radius);  // went around
  }
}

TEST_CASE("orca: agents dodge a moving sphere", "[orca]") {
  // a sphere of radius 1 m sweeps along +x at 1.5 m/s through agents that want to stay put
  // (max speed 2 m/s): avoided in relative velocity, none is ever inside it
  Params p = paramsFor(0.1f);
  const float dt = 0.02f;
  Crowd c;
  for (int i = 0; i < 5; ++i) {
    const Vec3 at(2.0f * static_cast<float>(i), 0.3f * static_cast<float>(i % 3) - 0.3f, 0.0f);
    c.add(at, at);
  }
  swarmsim::orca::Obstacles obstacles;
  const Vec3 velocity(1.5f, 0.0f, 0.0f);
  float clearance = std::numeric_limits<float>::infinity();
  for (int s = 0; s < 600; ++s) {  // 12 s: from x = -4 to x = 14
    const Vec3 centre = Vec3(-4.0f, 0.0f, 0.0f) + velocity * (static_cast<float>(s) * dt);
    obstacles.spheres = {{centre, 1.0f, velocity}};
    c.step(p, obstacles, dt);
    const Vec3 next = centre + velocity * dt;  // where the sphere is when the agents arrive
    for (std::size_t k = 0; k < c.size(); ++k) clearance = std::min(clearance, (c.position(k) - next).norm() - 1.0f);
  }
  INFO("closest approach of an agent centre to the moving surface " << clearance);
  CHECK(clearance >= p.radius - 0.01f);
}

TEST_CASE("orca: agents do not enter a box given only as a signed distance grid", "[orca]") {
  Params p = paramsFor(0.3f);
  const float dt = 0.05f;
  const Vec3 lo(-1, -1, -1), hi(1, 1, 1);
  swarmsim::Obstacles scene;
  scene.boxes.push_back({lo.cast<double>(), hi.cast<double>()});
  const auto spec =
      swarmsim::GridSpec::covering(Vec3(-6, -6, -6).cast<double>(), Vec3(6, 6, 6).cast<double>(), {96, 96, 96});
  const swarmsim::Grid3<float> sdf = swarmsim::signedDistance(scene, spec);
  swarmsim::orca::Obstacles obstacles;
  obstacles.sdf = &sdf;
  Crowd c;
  c.add(Vec3(-5, 0.2f, -0.1f), Vec3(5, 0.2f, -0.1f));  // straight at a face: stops
  c.add(Vec3(-5, -0.5f, 0), Vec3(5, 2.5f, 0));         // across a face: slides off its edge
  c.add(Vec3(-4, -4, 0.5f), Vec3(4, 4, 0.5f));         // at a vertical edge, slightly off
  c.add(Vec3(0.3f, 0.2f, -5), Vec3(-0.3f, 0.1f, 5));   // from below, at the bottom face
  c.add(Vec3(5, 5, 5), Vec3(-5, -5, -4.5f));           // at a corner, slightly off the diagonal
  float clearance = std::numeric_limits<float>::infinity();
  for (int s = 0; s < 600; ++s) {
    c.step(p, obstacles, dt);
    for (std::size_t k = 0; k < c.size(); ++k) clearance = std::min(clearance, boxDistance(c.position(k), lo, hi));
  }
  INFO("closest approach of an agent centre to the box " << clearance << " (radius " << p.radius << ")");
  CHECK(clearance >= p.radius - 0.02f);
  const auto at = [&](std::uint32_t agent) { return c.position(c.slotOf(agent)); };
  const auto goal = [&](std::uint32_t agent) {
    const std::size_t k = c.slotOf(agent);
    return Vec3(c.gx[k], c.gy[k], c.gz[k]);
  };
  CHECK(at(0).x() < -1.0f);  // stopped in front of the face
  CHECK(at(0).x() > -1.0f - p.radius - 0.2f);
  CHECK(c.velocity(c.slotOf(0)).norm() < 0.05f);
  for (std::uint32_t agent : {1u, 2u, 4u}) {
    INFO("agent " << agent << " at " << at(agent).transpose());
    CHECK((at(agent) - goal(agent)).norm() < 0.1f);
  }
  CHECK(at(3).z() < -1.0f);  // straight at the bottom face: stopped below it
}

TEST_CASE("orca: an infeasible crowd gets finite, bounded velocities", "[orca]") {
  Params p = paramsFor(0.5f);
  std::mt19937 rng(8);
  Crowd c;
  // 300 agents in a ball of radius 2.5 (about 2.6 times overlapped), all wanting the
  // centre; two pairs at identical positions; some inside a sphere obstacle and in a box
  for (int i = 0; i < 300; ++i) c.add(randomInBall(rng, 2.5f), Vec3::Zero());
  c.add(Vec3(1, 1, 1), Vec3::Zero());
  c.add(Vec3(1, 1, 1), Vec3::Zero());
  c.add(Vec3(0.5f, 0, 0), Vec3::Zero(), Vec3(1, 0, 0));
  c.add(Vec3(0.5f, 0, 0), Vec3::Zero(), Vec3(1, 0, 0));
  c.add(Vec3(2, 0, 0), Vec3::Zero());  // exactly at the sphere's centre
  swarmsim::Obstacles scene;
  scene.boxes.push_back({Vec3d(-3, -3, -3), Vec3d(-1.5, -1.5, -1.5)});
  const auto spec = swarmsim::GridSpec::covering(Vec3d(-5, -5, -5), Vec3d(5, 5, 5), {40, 40, 40});
  const swarmsim::Grid3<float> sdf = swarmsim::signedDistance(scene, spec);
  swarmsim::orca::Obstacles obstacles;
  obstacles.spheres.push_back({Vec3(2, 0, 0), 1.0f});
  obstacles.sdf = &sdf;
  const float dt = 0.1f;
  for (int s = 0; s < 5; ++s) {
    c.step(p, obstacles, dt);
    INFO("step " << s << ": infeasible " << c.solver.infeasibleCount());
    if (s == 0) CHECK(c.solver.infeasibleCount() > 100);
    for (std::size_t k = 0; k < c.size(); ++k) {
      const Vec3 v = c.velocity(k);
      REQUIRE(std::isfinite(v.x()));
      REQUIRE(std::isfinite(v.y()));
      REQUIRE(std::isfinite(v.z()));
      REQUIRE(v.norm() <= p.maxSpeed * (1.0f + 1e-5f));
    }
  }
  // the coincident pairs were pushed apart
  const Vec3 a = c.position(c.slotOf(300)), b = c.position(c.slotOf(301));
  CHECK((a - b).norm() > 0.1f);
}

TEST_CASE("orca: results are identical for 1 and 2 threads", "[orca]") {
  Params p = paramsFor(0.4f);
  std::mt19937 rng(99);
  Crowd base;
  for (int i = 0; i < 5000; ++i) {
    base.add(randomInBall(rng, 14.0f), randomInBall(rng, 14.0f));
  }
  swarmsim::Obstacles scene;
  scene.boxes.push_back({Vec3d(-12, -12, -12), Vec3d(-6, -6, -6)});
  const auto spec = swarmsim::GridSpec::covering(Vec3d(-15, -15, -15), Vec3d(15, 15, 15), {30, 30, 30});
  const swarmsim::Grid3<float> sdf = swarmsim::signedDistance(scene, spec);
  swarmsim::orca::Obstacles obstacles;
  obstacles.spheres.push_back({Vec3(4, 4, 4), 3.0f});
  obstacles.sdf = &sdf;
  const int saved = swarmsim::threadCount();
  Crowd one = base, two = base;
  for (int s = 0; s < 6; ++s) {
    swarmsim::setThreadCount(1);
    one.step(p, obstacles, 0.1f);
    swarmsim::setThreadCount(2);
    two.step(p, obstacles, 0.1f);
    INFO("step " << s);
    REQUIRE(one.id == two.id);
    for (const auto& pair : {std::make_pair(&one.ox, &two.ox), std::make_pair(&one.oy, &two.oy),
                             std::make_pair(&one.oz, &two.oz), std::make_pair(&one.x, &two.x)}) {
      CHECK(std::memcmp(pair.first->data(), pair.second->data(), pair.first->size() * sizeof(float)) == 0);
    }
    CHECK(one.solver.infeasibleCount() == two.solver.infeasibleCount());
  }
  swarmsim::setThreadCount(saved);
}

TEST_CASE("orca: results are identical on every lane set, with obstacles, coincident and overlapping agents",
          "[orca]") {
  // With AVX2 or AVX-512, solve builds eight agents' half-spaces at once and runs their programs on lanes;
  // without (SWARMSIM_NO_AVX2, SWARMSIM_NO_AVX) one agent at a time. Agents near the sphere or the box have one or
  // two obstacle planes, the others none, so the groups mix counts; coincident agents at rest and overlapping
  // ones give the half-spaces agentPlane redoes.
  Params p = paramsFor(0.4f);
  std::mt19937 rng(7);
  Crowd base;
  for (int i = 0; i < 3000; ++i) {
    base.add(randomInBall(rng, 10.0f), randomInBall(rng, 10.0f), randomInBall(rng, 2.0f));
  }
  for (int i = 0; i < 40; ++i) {  // pairs at one point, at rest; pairs overlapping
    const Vec3 at = randomInBall(rng, 9.0f);
    base.add(at, randomInBall(rng, 10.0f));
    base.add(at, randomInBall(rng, 10.0f));
    base.add(at + randomUnit(rng) * 0.3f, randomInBall(rng, 10.0f), randomInBall(rng, 1.0f));
  }
  swarmsim::Obstacles scene;
  scene.boxes.push_back({Vec3d(-9, -9, -9), Vec3d(-4, -4, -4)});
  const auto spec = swarmsim::GridSpec::covering(Vec3d(-12, -12, -12), Vec3d(12, 12, 12), {24, 24, 24});
  const swarmsim::Grid3<float> sdf = swarmsim::signedDistance(scene, spec);
  swarmsim::orca::Obstacles obstacles;
  obstacles.spheres.push_back({Vec3(3, 3, 3), 2.0f});
  obstacles.spheres.push_back({Vec3(-2, 4, 0), 1.5f, Vec3(0.5f, 0, 0)});
  obstacles.sdf = &sdf;
  const std::vector<std::pair<const char*, const char*>> modes = {{"SWARMSIM_NO_AVX512", nullptr},
                                                                  {"SWARMSIM_NO_AVX512", "1"},
                                                                  {"SWARMSIM_NO_AVX2", "1"},
                                                                  {"SWARMSIM_NO_AVX", "1"}};
  std::vector<Crowd> runs(modes.size(), base);
  for (int s = 0; s < 4; ++s) {
    for (std::size_t m = 0; m < modes.size(); ++m) {
      const swarmsim_test::EnvGuard lanes(modes[m].first, modes[m].second);
      runs[m].step(p, obstacles, 0.1f);
    }
    for (std::size_t m = 1; m < modes.size(); ++m) {
      INFO("step " << s << ", " << modes[m].first << " against the widest lanes");
      REQUIRE(runs[0].id == runs[m].id);
      for (const auto& pair : {std::make_pair(&runs[0].ox, &runs[m].ox), std::make_pair(&runs[0].oy, &runs[m].oy),
                               std::make_pair(&runs[0].oz, &runs[m].oz)}) {
        CHECK(std::memcmp(pair.first->data(), pair.second->data(), pair.first->size() * sizeof(float)) == 0);
      }
      CHECK(runs[0].solver.infeasibleCount() == runs[m].solver.infeasibleCount());
    }
  }
  CHECK(runs[0].solver.infeasibleCount() > 0);
}

TEST_CASE("orca: parameters out of range are rejected", "[orca]") {
  Crowd c;
  c.add(Vec3(0, 0, 0), Vec3(1, 0, 0));
  const Params good = paramsFor(0.5f);
  CHECK_NOTHROW(c.solve(good, {}, 0.1f));
  CHECK_THROWS_AS(c.solve(good, {}, 0.0f), std::invalid_argument);
  Params p = good;
  p.maxSpeed = 0.0f;
  CHECK_THROWS_AS(c.solve(p, {}, 0.1f), std::invalid_argument);
  p = good;
  p.timeHorizon = -1.0f;
  CHECK_THROWS_AS(c.solve(p, {}, 0.1f), std::invalid_argument);
  p = good;
  p.maxNeighbors = -1;
  CHECK_THROWS_AS(c.solve(p, {}, 0.1f), std::invalid_argument);
  p = good;
  p.radius = std::numeric_limits<float>::quiet_NaN();
  CHECK_THROWS_AS(c.solve(p, {}, 0.1f), std::invalid_argument);
}
