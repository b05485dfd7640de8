// UniformGrid: fixed-radius neighbour search against brute force.
//
// The reference is an exhaustive scan over the original points with the same
// float arithmetic the grid documents (dx = p - q in float, d2 = dx*dx + dy*dy
// + dz*dz, included when d2 <= r*r), so the visited sets must match exactly.
#include "spatial/uniform_grid.hpp"

#include <algorithm>
#include <array>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <numeric>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/parallel.hpp"
#include "test_util.hpp"

using swarmsim::UniformGrid;

namespace {

struct Points {
  std::vector<float> x, y, z;
  void add(float a, float b, float c) {
    x.push_back(a);
    y.push_back(b);
    z.push_back(c);
  }
  std::size_t size() const { return x.size(); }
};

struct Query {
  float x, y, z;
};

struct Visit {
  std::uint32_t k;
  float dx, dy, dz, d2;
  bool operator==(const Visit& o) const {
    return k == o.k && dx == o.dx && dy == o.dy && dz == o.dz && d2 == o.d2;
  }
};

void build(UniformGrid& g, const Points& p, float minCell) { g.build(p.x.data(), p.y.data(), p.z.data(), p.size(), minCell); }

std::vector<Visit> visits(const UniformGrid& g, const Query& q, float r) {
  std::vector<Visit> out;
  g.forEachNeighbor(q.x, q.y, q.z, r, [&](std::uint32_t k, float dx, float dy, float dz, float d2) {
    out.push_back({k, dx, dy, dz, d2});
  });
  return out;
}

// original indices of the points within r of q, by exhaustive scan
std::vector<std::uint32_t> bruteForce(const Points& p, const Query& q, float r) {
  const float r2 = r * r;
  std::vector<std::uint32_t> out;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const float dx = p.x[i] - q.x, dy = p.y[i] - q.y, dz = p.z[i] - q.z;
    const float d2 = dx * dx + dy * dy + dz * dz;
    if (d2 <= r2) out.push_back(static_cast<std::uint32_t>(i));
  }
  return out;
}

std::string describe(const Query& q, float r) {
  std::ostringstream s;
  s.precision(9);
  s << "query (" << q.x << ", " << q.y << ", " << q.z << ") r=" << r;
  return s.str();
}

// Compare one query with brute force; returns "" or a description of the first problem.
std::string checkQuery(const UniformGrid& g, const Points& p, const Query& q, float r) {
  const auto v = visits(g, q, r);
  const float r2 = r * r;
  std::vector<std::uint32_t> got;
  for (std::size_t h = 0; h < v.size(); ++h) {
    const Visit& e = v[h];
    if (e.k >= p.size()) return describe(q, r) + ": visited sorted position " + std::to_string(e.k) + " >= n";
    // documented order: cell order, then point index -> increasing sorted position
    if (h > 0 && !(v[h - 1].k < e.k)) {
      return describe(q, r) + ": visits not in increasing sorted position (" + std::to_string(v[h - 1].k) + " then " +
             std::to_string(e.k) + ")";
    }
    const float dx = g.sortedX()[e.k] - q.x, dy = g.sortedY()[e.k] - q.y, dz = g.sortedZ()[e.k] - q.z;
    if (e.dx != dx || e.dy != dy || e.dz != dz || e.d2 != dx * dx + dy * dy + dz * dz) {
      return describe(q, r) + ": wrong offset/distance passed for sorted position " + std::to_string(e.k);
    }
    if (!(e.d2 <= r2)) return describe(q, r) + ": visited a point outside the radius";
    got.push_back(g.order()[e.k]);
  }
  std::sort(got.begin(), got.end());
  const auto want = bruteForce(p, q, r);
  if (got != want) {
    std::vector<std::uint32_t> missing, extra;
    std::set_difference(want.begin(), want.end(), got.begin(), got.end(), std::back_inserter(missing));
    std::set_difference(got.begin(), got.end(), want.begin(), want.end(), std::back_inserter(extra));
    std::ostringstream s;
    s << describe(q, r) << ": grid found " << got.size() << ", brute force " << want.size() << "; missing "
      << missing.size() << " (first: " << (missing.empty() ? -1 : static_cast<long>(missing[0])) << "), extra "
      << extra.size();
    if (!missing.empty()) {
      const auto i = missing[0];
      s.precision(9);
      s << "; missing point (" << p.x[i] << ", " << p.y[i] << ", " << p.z[i] << ")";
    }
    return s.str();
  }
  return "";
}

// Run every (query, radius) pair; returns the number of failing queries and the first failure.
struct CheckSummary {
  std::size_t queries = 0, failures = 0, visited = 0;
  std::string first;
};

CheckSummary checkAll(const UniformGrid& g, const Points& p, const std::vector<Query>& qs, const std::vector<float>& radii) {
  CheckSummary s;
  for (float r : radii) {
    for (const Query& q : qs) {
      ++s.queries;
      const std::string problem = checkQuery(g, p, q, r);
      if (!problem.empty()) {
        if (s.failures == 0) s.first = problem;
        ++s.failures;
      }
      s.visited += bruteForce(p, q, r).size();
    }
  }
  return s;
}

std::vector<Query> pointsAsQueries(const Points& p) {
  std::vector<Query> qs;
  for (std::size_t i = 0; i < p.size(); ++i) qs.push_back({p.x[i], p.y[i], p.z[i]});
  return qs;
}

Points randomPoints(std::mt19937& rng, std::size_t n, float lo, float hi) {
  std::uniform_real_distribution<float> u(lo, hi);
  Points p;
  for (std::size_t i = 0; i < n; ++i) {
    const float a = u(rng), b = u(rng), c = u(rng);
    p.add(a, b, c);
  }
  return p;
}

void requirePermutationAndSorted(const UniformGrid& g, const Points& p) {
  REQUIRE(g.size() == p.size());
  REQUIRE(g.order().size() == p.size());
  std::vector<std::uint32_t> sorted = g.order();
  std::sort(sorted.begin(), sorted.end());
  std::vector<std::uint32_t> iota(p.size());
  std::iota(iota.begin(), iota.end(), 0u);
  CHECK(sorted == iota);  // order() is a permutation of 0..n-1
  REQUIRE(g.sortedX().size() == p.size() + UniformGrid::kSortedPad);  // whole-lane padding
  REQUIRE(g.sortedY().size() == p.size() + UniformGrid::kSortedPad);
  REQUIRE(g.sortedZ().size() == p.size() + UniformGrid::kSortedPad);
  std::size_t bad = 0;
  for (std::size_t k = 0; k < p.size(); ++k) {
    const std::uint32_t i = g.order()[k];
    if (i >= p.size() || g.sortedX()[k] != p.x[i] || g.sortedY()[k] != p.y[i] || g.sortedZ()[k] != p.z[i]) ++bad;
  }
  CHECK(bad == 0);
}

// Lattices (every point twice) placed exactly on multiples of the cell edge
// the grid picks, so points sit on cell borders up to float rounding; many
// sizes and origins, because whether a border point rounds into the lower or
// upper cell depends on them. Radii are given in units of minCell or, with
// inCellEdges, of the actual cell edge of each axis.
CheckSummary checkBorderLattices(const std::vector<float>& radiusFactors, bool inCellEdges) {
  std::mt19937 rng(77);
  std::uniform_real_distribution<float> uCell(0.05f, 1.0f), uOrigin(-10.0f, 10.0f), uExt(4.0f, 6.5f);
  CheckSummary total;
  for (int trial = 0; trial < 40; ++trial) {
    const float minCell = uCell(rng);
    const float o[3] = {uOrigin(rng), uOrigin(rng), uOrigin(rng)};
    // learn the cell edges the grid picks for this bounding box
    Points box;
    box.add(o[0], o[1], o[2]);
    box.add(o[0] + uExt(rng) * minCell, o[1] + uExt(rng) * minCell, o[2] + uExt(rng) * minCell);
    for (int i = 0; i < 400; ++i) box.add(o[0], o[1], o[2]);  // enough points that the grid is not coarsened
    UniformGrid probe;
    build(probe, box, minCell);
    const float c[3] = {probe.cellSize(0), probe.cellSize(1), probe.cellSize(2)};
    const int d[3] = {probe.dim(0), probe.dim(1), probe.dim(2)};
    REQUIRE(d[0] > 2);
    REQUIRE(d[1] > 2);
    REQUIRE(d[2] > 2);
    Points p;
    for (int i = 0; i <= d[0]; ++i)
      for (int j = 0; j <= d[1]; ++j)
        for (int k = 0; k <= d[2]; ++k)
          for (int rep = 0; rep < 2; ++rep)
            p.add(o[0] + static_cast<float>(i) * c[0], o[1] + static_cast<float>(j) * c[1],
                  o[2] + static_cast<float>(k) * c[2]);
    UniformGrid g;
    build(g, p, minCell);
    requirePermutationAndSorted(g, p);
    for (int a = 0; a < 3; ++a) CHECK(g.dim(a) == d[a]);  // same box, same grid: the lattice is on its borders
    std::vector<Query> qs = pointsAsQueries(p);
    for (int i = -1; i <= d[0] + 1; ++i) {
      qs.push_back({o[0] + static_cast<float>(i) * c[0], o[1] + 0.5f * c[1], o[2] + static_cast<float>(i) * c[2]});
    }
    std::vector<float> radii;
    for (float f : radiusFactors) {
      if (inCellEdges) {
        for (float e : c) radii.push_back(f * e);
      } else {
        radii.push_back(f * minCell);
      }
    }
    const CheckSummary s = checkAll(g, p, qs, radii);
    if (s.failures > 0 && total.failures == 0) {
      std::ostringstream msg;
      msg.precision(9);
      msg << "minCell " << minCell << ", cell " << c[0] << " x " << c[1] << " x " << c[2] << ": " << s.first;
      total.first = msg.str();
    }
    total.failures += s.failures;
    total.queries += s.queries;
    total.visited += s.visited;
  }
  return total;
}

// restores the OpenMP thread count when a test ends
struct ThreadCountGuard {
  int saved = swarmsim::threadCount();
  ~ThreadCountGuard() { swarmsim::setThreadCount(saved); }
};

}  // namespace

TEST_CASE("UniformGrid random points match brute force", "[grid]") {
  const float cell = 0.5f;
  // radii equal to, smaller than and larger than the cell size (incl. near-integer multiples)
  const std::vector<float> radii = {cell, 0.5f * cell, 0.37f * cell, 0.999f * cell, 1.001f * cell,
                                    1.7f * cell, 2.0f * cell, 3.0f * cell, 0.0f};
  for (unsigned seed : {1u, 2u, 3u, 4u, 5u}) {
    DYNAMIC_SECTION("seed " << seed) {
      std::mt19937 rng(seed);
      // a box that is not a multiple of the cell size on any axis
      Points p;
      {
        std::uniform_real_distribution<float> ux(-2.1f, 5.3f), uy(0.0f, 3.7f), uz(10.0f, 12.45f);
        for (int i = 0; i < 1200; ++i) {
          const float a = ux(rng), b = uy(rng), c = uz(rng);
          p.add(a, b, c);
        }
      }
      UniformGrid g;
      build(g, p, cell);
      requirePermutationAndSorted(g, p);
      for (int a = 0; a < 3; ++a) CHECK(g.cellSize(a) >= cell);  // documented: edge >= minCell

      std::vector<Query> qs = pointsAsQueries(p);
      // random queries, many of them outside the points' bounding box
      std::uniform_real_distribution<float> qx(-4.0f, 7.0f), qy(-2.0f, 5.5f), qz(8.0f, 14.0f);
      for (int i = 0; i < 300; ++i) {
        const float a = qx(rng), b = qy(rng), c = qz(rng);
        qs.push_back({a, b, c});
      }
      const CheckSummary s = checkAll(g, p, qs, radii);
      INFO("first failure: " << s.first);
      CHECK(s.failures == 0);
      CHECK(s.visited > s.queries);  // the test is not vacuous: queries do find neighbours
    }
  }
}

TEST_CASE("UniformGrid lattice with spacing equal to the cell size", "[grid]") {
  SECTION("spacing equal to minCell") {
    for (float h : {0.25f, 0.1f, 1.0f / 3.0f}) {
      Points p;
      for (int i = 0; i < 9; ++i)
        for (int j = 0; j < 9; ++j)
          for (int k = 0; k < 9; ++k) p.add(static_cast<float>(i) * h, static_cast<float>(j) * h, static_cast<float>(k) * h);
      UniformGrid g;
      build(g, p, h);
      requirePermutationAndSorted(g, p);
      std::vector<Query> qs = pointsAsQueries(p);
      // cell corners / half-way points and points outside the box
      for (int i = -2; i <= 10; ++i) {
        const float t = (static_cast<float>(i) + 0.5f) * h;
        qs.push_back({t, t, t});
        qs.push_back({t, 4.0f * h, -0.5f * h});
        qs.push_back({-1.0f * h, t, 9.0f * h});
      }
      const CheckSummary s = checkAll(g, p, qs, {h, 0.5f * h, 2.0f * h, 1.5f * h, h * std::sqrt(2.0f), h * std::sqrt(3.0f)});
      INFO("spacing " << h << "; first failure: " << s.first);
      CHECK(s.failures == 0);
    }
  }
  SECTION("neighbour counts worked out by hand (exact spacing 0.25)") {
    const float h = 0.25f;  // exact in binary: lattice distances are exact
    Points p;
    for (int i = 0; i < 9; ++i)
      for (int j = 0; j < 9; ++j)
        for (int k = 0; k < 9; ++k) p.add(static_cast<float>(i) * h, static_cast<float>(j) * h, static_cast<float>(k) * h);
    UniformGrid g;
    build(g, p, h);
    const auto count = [&](Query q, float r) { return visits(g, q, r).size(); };
    // interior point, r = spacing: itself + 6 face neighbours at exactly r (d2 == r2 is included)
    CHECK(count({1.0f, 1.0f, 1.0f}, h) == 7u);
    // corner point: itself + 3
    CHECK(count({0.0f, 0.0f, 0.0f}, h) == 4u);
    // interior, r = 2 spacings: 1 + 6 (d=1) + 12 (sqrt 2) + 8 (sqrt 3) + 6 (d=2) = 33
    CHECK(count({1.0f, 1.0f, 1.0f}, 2.0f * h) == 33u);
    // r = 0: only the point itself
    CHECK(count({0.5f, 0.75f, 1.0f}, 0.0f) == 1u);
    // cell-centre of 8 lattice points: the 8 corners at sqrt(3)/2 spacing
    CHECK(count({0.625f, 0.625f, 0.625f}, 0.9f * h) == 8u);
  }
  SECTION("spacing equal to the grid's actual cell size: points on cell borders") {
    const CheckSummary s = checkBorderLattices({1.0f, 0.5f, 0.75f, 1.5f, 2.5f}, false);
    INFO("first failure: " << s.first);
    CHECK(s.queries > 10000u);
    CHECK(s.failures == 0u);
  }
}

// LIB BUG (lib/spatial/uniform_grid.hpp, forEachNeighbor: `span =
// floor(r * inv_[a]) + 1`; the same formula is in UniformGrid::gatherCell in
// uniform_grid.cpp): for a radius equal to (a multiple of) the grid's actual
// cell edge, r * inv_ rounds to just below the integer (e.g. 0.99999994), so
// span is one cell too small, while the cell coordinates of a query and of a
// point one edge away are rounded separately and can differ by span + 1: a
// point at distance <= r is missed. The header promises "Any r works".
// Smallest reproduction (all numbers exact floats): minCell = 0.545398235,
// build on x = {-7.74356365, -7.74356365 + 5.3 * minCell} -> cellSize(0) =
// c = 0.578122139; then build on the 1-D lattice x_i = -7.74356365 + i * c
// (i = 0..dim(0)) and query x_2 with r = c: 2 points found, brute force 3
// (x_3 is missed). The boids model only queries with r = minCell, where the
// 1e-5 cell-edge margin hides this. Tagged  until fixed: remove
// the tag when the grid finds these points (the test then passes as written).
TEST_CASE("UniformGrid query radius equal to the actual cell size", "[grid]") {
  SECTION("the smallest reproduction") {
    const float minCell = 0.545398235f, o = -7.74356365f;
    Points box;
    box.add(o, 0.0f, 0.0f);
    box.add(o + 5.3f * minCell, 0.0f, 0.0f);
    UniformGrid probe;
    build(probe, box, minCell);
    const float c = probe.cellSize(0);
    Points p;
    for (int i = 0; i <= probe.dim(0); ++i) p.add(o + static_cast<float>(i) * c, 0.0f, 0.0f);
    UniformGrid g;
    build(g, p, minCell);
    const CheckSummary s = checkAll(g, p, pointsAsQueries(p), {c});
    INFO("c = " << c << "; first failure: " << s.first);
    CHECK(s.failures == 0u);
  }
  SECTION("lattices on cell borders, r = 1 and 2 cell edges") {
    const CheckSummary s = checkBorderLattices({1.0f, 2.0f}, true);
    INFO("first failure: " << s.first);
    CHECK(s.failures == 0u);
  }
}

TEST_CASE("UniformGrid coincident points", "[grid]") {
  std::mt19937 rng(11);
  Points base = randomPoints(rng, 200, 0.0f, 3.0f);
  Points p;
  // every base point 4 times, interleaved so copies are far apart in index
  for (int rep = 0; rep < 4; ++rep)
    for (std::size_t i = 0; i < base.size(); ++i) p.add(base.x[i], base.y[i], base.z[i]);
  // and 30 points all at one place
  for (int i = 0; i < 30; ++i) p.add(1.5f, 1.5f, 1.5f);
  UniformGrid g;
  build(g, p, 0.4f);
  requirePermutationAndSorted(g, p);
  const CheckSummary s = checkAll(g, p, pointsAsQueries(p), {0.4f, 0.0f, 0.15f, 1.0f});
  INFO("first failure: " << s.first);
  CHECK(s.failures == 0);

  // r = 0 finds exactly the copies
  CHECK(visits(g, {base.x[7], base.y[7], base.z[7]}, 0.0f).size() == 4u);
  CHECK(visits(g, {1.5f, 1.5f, 1.5f}, 0.0f).size() >= 30u);
  // copies share a cell, and within a cell points are in index order
  for (std::size_t i = 0; i < base.size(); ++i) {
    std::vector<std::size_t> pos;
    for (std::size_t k = 0; k < p.size(); ++k) {
      const std::uint32_t j = g.order()[k];
      if (p.x[j] == base.x[i] && p.y[j] == base.y[i] && p.z[j] == base.z[i]) pos.push_back(k);
    }
    REQUIRE(pos.size() == 4u);
    for (std::size_t t = 1; t < pos.size(); ++t) {
      CHECK(g.order()[pos[t - 1]] < g.order()[pos[t]]);
    }
  }
}

TEST_CASE("UniformGrid far-away outliers coarsen the grid", "[grid]") {
  std::mt19937 rng(5);
  const std::size_t n = 1000;
  Points p = randomPoints(rng, n, 0.0f, 4.0f);
  p.add(1000.0f, 0.0f, 0.0f);
  p.add(0.0f, -1000.0f, 0.0f);
  p.add(0.0f, 0.0f, 500.0f);
  p.add(-300.0f, 400.0f, 800.0f);
  p.add(1000.0f, 0.5f, 0.0f);  // a neighbour of the first outlier at distance 0.5
  const float minCell = 0.25f;
  UniformGrid g;
  build(g, p, minCell);
  requirePermutationAndSorted(g, p);
  const double cells = static_cast<double>(g.dim(0)) * g.dim(1) * g.dim(2);
  // documented: far-flung points only make cells coarser; the number of cells
  // is capped at a few per point (the uncoarsened grid would have ~10^13 cells)
  CHECK(cells <= 4.0 * static_cast<double>(p.size()) + 64.0);
  for (int a = 0; a < 3; ++a) CHECK(g.cellSize(a) >= minCell);
  CHECK(std::max({g.cellSize(0), g.cellSize(1), g.cellSize(2)}) > 10.0f * minCell);

  std::vector<Query> qs = pointsAsQueries(p);
  qs.push_back({1000.2f, 0.1f, 0.0f});
  qs.push_back({-2000.0f, 0.0f, 0.0f});
  qs.push_back({2.0f, 2.0f, 2.0f});
  const CheckSummary s = checkAll(g, p, qs, {minCell, 0.1f, 1.0f, 50.0f});
  INFO("first failure: " << s.first);
  CHECK(s.failures == 0);
  // a query reaching every point from far away
  CHECK(visits(g, {0.0f, 0.0f, 0.0f}, 2000.0f).size() == p.size());
  // the two neighbouring outliers see each other
  CHECK(visits(g, {1000.0f, 0.0f, 0.0f}, 0.5f).size() == 2u);
}

TEST_CASE("UniformGrid queries outside the bounding box", "[grid]") {
  std::mt19937 rng(21);
  Points p = randomPoints(rng, 400, 0.0f, 1.0f);
  UniformGrid g;
  build(g, p, 0.1f);
  std::vector<Query> qs = {{-0.05f, 0.5f, 0.5f}, {-0.5f, 0.5f, 0.5f}, {1.5f, 1.5f, 1.5f}, {1.02f, 0.3f, 0.99f},
                           {0.5f, -0.3f, 1.2f},  {10.0f, 10.0f, 10.0f}, {-5.0f, -5.0f, -5.0f}, {0.5f, 0.5f, 3.0f}};
  std::uniform_real_distribution<float> u(-1.5f, 2.5f);
  for (int i = 0; i < 500; ++i) {
    const float a = u(rng), b = u(rng), c = u(rng);
    qs.push_back({a, b, c});
  }
  const CheckSummary s = checkAll(g, p, qs, {0.1f, 0.05f, 0.6f, 0.9f, 1.3f});
  INFO("first failure: " << s.first);
  CHECK(s.failures == 0);
  CHECK(visits(g, {10.0f, 10.0f, 10.0f}, 0.5f).empty());
  CHECK(visits(g, {-5.0f, -5.0f, -5.0f}, 20.0f).size() == p.size());
  // (-0.5, 0.5, 0.5) with r = 0.6 reaches the slab x < 0.1 only
  for (const Visit& v : visits(g, {-0.5f, 0.5f, 0.5f}, 0.6f)) CHECK(g.sortedX()[v.k] <= 0.1f);
}

TEST_CASE("UniformGrid runs cut to the ball hold the same points within r, in the same order, and fewer others",
          "[grid]") {
  // points in a box (some queries outside it, some on cell faces), cells of several fractions of r; the hits
  // of forEachRunInBall's runs against forEachRun's: the same sorted positions in the same order
  std::mt19937 rng(33);
  Points p = randomPoints(rng, 3000, 0.0f, 2.0f);
  for (int i = 0; i < 64; ++i) p.add(0.25f * static_cast<float>(i % 8), 0.5f, 0.25f * static_cast<float>(i / 8));
  std::uniform_real_distribution<float> u(-0.7f, 2.7f);
  std::size_t hits = 0, readAll = 0, readBall = 0;
  for (const float cell : {0.05f, 0.1f, 0.25f}) {
    UniformGrid g;
    build(g, p, cell);
    for (const float r : {0.1f, 0.2f, 0.25f, 0.5f, 0.63f}) {
      std::vector<Query> qs = pointsAsQueries(p);
      for (int i = 0; i < 200; ++i) {
        const float a = u(rng), b = u(rng), c = u(rng);
        qs.push_back({a, b, c});
      }
      qs.push_back({0.25f, 0.5f, 0.25f});  // on cell faces
      for (const Query& q : qs) {
        const auto collect = [&](bool ball, std::size_t& read) {
          std::vector<std::uint32_t> in;
          const auto f = [&](std::uint32_t b, std::uint32_t e) {
            read += e - b;
            for (std::uint32_t k = b; k < e; ++k) {
              const float dx = g.sortedX()[k] - q.x, dy = g.sortedY()[k] - q.y, dz = g.sortedZ()[k] - q.z;
              if (dx * dx + dy * dy + dz * dz <= r * r) in.push_back(k);
            }
          };
          if (ball) {
            g.forEachRunInBall(q.x, q.y, q.z, r, f);
          } else {
            g.forEachRun(q.x, q.y, q.z, r, f);
          }
          return in;
        };
        std::size_t a = 0, b = 0;
        const auto all = collect(false, a), cut = collect(true, b);
        REQUIRE(cut == all);
        CHECK(b <= a);
        hits += all.size();
        readAll += a;
        readBall += b;
      }
    }
  }
  CHECK(hits > 100000);  // not vacuous
  // the cut runs read clearly fewer points (cells of r / 2: about two thirds)
  CHECK(static_cast<double>(readBall) < 0.85 * static_cast<double>(readAll));
}

TEST_CASE("UniformGrid visit order is deterministic", "[grid]") {
  ThreadCountGuard guard;
  std::mt19937 rng(99);
  Points p = randomPoints(rng, 3000, -1.0f, 2.0f);
  for (int i = 0; i < 20; ++i) p.add(0.25f, 0.25f, 0.25f);  // coincident points
  p.add(40.0f, -30.0f, 12.0f);                                // an outlier
  std::vector<Query> qs;
  for (std::size_t i = 0; i < p.size(); i += 7) qs.push_back({p.x[i], p.y[i], p.z[i]});
  qs.push_back({0.25f, 0.25f, 0.25f});

  const auto record = [&](const UniformGrid& g) {
    std::vector<std::vector<Visit>> all;
    for (const Query& q : qs)
      for (float r : {0.2f, 0.45f}) all.push_back(visits(g, q, r));
    return all;
  };
  swarmsim::setThreadCount(1);
  UniformGrid a;
  build(a, p, 0.2f);
  const auto ra = record(a);
  swarmsim::setThreadCount(2);
  UniformGrid b;
  build(b, p, 0.2f);
  const auto rb = record(b);
  // rebuilding a used grid from different points and back again
  Points other = randomPoints(rng, 500, 5.0f, 9.0f);
  build(b, other, 0.3f);
  build(b, p, 0.2f);
  const auto rc = record(b);

  CHECK(a.order() == b.order());
  CHECK(ra == rb);
  CHECK(ra == rc);
  std::size_t total = 0;
  for (const auto& v : ra) total += v.size();
  CHECK(total > qs.size());
}

TEST_CASE("UniformGrid order and gather", "[grid]") {
  std::mt19937 rng(3);
  Points p = randomPoints(rng, 777, -5.0f, 5.0f);
  p.add(p.x[3], p.y[3], p.z[3]);
  p.add(300.0f, 0.0f, 0.0f);
  UniformGrid g;
  build(g, p, 0.7f);
  requirePermutationAndSorted(g, p);
  std::vector<float> src(p.size()), dst;
  for (std::size_t i = 0; i < src.size(); ++i) src[i] = static_cast<float>(i) * 0.5f - 3.0f;
  g.gather(src, dst);
  REQUIRE(dst.size() == p.size());
  std::size_t bad = 0;
  for (std::size_t k = 0; k < dst.size(); ++k) bad += dst[k] == src[g.order()[k]] ? 0 : 1;
  CHECK(bad == 0);
}

TEST_CASE("UniformGrid counting sort: points in any order or in last build's cell order, any thread count, give the "
          "stable cell order", "[grid]") {
  // the build sorts by one of two ways: per-thread cursors over each thread's range of cells when the points
  // come nearly in cell order (as every model keeps its state), else on one thread; both must give the
  // order of a plain stable sort by cell, and so must every thread count
  std::mt19937 rng(21);
  Points p = randomPoints(rng, 20000, -4.0f, 4.0f);
  for (int i = 0; i < 300; ++i) p.add(p.x[static_cast<std::size_t>(i)], p.y[static_cast<std::size_t>(i)], 1.0f);
  const auto check = [](const UniformGrid& g, const Points& q) {
    REQUIRE(g.order().size() == q.size());
    std::vector<std::uint32_t> seen = g.order();
    std::sort(seen.begin(), seen.end());
    std::size_t missing = 0, elsewhere = 0, unstable = 0;
    for (std::size_t i = 0; i < seen.size(); ++i) missing += seen[i] == i ? 0 : 1;  // a permutation
    for (std::size_t c = 0; c < g.cellCount(); ++c) {
      for (std::uint32_t k = g.cellBegin(c); k < g.cellEnd(c); ++k) {
        const std::uint32_t i = g.order()[k];
        int lo[3], hi[3];
        g.cellRange(q.x[i], q.y[i], q.z[i], 0.0f, lo, hi);  // the point's own cell
        const std::size_t own = (static_cast<std::size_t>(lo[2]) * g.dim(1) + lo[1]) * g.dim(0) + lo[0];
        elsewhere += own == c ? 0 : 1;
        if (k > g.cellBegin(c)) unstable += g.order()[k - 1] < i ? 0 : 1;  // in point index order
      }
    }
    CHECK(missing == 0);
    CHECK(elsewhere == 0);
    CHECK(unstable == 0);
  };
  // the points in the cell order of a first build (the case of a model's state from the second step on)
  const auto inCellOrder = [](const UniformGrid& g, const Points& q) {
    Points s;
    for (std::size_t k = 0; k < q.size(); ++k) {
      const std::uint32_t i = g.order()[k];
      s.add(q.x[i], q.y[i], q.z[i]);
    }
    return s;
  };
  std::vector<std::vector<std::uint32_t>> orders;
  const ThreadCountGuard restore;
  for (const int threads : {1, 2, 3}) {
    swarmsim::setThreadCount(threads);
    UniformGrid g;
    build(g, p, 0.2f);  // any order (a random cloud)
    check(g, p);
    requirePermutationAndSorted(g, p);
    orders.push_back(g.order());
    const Points sorted = inCellOrder(g, p);
    UniformGrid h;
    h.build(sorted.x.data(), sorted.y.data(), sorted.z.data(), sorted.size(), 0.2f, 2.0, false);
    check(h, sorted);
    CHECK(h.sortedX().empty());  // no copies asked for
    std::size_t moved = 0;  // points already in cell order stay where they are
    for (std::size_t k = 0; k < sorted.size(); ++k) moved += h.order()[k] == k ? 0 : 1;
    CHECK(moved == 0);
  }
  CHECK(orders[0] == orders[1]);
  CHECK(orders[0] == orders[2]);
}

TEST_CASE("UniformGrid buildFromCells: the caller's cells in a stable counting sort, any thread count", "[grid]") {
  // (the field model's same_cell bins: cells found by the caller, here random in a 7 x 5 x 3 grid, and a run of
  // each in the cell order of a first build, as a model's state comes from its second step on)
  std::mt19937 rng(5);
  const int dims[3] = {7, 5, 3};
  const double origin[3] = {0, 0, 0}, edge[3] = {1, 1, 1};
  const std::size_t n = 5000, ncell = 7 * 5 * 3;
  std::vector<std::uint32_t> cells(n);
  std::uniform_int_distribution<std::uint32_t> pick(0, ncell - 1);
  for (auto& c : cells) c = pick(rng);
  // the reference: a stable sort of the indices by cell
  std::vector<std::uint32_t> expected(n);
  for (std::size_t i = 0; i < n; ++i) expected[i] = static_cast<std::uint32_t>(i);
  std::stable_sort(expected.begin(), expected.end(),
                   [&](std::uint32_t a, std::uint32_t b) { return cells[a] < cells[b]; });
  const ThreadCountGuard restore;
  for (const int threads : {1, 2, 3}) {
    swarmsim::setThreadCount(threads);
    UniformGrid g;
    std::vector<std::uint32_t> given = cells;
    g.buildFromCells(given, n, dims, origin, edge);
    CHECK(g.order() == expected);
    REQUIRE(g.cellCount() == ncell);
    std::size_t wrong = 0;
    for (std::size_t c = 0; c < ncell; ++c) {
      for (std::uint32_t k = g.cellBegin(c); k < g.cellEnd(c); ++k) wrong += cells[g.order()[k]] == c ? 0 : 1;
    }
    CHECK(wrong == 0);
    CHECK(g.cellEnd(ncell - 1) == n);
    CHECK(g.sortedX().empty());
    // the same cells in that order: every point stays where it is
    std::vector<std::uint32_t> again(n);
    for (std::size_t k = 0; k < n; ++k) again[k] = cells[g.order()[k]];
    g.buildFromCells(again, n, dims, origin, edge);
    std::size_t moved = 0;
    for (std::size_t k = 0; k < n; ++k) moved += g.order()[k] == k ? 0 : 1;
    CHECK(moved == 0);
  }
  UniformGrid g;
  std::vector<std::uint32_t> beyond = {0, 3, static_cast<std::uint32_t>(ncell)};
  CHECK_THROWS_AS(g.buildFromCells(beyond, 3, dims, origin, edge), std::invalid_argument);
  std::vector<std::uint32_t> few = {0};
  CHECK_THROWS_AS(g.buildFromCells(few, 3, dims, origin, edge), std::invalid_argument);
}

TEST_CASE("UniformGrid small and invalid inputs", "[grid]") {
  UniformGrid g;
  Points empty;
  build(g, empty, 1.0f);
  CHECK(g.size() == 0u);
  CHECK(visits(g, {0.0f, 0.0f, 0.0f}, 100.0f).empty());

  Points one;
  one.add(1.0f, 2.0f, 3.0f);
  build(g, one, 1.0f);
  CHECK(visits(g, {1.0f, 2.0f, 3.0f}, 0.0f).size() == 1u);
  CHECK(visits(g, {1.0f, 2.0f, 4.0f}, 1.0f).size() == 1u);
  CHECK(visits(g, {1.0f, 2.0f, 4.5f}, 1.0f).empty());

  CHECK_THROWS_AS(build(g, one, 0.0f), std::invalid_argument);
  CHECK_THROWS_AS(build(g, one, -1.0f), std::invalid_argument);
  Points inf;
  inf.add(0.0f, std::numeric_limits<float>::infinity(), 0.0f);
  CHECK_THROWS(build(g, inf, 1.0f));
}

// LIB BUG (lib/spatial/uniform_grid.cpp, UniformGrid::build, the bounding-box
// loop with `reduction(min : l) reduction(max : h)` and the isfinite check after
// it): build() means to throw "non-finite agent position", and does for Inf,
// but std::min/std::max skip a NaN (every comparison with NaN is false), so the
// box stays finite, no exception is thrown, and the NaN point is silently
// binned into cell 0 (cellCoord maps NaN to 0). A NaN agent then never finds
// neighbours and the error spreads unreported. Tagged  until
// fixed: remove the tag when build() rejects NaN (the test then passes as written).
TEST_CASE("UniformGrid rejects NaN positions", "[grid]") {
  // build() throws "non-finite agent position" for Inf; a NaN coordinate must
  // be rejected the same way (it would otherwise be binned into cell 0).
  UniformGrid g;
  Points bad;
  bad.add(0.0f, 0.0f, 0.0f);
  bad.add(std::numeric_limits<float>::quiet_NaN(), 0.0f, 0.0f);
  bad.add(1.0f, 1.0f, 1.0f);
  CHECK_THROWS_AS(build(g, bad, 1.0f), std::runtime_error);
}

TEST_CASE("UniformGrid rejects a NaN among many points, on every axis", "[grid]") {
  // (enough points for the lanes' box, eight at a time, and a NaN in the middle of an eight)
  for (int axis = 0; axis < 3; ++axis) {
    Points p;
    std::mt19937 gen(5);
    std::uniform_real_distribution<float> u(-2.0f, 2.0f);
    for (int i = 0; i < 100; ++i) p.add(u(gen), u(gen), u(gen));
    (axis == 0 ? p.x : axis == 1 ? p.y : p.z)[37] = std::numeric_limits<float>::quiet_NaN();
    UniformGrid g;
    INFO("axis " << axis);
    CHECK_THROWS_AS(build(g, p, 0.5f), std::runtime_error);
  }
}

TEST_CASE("growBox: the points' box as std::min and std::max give it, any lane set, NaNs flagged and left out",
          "[grid]") {
  std::mt19937 gen(3);
  std::uniform_real_distribution<float> u(-4.0f, 6.0f);
  Points p;
  for (int i = 0; i < 37; ++i) p.add(u(gen), u(gen), u(gen));
  // signed zeros as the smallest x, -0 first and +0 eight and sixteen points on (the same lane of every lane
  // set): std::min keeps the -0 it met first, as the lanes must
  for (float& x : p.x) x = std::abs(x) + 0.5f;
  p.x[5] = -0.0f;
  p.x[13] = 0.0f;
  p.x[21] = 0.0f;
  std::array<float, 6> want = {1e30f, 1e30f, 1e30f, -1e30f, -1e30f, -1e30f};
  for (std::size_t i = 0; i < p.size(); ++i) {
    const float v[3] = {p.x[i], p.y[i], p.z[i]};
    for (int a = 0; a < 3; ++a) {
      want[a] = std::min(want[a], v[a]);
      want[3 + a] = std::max(want[3 + a], v[a]);
    }
  }
  for (const auto lanes : {swarmsim::LaneSet::kSse, swarmsim::laneSet()}) {
    INFO("lanes " << static_cast<int>(lanes));
    std::array<float, 6> box = {1e30f, 1e30f, 1e30f, -1e30f, -1e30f, -1e30f};
    CHECK(swarmsim::growBox(p.x.data(), p.y.data(), p.z.data(), p.size(), box, lanes));
    CHECK(std::memcmp(box.data(), want.data(), sizeof box) == 0);
    // a NaN, in an eight and in the tail: flagged, and the box is that of the other points
    for (const std::size_t at : {std::size_t{3}, std::size_t{35}}) {
      Points q = p;
      q.y[at] = std::numeric_limits<float>::quiet_NaN();
      std::array<float, 6> b = {1e30f, 1e30f, 1e30f, -1e30f, -1e30f, -1e30f};
      CHECK_FALSE(swarmsim::growBox(q.x.data(), q.y.data(), q.z.data(), q.size(), b, lanes));
      CHECK(std::isfinite(b[1]));
      CHECK(std::isfinite(b[4]));
    }
  }
}

TEST_CASE("UniformGrid: the same box, cells and order with and without AVX", "[grid]") {
  Points p;
  std::mt19937 gen(9);
  std::uniform_real_distribution<float> u(-3.0f, 5.0f);
  for (int i = 0; i < 2003; ++i) p.add(u(gen), u(gen) * 0.5f, u(gen) * 2.0f);
  p.add(-0.0f, 0.0f, 0.0f);  // (a signed zero among them)
  const auto grid = [&](const char* noAvx) {
    const swarmsim_test::EnvGuard lanes("SWARMSIM_NO_AVX", noAvx);
    UniformGrid g;
    build(g, p, 0.37f);
    std::vector<std::uint32_t> out(g.order().begin(), g.order().end());
    for (std::size_t c = 0; c <= g.cellCount(); ++c) out.push_back(c < g.cellCount() ? g.cellBegin(c) : 0u);
    for (int a = 0; a < 3; ++a) out.push_back(static_cast<std::uint32_t>(g.dim(a)));
    return out;
  };
  const auto scalar = grid("1"), lanes = grid(nullptr);
  CHECK(scalar.size() > p.size() + 100);  // (cells as well as the order)
  CHECK(scalar == lanes);
}

namespace {

// gatherCell + CellBlock::filter (the batched per-cell search the boids model
// uses) against brute force, for every point of every cell as the query
CheckSummary checkCellBlocks(const UniformGrid& g, const Points& p, float r) {
  CheckSummary s;
  swarmsim::CellBlock block;
  const float r2 = r * r;
  for (std::size_t c = 0; c < g.cellCount(); ++c) {
    const std::uint32_t a0 = g.cellBegin(c), a1 = g.cellEnd(c);
    if (a0 == a1) continue;
    g.gatherCell(c, r, block);
    for (std::uint32_t k = a0; k < a1; ++k) {
      const Query q{g.sortedX()[k], g.sortedY()[k], g.sortedZ()[k]};
      const std::size_t hits = block.filter(q.x, q.y, q.z, r);
      ++s.queries;
      std::vector<std::uint32_t> got;
      std::string problem;
      for (std::size_t h = 0; h < hits && problem.empty(); ++h) {
        const std::uint32_t b = block.hits[h];
        if (h > 0 && !(block.hits[h - 1] < b)) problem = "hits not in increasing order";
        if (b >= block.size) problem = "hit outside the block";
        if (!problem.empty()) break;
        const std::uint32_t j = block.index[b];
        const float dx = g.sortedX()[j] - q.x, dy = g.sortedY()[j] - q.y, dz = g.sortedZ()[j] - q.z;
        if (block.x[b] != g.sortedX()[j] || block.y[b] != g.sortedY()[j] || block.z[b] != g.sortedZ()[j]) {
          problem = "block position differs from the sorted position";
        } else if (block.d2[b] != dx * dx + dy * dy + dz * dz || !(block.d2[b] <= r2)) {
          problem = "wrong squared distance";
        }
        got.push_back(g.order()[j]);
      }
      std::sort(got.begin(), got.end());
      if (problem.empty() && got != bruteForce(p, q, r)) {
        problem = "found " + std::to_string(got.size()) + " neighbours, brute force " +
                  std::to_string(bruteForce(p, q, r).size());
      }
      if (!problem.empty()) {
        if (s.failures == 0) s.first = describe(q, r) + " (cell " + std::to_string(c) + "): " + problem;
        ++s.failures;
      }
      s.visited += got.size();
    }
  }
  return s;
}

void requireCellPartition(const UniformGrid& g) {
  REQUIRE(g.cellCount() == static_cast<std::size_t>(g.dim(0)) * g.dim(1) * g.dim(2));
  REQUIRE(g.cellCount() > 0);
  CHECK(g.cellBegin(0) == 0u);
  CHECK(g.cellEnd(g.cellCount() - 1) == g.size());
  std::size_t bad = 0;
  for (std::size_t c = 0; c + 1 < g.cellCount(); ++c) {
    bad += g.cellEnd(c) == g.cellBegin(c + 1) && g.cellBegin(c) <= g.cellEnd(c) ? 0 : 1;
  }
  CHECK(bad == 0u);
}

}  // namespace

TEST_CASE("UniformGrid gatherCell and filter match brute force", "[grid]") {
  std::mt19937 rng(8);
  const float cell = 0.3f;
  std::vector<std::pair<std::string, Points>> sets;
  sets.emplace_back("random", randomPoints(rng, 2000, -1.0f, 2.2f));
  {
    Points lattice;  // spacing equal to minCell, every point twice
    for (int i = 0; i < 8; ++i)
      for (int j = 0; j < 8; ++j)
        for (int k = 0; k < 8; ++k)
          for (int rep = 0; rep < 2; ++rep)
            lattice.add(static_cast<float>(i) * cell, static_cast<float>(j) * cell, static_cast<float>(k) * cell);
    sets.emplace_back("lattice", lattice);
  }
  {
    Points outliers = randomPoints(rng, 800, 0.0f, 2.0f);
    outliers.add(200.0f, 0.0f, 0.0f);
    outliers.add(200.0f, 0.1f, 0.0f);
    outliers.add(-50.0f, 80.0f, -20.0f);
    sets.emplace_back("outliers", outliers);
  }
  for (const auto& [name, p] : sets) {
    UniformGrid g;
    build(g, p, cell);
    requireCellPartition(g);
    for (float r : {cell, 0.5f * cell, 0.99f * cell}) {
      const CheckSummary s = checkCellBlocks(g, p, r);
      INFO(name << " r=" << r << "; first failure: " << s.first);
      CHECK(s.queries == p.size());
      CHECK(s.failures == 0u);
      CHECK(s.visited > s.queries);
    }
  }
}

// For every stride-th non-empty cell c, its block (gatherCell(c, cell)) must hold every grid point within
// coveredRadius of each point of c; radius(r) sees each such radius. Returns the points found within them.
template <typename F>
std::size_t checkBlocksCover(const UniformGrid& g, float cell, std::size_t stride, F&& radius) {
  swarmsim::CellBlock block;
  std::size_t inside = 0;
  for (std::size_t c = 0; c < g.cellCount(); c += stride) {
    if (g.cellBegin(c) == g.cellEnd(c)) continue;
    g.gatherCell(c, cell, block);
    std::vector<std::uint32_t> in(block.index.begin(), block.index.begin() + static_cast<std::ptrdiff_t>(block.size));
    std::sort(in.begin(), in.end());
    for (std::uint32_t k = g.cellBegin(c); k < g.cellEnd(c); ++k) {
      const float qx = g.sortedX()[k], qy = g.sortedY()[k], qz = g.sortedZ()[k];
      const float r = g.coveredRadius(block, qx, qy, qz);
      radius(r);
      for (std::uint32_t j = 0; j < g.size(); ++j) {
        const float dx = g.sortedX()[j] - qx, dy = g.sortedY()[j] - qy, dz = g.sortedZ()[j] - qz;
        if (dx * dx + dy * dy + dz * dz > r * r) continue;
        ++inside;
        if (!std::binary_search(in.begin(), in.end(), j)) {
          FAIL_CHECK("point " << j << " within " << r << " of " << k << " is not in the block");
        }
      }
    }
  }
  return inside;
}

TEST_CASE("UniformGrid coveredRadius: every point within it of a query is in the gathered block", "[grid]") {
  // the shape model takes an insect's nearest neighbours from its cell's block when they lie within
  // coveredRadius; a point missed there would silently change F_int
  std::mt19937 rng(11);
  Points p;
  std::uniform_real_distribution<float> ux(-2.1f, 5.3f), uy(0.0f, 3.7f), uz(10.0f, 12.45f);
  for (int i = 0; i < 3000; ++i) {
    const float a = ux(rng), b = uy(rng), c = uz(rng);
    p.add(a, b, c);
  }
  for (const float cell : {0.3f, 0.5f, 0.91f}) {
    UniformGrid g;
    build(g, p, cell);
    std::size_t checked = 0, bounded = 0;
    const std::size_t inside = checkBlocksCover(g, cell, 1, [&](float r) {
      CHECK(r >= 0.999f * cell);  // at least one cell: the block is the cell and its 26 neighbours
      if (r < 1e30f) ++bounded;
      ++checked;
    });
    CHECK(checked == p.x.size());
    CHECK(bounded > checked / 2);     // not vacuous: most blocks are bounded by inner cell faces
    CHECK(inside > 2 * checked);      // and hold points within the radius
  }
}

TEST_CASE("UniformGrid moveSorted: queries on kept cells find what a grid built on the moved points finds",
          "[grid]") {
  // the shape model keeps a grid's cells over several steps and only moves its points (moveSorted): every
  // query must still find exactly the points within its radius (brute force on the moved points), through
  // forEachNeighbor, forEachRunInBall and gathered blocks within coveredRadius, while points leave their cells
  std::mt19937 rng(21);
  Points p = randomPoints(rng, 2500, 0.0f, 3.0f);
  const float cell = 0.3f;
  UniformGrid g;
  build(g, p, cell);
  std::vector<float> xs(p.size()), ys(p.size()), zs(p.size());
  std::uniform_real_distribution<float> step(-1.0f, 1.0f), u(-0.5f, 3.5f);
  float total = 0.0f;
  for (int round = 0; round < 6; ++round) {
    // every point moves by at most `move` (a random direction, some points pushed out of the box)
    const float move = 0.04f * static_cast<float>(round + 1);
    for (std::size_t i = 0; i < p.size(); ++i) {
      float d[3] = {step(rng), step(rng), step(rng)};
      const float len = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
      const float scale = len > 0.0f ? move * 0.999f / std::max(len, 1.0f) : 0.0f;
      p.x[i] += d[0] * scale;
      p.y[i] += d[1] * scale;
      p.z[i] += d[2] * scale;
    }
    for (std::size_t k = 0; k < p.size(); ++k) {
      const std::uint32_t i = g.order()[k];
      xs[k] = p.x[i];
      ys[k] = p.y[i];
      zs[k] = p.z[i];
    }
    g.moveSorted(xs.data(), ys.data(), zs.data(), move);
    total += move;
    CHECK(g.slack() >= total);
    CHECK(g.slack() <= total * 1.001f);
    for (std::size_t k = 0; k < p.size(); ++k) CHECK(g.sortedX()[k] == p.x[g.order()[k]]);
    std::vector<Query> qs = pointsAsQueries(p);
    for (int i = 0; i < 200; ++i) {
      const float a = u(rng), b = u(rng), c = u(rng);
      qs.push_back({a, b, c});
    }
    const CheckSummary s = checkAll(g, p, qs, {0.5f * cell, cell, 1.7f * cell});
    INFO("round " << round << ", first failure: " << s.first);
    CHECK(s.failures == 0);
    CHECK(s.visited > s.queries);
    // the runs cut to the ball: the same points within r as the full runs
    for (const Query& q : qs) {
      for (const float r : {0.5f * cell, 1.3f * cell}) {
        const auto collect = [&](bool ball) {
          std::vector<std::uint32_t> in;
          const auto f = [&](std::uint32_t b, std::uint32_t e) {
            for (std::uint32_t k = b; k < e; ++k) {
              const float dx = g.sortedX()[k] - q.x, dy = g.sortedY()[k] - q.y, dz = g.sortedZ()[k] - q.z;
              if (dx * dx + dy * dy + dz * dz <= r * r) in.push_back(g.order()[k]);
            }
          };
          if (ball) {
            g.forEachRunInBall(q.x, q.y, q.z, r, f);
          } else {
            g.forEachRun(q.x, q.y, q.z, r, f);
          }
          std::sort(in.begin(), in.end());
          return in;
        };
        const auto cut = collect(true);
        REQUIRE(cut == collect(false));
        REQUIRE(cut == bruteForce(p, q, r));
      }
    }
    // a cell's block holds every point within coveredRadius of the cell's points, wherever they went
    CHECK(checkBlocksCover(g, cell, 7, [](float) {}) > 0);
    // every point's own cell is within reach of a query of radius 0 about it (the queries reach slack() farther)
    for (std::size_t c = 0; c < g.cellCount(); ++c) {
      const int cx = static_cast<int>(c % static_cast<std::size_t>(g.dim(0)));
      const int cy = static_cast<int>((c / static_cast<std::size_t>(g.dim(0))) % static_cast<std::size_t>(g.dim(1)));
      const int cz = static_cast<int>(c / (static_cast<std::size_t>(g.dim(0)) * static_cast<std::size_t>(g.dim(1))));
      for (std::uint32_t k = g.cellBegin(c); k < g.cellEnd(c); ++k) {
        int lo[3], hi[3];
        g.cellRange(g.sortedX()[k], g.sortedY()[k], g.sortedZ()[k], 0.0f, lo, hi);
        CHECK((cx >= lo[0] && cx <= hi[0] && cy >= lo[1] && cy <= hi[1] && cz >= lo[2] && cz <= hi[2]));
      }
    }
    // not vacuous: points have left the cells they were binned in (a grid built on them orders them otherwise)
    UniformGrid fresh;
    build(fresh, p, cell);
    CHECK(fresh.order() != g.order());
  }
  // a fresh build forgets the slack
  build(g, p, cell);
  CHECK(g.slack() == 0.0f);
  CHECK_THROWS_AS(g.moveSorted(xs.data(), ys.data(), zs.data(), -1.0f), std::invalid_argument);
}
