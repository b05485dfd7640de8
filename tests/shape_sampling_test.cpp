// Shape model building blocks: stratified surface sampling (on the surface,
// area-uniform, stratified, deterministic, input errors) and the agent-to-target
// assignment (a permutation, close to the exact optimum of an O(n^3) Hungarian
// solver, bit-identical for any thread count). Timings: the hidden
// "[shape-sampling-bench]" test.
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "core/error.hpp"
#include "core/parallel.hpp"
#include "core/rng.hpp"
#include "brute_distance.hpp"
#include "geometry/mesh.hpp"
#include "models/shape/assignment.hpp"
#include "models/shape/sampling.hpp"
#include "test_util.hpp"

using Catch::Matchers::Contains;
using swarmsim::AgentRng;
using swarmsim::InputError;
using swarmsim::RngPurpose;
using swarmsim::SurfacePoint;
using swarmsim::TriangleMesh;
using swarmsim::Vec3;
using swarmsim::Vec3d;
using swarmsim_test::bruteDistance;
using swarmsim_test::ThreadCountGuard;

namespace {

// ---- meshes -----------------------------------------------------------------

TriangleMesh ballMesh() { return swarmsim::loadObj(swarmsim_test::kSourceTree + "/data/ball.obj"); }

// 40 triangles around the origin whose areas differ by a factor of ~60
TriangleMesh fanMesh() {
  TriangleMesh m;
  m.source = "fan";
  m.vertices.push_back(Vec3d::Zero());
  const int count = 40;
  for (int i = 0; i < count; ++i) {
    const double a = 2.0 * M_PI * i / count, r = 1.0 + (i % 8);
    m.vertices.emplace_back(r * std::cos(a), r * std::sin(a), 0.2 * (i % 3));
  }
  for (int i = 0; i < count; ++i) {
    m.triangles.push_back({0u, static_cast<std::uint32_t>(1 + i), static_cast<std::uint32_t>(1 + (i + 1) % count)});
  }
  return m;
}

// A closed surface of latitude rings x longitude segments whose radius in
// direction d is radius(d) (a sphere for a constant).
template <typename R>
TriangleMesh ringMesh(int rings, int segments, R&& radius) {
  TriangleMesh m;
  m.source = "rings";
  m.vertices.emplace_back(radius(Vec3d(0, 0, 1)) * Vec3d(0, 0, 1));
  for (int i = 1; i < rings; ++i) {
    const double theta = M_PI * i / rings;
    for (int j = 0; j < segments; ++j) {
      const double phi = 2.0 * M_PI * j / segments;
      const Vec3d d(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
      m.vertices.push_back(radius(d) * d);
    }
  }
  m.vertices.emplace_back(radius(Vec3d(0, 0, -1)) * Vec3d(0, 0, -1));
  const auto at = [&](int ring, int j) { return static_cast<std::uint32_t>(1 + (ring - 1) * segments + j % segments); };
  const auto south = static_cast<std::uint32_t>(m.vertices.size() - 1);
  for (int j = 0; j < segments; ++j) {
    m.triangles.push_back({0u, at(1, j), at(1, j + 1)});
    m.triangles.push_back({south, at(rings - 1, j + 1), at(rings - 1, j)});
    for (int i = 1; i + 1 < rings; ++i) {
      m.triangles.push_back({at(i, j), at(i + 1, j), at(i + 1, j + 1)});
      m.triangles.push_back({at(i, j), at(i + 1, j + 1), at(i, j + 1)});
    }
  }
  return m;
}

// an animal-like closed surface 20 m long: a stretched body with a head and
// four legs as bumps (2 (rings - 1) x segments triangles)
TriangleMesh animalMesh(int rings, int segments) {
  const std::array<Vec3d, 5> bumps = {Vec3d(1, 0, 0.4), Vec3d(0.5, 0.6, -0.6), Vec3d(0.5, -0.6, -0.6),
                                      Vec3d(-0.5, 0.6, -0.6), Vec3d(-0.5, -0.6, -0.6)};
  TriangleMesh m = ringMesh(rings, segments, [&](const Vec3d& d) {
    double r = 1.0;
    for (const Vec3d& b : bumps) r += 0.8 * std::exp(-(d - b.normalized()).squaredNorm() / 0.04);
    return r;
  });
  for (Vec3d& v : m.vertices) v = v.cwiseProduct(Vec3d(5.0, 2.5, 3.0));
  const double scale = 20.0 / m.bounds().sizes().maxCoeff();  // 20 m long
  for (Vec3d& v : m.vertices) v *= scale;
  return m;
}

// ---- geometry and statistics helpers -----------------------------------------

double triangleArea(const TriangleMesh& m, std::size_t t) {
  const auto& f = m.triangles[t];
  return 0.5 * (m.vertices[f[1]] - m.vertices[f[0]]).cross(m.vertices[f[2]] - m.vertices[f[0]]).norm();
}

// upper critical value of chi-square with df degrees of freedom at tail
// probability 0.001 (Wilson-Hilferty; z = 3.090)
double chiSquareCritical(double df) {
  const double z = 3.090, h = 2.0 / (9.0 * df);
  return df * std::pow(1.0 - h + z * std::sqrt(h), 3.0);
}

// sum (observed - expected)^2 / expected
double chiSquare(const std::vector<double>& observed, const std::vector<double>& expected) {
  double s = 0.0;
  for (std::size_t i = 0; i < observed.size(); ++i) s += (observed[i] - expected[i]) * (observed[i] - expected[i]) / expected[i];
  return s;
}

// samples per triangle
std::vector<double> countPerTriangle(const TriangleMesh& m, const std::vector<SurfacePoint>& s) {
  std::vector<double> count(m.triangles.size(), 0.0);
  for (const SurfacePoint& p : s) count[p.triangle] += 1.0;
  return count;
}

// bin of (u, v) among the 16 congruent sub-triangles of the 4-grid (equal areas)
int barycentricBin(float u, float v) {
  const int i = std::min(3, static_cast<int>(4.0f * u)), j = std::min(3, static_cast<int>(4.0f * v));
  const bool up = (4.0f * u - static_cast<float>(i)) + (4.0f * v - static_cast<float>(j)) < 1.0f || i + j == 3;
  return up ? i * 4 + j : 16 + i * 4 + j;  // 10 up and 6 down bins are used
}

// Independent area-weighted samples (no stratification): triangle by the area
// CDF, position by the square-root method (Osada et al. 2002), or with
// biasedInside the non-uniform (u, v) = (r1, r2 (1 - r1)).
std::vector<SurfacePoint> independentSamples(const TriangleMesh& m, std::size_t n, std::uint64_t seed,
                                             bool biasedInside = false) {
  std::vector<double> cdf(m.triangles.size());
  double sum = 0.0;
  for (std::size_t t = 0; t < cdf.size(); ++t) cdf[t] = sum += triangleArea(m, t);
  std::vector<SurfacePoint> out(n);
  for (std::size_t i = 0; i < n; ++i) {
    AgentRng rng(seed, 0, static_cast<std::uint32_t>(i), RngPurpose::kSpawnPosition);
    const double x = rng.uniform() * sum;
    const auto t = static_cast<std::size_t>(std::upper_bound(cdf.begin(), cdf.end(), x) - cdf.begin());
    const float r1 = rng.uniform(), r2 = rng.uniform();
    out[i].triangle = static_cast<std::uint32_t>(std::min(t, cdf.size() - 1));
    if (biasedInside) {
      out[i].u = r1;
      out[i].v = r2 * (1.0f - r1);
    } else {
      const float s = std::sqrt(r1);
      out[i].u = s * (1.0f - r2);
      out[i].v = s * r2;
    }
  }
  return out;
}

double meanNearestNeighbour(const std::vector<Vec3d>& p) {
  double sum = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    double best = std::numeric_limits<double>::max();
    for (std::size_t j = 0; j < p.size(); ++j) {
      if (j != i) best = std::min(best, (p[i] - p[j]).squaredNorm());
    }
    sum += std::sqrt(best);
  }
  return sum / static_cast<double>(p.size());
}

std::vector<Vec3d> positions(const TriangleMesh& m, const std::vector<SurfacePoint>& s) {
  std::vector<Vec3d> p;
  for (const SurfacePoint& q : s) p.push_back(swarmsim::surfacePoint(m, q));
  return p;
}

std::string sampleError(const TriangleMesh& m) {
  try {
    swarmsim::sampleSurface(m, 10, 1);
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no InputError)";
}

// ---- assignment helpers ------------------------------------------------------

std::vector<Vec3> inBall(std::size_t n, float radius, const Vec3& centre, std::uint64_t seed) {
  std::vector<Vec3> p(n);
  for (std::size_t i = 0; i < n; ++i) {
    p[i] = centre + radius * AgentRng(seed, 0, static_cast<std::uint32_t>(i), RngPurpose::kSpawnPosition).inUnitBall();
  }
  return p;
}

std::vector<Vec3> onSphere(std::size_t n, float radius, const Vec3& centre, std::uint64_t seed) {
  std::vector<Vec3> p(n);
  for (std::size_t i = 0; i < n; ++i) {
    p[i] = centre + radius * AgentRng(seed, 0, static_cast<std::uint32_t>(i), RngPurpose::kSpawnPosition).unitVector();
  }
  return p;
}

std::vector<Vec3> onMesh(const TriangleMesh& m, std::size_t n, std::uint64_t seed) {
  std::vector<Vec3> p;
  p.reserve(n);
  for (const SurfacePoint& s : swarmsim::sampleSurface(m, n, seed)) p.push_back(swarmsim::surfacePoint(m, s).cast<float>());
  return p;
}

double totalDistance(const std::vector<Vec3>& a, const std::vector<Vec3>& t, const std::vector<std::uint32_t>& perm) {
  double s = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) s += (a[i] - t[perm[i]]).cast<double>().norm();
  return s;
}

bool isPermutation(std::vector<std::uint32_t> perm) {
  std::sort(perm.begin(), perm.end());
  for (std::size_t i = 0; i < perm.size(); ++i) {
    if (perm[i] != i) return false;
  }
  return true;
}

// the exact minimum of sum_i |a_i - t_perm[i]|: the Hungarian algorithm with
// potentials (shortest augmenting paths, O(n^3)), in double
double optimalTotalDistance(const std::vector<Vec3>& a, const std::vector<Vec3>& t) {
  const std::size_t n = a.size();
  const auto cost = [&](std::size_t i, std::size_t j) { return (a[i - 1] - t[j - 1]).cast<double>().norm(); };
  std::vector<double> u(n + 1, 0.0), v(n + 1, 0.0);
  std::vector<std::size_t> row(n + 1, 0), way(n + 1, 0);  // row[j]: agent on target j (1-based, 0 none)
  for (std::size_t i = 1; i <= n; ++i) {
    row[0] = i;
    std::size_t j0 = 0;
    std::vector<double> minv(n + 1, std::numeric_limits<double>::max());
    std::vector<char> used(n + 1, 0);
    do {
      used[j0] = 1;
      const std::size_t i0 = row[j0];
      double delta = std::numeric_limits<double>::max();
      std::size_t j1 = 0;
      for (std::size_t j = 1; j <= n; ++j) {
        if (used[j]) continue;
        const double cur = cost(i0, j) - u[i0] - v[j];
        if (cur < minv[j]) {
          minv[j] = cur;
          way[j] = j0;
        }
        if (minv[j] < delta) {
          delta = minv[j];
          j1 = j;
        }
      }
      for (std::size_t j = 0; j <= n; ++j) {
        if (used[j]) {
          u[row[j]] += delta;
          v[j] -= delta;
        } else {
          minv[j] -= delta;
        }
      }
      j0 = j1;
    } while (row[j0] != 0);
    do {
      const std::size_t j1 = way[j0];
      row[j0] = row[j1];
      j0 = j1;
    } while (j0 != 0);
  }
  double total = 0.0;
  for (std::size_t j = 1; j <= n; ++j) total += cost(row[j], j);
  return total;
}

double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

// ---- sampling ------------------------------------------------------------------

TEST_CASE("Surface samples lie on the mesh, inside their triangle", "[shape-sampling]") {
  const TriangleMesh ball = ballMesh();
  const double diagonal = ball.bounds().diagonal().norm();
  const std::size_t n = 3000;
  const auto samples = swarmsim::sampleSurface(ball, n, 7);
  REQUIRE(samples.size() == n);
  double worst = 0.0;
  for (const SurfacePoint& s : samples) {
    REQUIRE(s.triangle < ball.triangles.size());
    CHECK(s.u >= 0.0f);
    CHECK(s.v >= 0.0f);
    CHECK(s.u + s.v <= 1.0f);
    worst = std::max(worst, bruteDistance(ball, swarmsim::surfacePoint(ball, s)));
  }
  CHECK(worst < 1e-5 * diagonal);
  // the total area of the icosphere, a little below the sphere's 4 pi
  CHECK(swarmsim::surfaceArea(ball) == Approx(4.0 * M_PI).epsilon(0.02));
}

TEST_CASE("Surface points follow a keyframe with the same faces", "[shape-sampling]") {
  const TriangleMesh ball = ballMesh();
  TriangleMesh moved = ball;
  for (Vec3d& v : moved.vertices) v = 2.0 * v + Vec3d(1, 2, 3);
  for (const SurfacePoint& s : swarmsim::sampleSurface(ball, 100, 3)) {
    const Vec3d want = 2.0 * swarmsim::surfacePoint(ball, s) + Vec3d(1, 2, 3);
    CHECK((swarmsim::surfacePoint(moved, s) - want).norm() < 1e-6);
  }
  CHECK_THROWS_AS(swarmsim::surfacePoint(ball, SurfacePoint{static_cast<std::uint32_t>(ball.triangles.size()), 0, 0}),
                  std::out_of_range);
}

TEST_CASE("Samples are area-uniform over triangles of unequal area", "[shape-sampling]") {
  const TriangleMesh fan = fanMesh();
  const std::size_t n = 20000;
  const double total = swarmsim::surfaceArea(fan);
  std::vector<double> expected;
  for (std::size_t t = 0; t < fan.triangles.size(); ++t) expected.push_back(n * triangleArea(fan, t) / total);
  const double critical = chiSquareCritical(static_cast<double>(fan.triangles.size() - 1));
  const double stratified = chiSquare(countPerTriangle(fan, swarmsim::sampleSurface(fan, n, 11)), expected);
  const double independent = chiSquare(countPerTriangle(fan, independentSamples(fan, n, 11)), expected);
  // a deliberately biased sampler: the same number of samples on every triangle
  const std::vector<double> equal(fan.triangles.size(), double(n) / double(fan.triangles.size()));
  const double biased = chiSquare(equal, expected);
  INFO("chi-square (df " << fan.triangles.size() - 1 << ", critical " << critical << " at 0.001): stratified "
                         << stratified << ", independent " << independent << ", equal per triangle " << biased);
  CHECK(stratified < critical);
  CHECK(independent < critical);  // the reference sampler passes too
  CHECK(biased > 10.0 * critical);
  // stratified: every triangle gets its expected count to within 1 either way
  // (whole strata inside its interval, plus possibly the two it shares)
  const auto count = countPerTriangle(fan, swarmsim::sampleSurface(fan, n, 11));
  for (std::size_t t = 0; t < count.size(); ++t) CHECK(std::abs(count[t] - expected[t]) < 2.0);
}

TEST_CASE("Samples are uniform inside their triangles", "[shape-sampling]") {
  // pooled over triangles: where inside its triangle (which of 16 equal
  // sub-triangles) a sample falls, with 2 samples per triangle on the
  // icosphere (the jitter alone) and 300 on the fan (the sub-triangle grid)
  const bool few = GENERATE(true, false);
  const TriangleMesh mesh = few ? ballMesh() : fanMesh();
  const std::size_t n = (few ? 2 : 300) * mesh.triangles.size();
  INFO(n << " samples on " << mesh.triangles.size() << " triangles");
  const auto binCounts = [](const std::vector<SurfacePoint>& s) {
    std::vector<double> c(32, 0.0);
    for (const SurfacePoint& p : s) c[barycentricBin(p.u, p.v)] += 1.0;
    std::vector<double> used;
    for (int i = 0; i < 4; ++i) {
      for (int j = 0; j < 4; ++j) {
        if (i + j <= 3) used.push_back(c[i * 4 + j]);
        if (i + j <= 2) used.push_back(c[16 + i * 4 + j]);
      }
    }
    return used;
  };
  const std::vector<double> expected(16, double(n) / 16.0);
  const double critical = chiSquareCritical(15.0);
  const double stratified = chiSquare(binCounts(swarmsim::sampleSurface(mesh, n, 5)), expected);
  const double biased = chiSquare(binCounts(independentSamples(mesh, n, 5, true)), expected);
  INFO("chi-square (df 15, critical " << critical << "): stratified " << stratified << ", (r1, r2 (1 - r1)) " << biased);
  CHECK(stratified < critical);
  CHECK(biased > critical);
}

TEST_CASE("Stratified samples are spread more evenly than independent ones", "[shape-sampling]") {
  // Mean nearest-neighbour distance of 2,000 samples on the unit icosphere
  // (seed 1): stratified 0.0466, independent 0.0395 (a Poisson process gives
  // 0.5 / sqrt(density) = 0.0396). The ratio 1.18 is that of jittered
  // sampling (a jittered grid in a square gives 1.16 - 1.22): every sample is
  // uniform in its own stratum, so neighbours across a stratum border can be
  // close, but none share one. Sampling noise of the ratio here is ~1%.
  const TriangleMesh ball = ballMesh();
  const std::size_t n = 2000;
  const double stratified = meanNearestNeighbour(positions(ball, swarmsim::sampleSurface(ball, n, 1)));
  const double independent = meanNearestNeighbour(positions(ball, independentSamples(ball, n, 1)));
  INFO("mean nearest-neighbour distance: stratified " << stratified << ", independent " << independent);
  CHECK(stratified > 1.1 * independent);
}

TEST_CASE("Sampling is deterministic for a seed and gives exactly n samples", "[shape-sampling]") {
  const TriangleMesh ball = ballMesh();
  const auto same = [](const std::vector<SurfacePoint>& a, const std::vector<SurfacePoint>& b) {
    if (a.size() != b.size()) return false;
    for (std::size_t i = 0; i < a.size(); ++i) {
      if (a[i].triangle != b[i].triangle || a[i].u != b[i].u || a[i].v != b[i].v) return false;
    }
    return true;
  };
  const auto a = swarmsim::sampleSurface(ball, 5000, 42);
  CHECK(same(a, swarmsim::sampleSurface(ball, 5000, 42)));
  CHECK_FALSE(same(a, swarmsim::sampleSurface(ball, 5000, 43)));
  {
    ThreadCountGuard guard;  // and whatever the thread count (5,000 samples run in parallel)
    swarmsim::setThreadCount(1);
    CHECK(same(a, swarmsim::sampleSurface(ball, 5000, 42)));
  }
  for (const std::size_t n : {0u, 1u, 2u, 7u, 1279u, 1280u, 1281u, 100000u}) {
    CHECK(swarmsim::sampleSurface(ball, n, 9).size() == n);
  }
  // one triangle, a million samples: one per sub-triangle of its 1000-grid, so
  // each of the 16 equal parts of the 4-grid gets n / 16 to within rounding at
  // the part borders (independent samples: +-250)
  TriangleMesh one;
  one.vertices = {Vec3d(0, 0, 0), Vec3d(3, 0, 0), Vec3d(0, 1, 1)};
  one.triangles = {{0u, 1u, 2u}};
  std::vector<int> bins(32, 0);
  for (const SurfacePoint& s : swarmsim::sampleSurface(one, 1000000, 2)) ++bins[barycentricBin(s.u, s.v)];
  CHECK(std::count(bins.begin(), bins.end(), 0) == 16);  // the 16 unused bin numbers
  for (const int count : bins) {
    if (count != 0) CHECK(std::abs(count - 62500) <= 5);
  }
}

TEST_CASE("Zero-area triangles get no samples; empty and zero-area meshes are input errors", "[shape-sampling]") {
  TriangleMesh m;
  m.source = "flat.obj";
  m.vertices = {Vec3d(0, 0, 0), Vec3d(1, 0, 0), Vec3d(2, 0, 0), Vec3d(0, 1, 0)};
  m.triangles = {{0u, 1u, 2u}, {0u, 1u, 3u}, {1u, 1u, 3u}};  // collinear, proper, repeated vertex
  for (const SurfacePoint& s : swarmsim::sampleSurface(m, 500, 1)) CHECK(s.triangle == 1u);

  m.triangles = {{0u, 1u, 2u}, {1u, 1u, 3u}};
  CHECK_THAT(sampleError(m), Contains("flat.obj") && Contains("zero"));
  m.triangles.clear();
  m.source = "empty.obj";
  CHECK_THAT(sampleError(m), Contains("empty.obj") && Contains("without triangles"));
  m.source = "bad.obj";
  m.triangles = {{0u, 1u, 9u}};
  CHECK_THAT(sampleError(m), Contains("bad.obj") && Contains("vertex 9"));
}

// ---- assignment -------------------------------------------------------------------

TEST_CASE("Assignment is a permutation; sizes must match", "[shape-sampling]") {
  for (const std::size_t n : {0u, 1u, 2u, 3u, 17u, 5000u}) {
    const auto a = inBall(n, 5.0f, Vec3::Zero(), 1), t = onSphere(n, 5.0f, Vec3(1, 0, 0), 2);
    const auto perm = swarmsim::assignTargets(a, t);
    CHECK(perm.size() == n);
    CHECK(isPermutation(perm));
  }
  // coincident points (everyone spawned at one spot) and a flat target set
  const std::vector<Vec3> same(3000, Vec3(1, 2, 3));
  std::vector<Vec3> flat = onSphere(3000, 4.0f, Vec3::Zero(), 3);
  for (Vec3& p : flat) p.z() = 0.0f;
  CHECK(isPermutation(swarmsim::assignTargets(same, flat)));
  CHECK(isPermutation(swarmsim::assignTargets(flat, same)));
  CHECK_THROWS_AS(swarmsim::assignTargets(inBall(3, 1.0f, Vec3::Zero(), 1), inBall(4, 1.0f, Vec3::Zero(), 1)),
                  std::invalid_argument);
  std::vector<Vec3> bad = inBall(3, 1.0f, Vec3::Zero(), 1);
  bad[1].y() = std::numeric_limits<float>::quiet_NaN();
  CHECK_THROWS_AS(swarmsim::assignTargets(bad, inBall(3, 1.0f, Vec3::Zero(), 2)), std::invalid_argument);
}

TEST_CASE("Assignment total distance is close to the exact optimum", "[shape-sampling]") {
  // Measured ratios of the total distance to the Hungarian optimum (500
  // agents): ball to sphere 1.0158, shifted cloud 1.0087, two clusters to one
  // 1.0005, sphere to animal 1.0028. The bound 1.05 leaves room for changes to
  // the heuristic.
  struct Case {
    const char* name;
    std::vector<Vec3> agents, targets;
    double bound;
  };
  std::vector<Vec3> two = inBall(250, 5.0f, Vec3(-25, 0, 0), 5);
  const std::vector<Vec3> other = inBall(250, 5.0f, Vec3(25, 0, 0), 6);
  two.insert(two.end(), other.begin(), other.end());
  TriangleMesh animal = animalMesh(20, 40);
  const std::vector<Case> cases = {
      {"ball to sphere surface", inBall(500, 20.0f, Vec3::Zero(), 1), onSphere(500, 20.0f, Vec3::Zero(), 2), 1.05},
      {"cloud shifted by half its radius", inBall(500, 20.0f, Vec3::Zero(), 3), inBall(500, 20.0f, Vec3(10, 0, 0), 4),
       1.05},
      {"two clusters to one", two, inBall(500, 8.0f, Vec3(0, 15, 0), 7), 1.05},
      {"sphere surface to an animal", onSphere(500, 20.0f, Vec3::Zero(), 8), onMesh(animal, 500, 9), 1.05},
  };
  for (const Case& c : cases) {
    const auto perm = swarmsim::assignTargets(c.agents, c.targets);
    REQUIRE(isPermutation(perm));
    const double ratio = totalDistance(c.agents, c.targets, perm) / optimalTotalDistance(c.agents, c.targets);
    INFO(c.name << ": total distance / optimum = " << ratio);
    CHECK(ratio >= 1.0 - 1e-9);
    CHECK(ratio <= c.bound);
  }
}

TEST_CASE("Assignment is bit-identical for 1 and 2 threads", "[shape-sampling]") {
  // 50,000 agents: above the serial threshold (32,768), so the passes of the
  // finest level run in parallel
  const auto a = inBall(50000, 20.0f, Vec3::Zero(), 1);
  const auto t = onMesh(animalMesh(30, 60), 50000, 2);
  ThreadCountGuard guard;
  swarmsim::setThreadCount(1);
  const auto one = swarmsim::assignTargets(a, t);
  swarmsim::setThreadCount(2);
  const auto twoThreads = swarmsim::assignTargets(a, t);
  CHECK(isPermutation(one));
  CHECK(one == twoThreads);
}

TEST_CASE("Shape sampling and assignment timings", "[.][shape-sampling-bench]") {
  // wall-clock seconds, the best of 3 runs (1 at a million points)
  const TriangleMesh animal = animalMesh(51, 100);  // 10,000 triangles
  std::printf("threads %d; animal mesh %zu triangles, 20 m long; ball and sphere radius 20 m\n",
              swarmsim::threadCount(), animal.triangles.size());
  for (const std::size_t n : {10000u, 100000u, 1000000u}) {
    const int reps = n < 1000000 ? 3 : 1;
    const auto best = [&](auto&& f) {
      double t = 1e30;
      for (int r = 0; r < reps; ++r) {
        const auto start = std::chrono::steady_clock::now();
        f();
        t = std::min(t, secondsSince(start));
      }
      return t;
    };
    std::vector<SurfacePoint> samples;
    const double sampling = best([&] { samples = swarmsim::sampleSurface(animal, n, 1); });
    std::vector<Vec3> targets;
    for (const SurfacePoint& s : samples) targets.push_back(swarmsim::surfacePoint(animal, s).cast<float>());
    const auto ball = inBall(n, 20.0f, Vec3::Zero(), 2), sphere = onSphere(n, 20.0f, Vec3::Zero(), 3);
    std::vector<std::uint32_t> perm;
    const double ballAnimal = best([&] { perm = swarmsim::assignTargets(ball, targets); });
    const double ballAnimalMean = totalDistance(ball, targets, perm) / double(n);
    const double sphereAnimal = best([&] { perm = swarmsim::assignTargets(sphere, targets); });
    const double sphereAnimalMean = totalDistance(sphere, targets, perm) / double(n);
    const double ballSphere = best([&] { perm = swarmsim::assignTargets(ball, sphere); });
    // ball to sphere: sum (R - |a_i|) is a lower bound of any assignment
    double bound = 0.0;
    for (const Vec3& p : ball) bound += 20.0 - p.cast<double>().norm();
    std::printf("n %7zu: sample %.3f s | assign ball->animal %.3f s (mean %.3f m), sphere->animal %.3f s (mean %.3f m), "
                "ball->sphere %.3f s (total / lower bound %.4f)\n",
                n, sampling, ballAnimal, ballAnimalMean, sphereAnimal, sphereAnimalMean, ballSphere,
                totalDistance(ball, sphere, perm) / bound);
  }
}
