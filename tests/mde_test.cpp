// MDE kernels of the field model (lib/models/field/mde.hpp) against a
// brute-force double-precision reference: the SIMD blocks, the scalar tails,
// the pair symmetry of the paper's within-cell rule and coincident points.
#include "models/field/mde.hpp"

#include <catch2/catch.hpp>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <vector>

namespace {

struct Points {
  std::vector<float> x, y, z;
};

Points randomPoints(std::size_t n, float extent, unsigned seed) {
  std::mt19937 gen(seed);
  std::uniform_real_distribution<float> u(0.0f, extent);
  Points p;
  for (std::size_t i = 0; i < n; ++i) {
    p.x.push_back(u(gen));
    p.y.push_back(u(gen));
    p.z.push_back(u(gen));
  }
  return p;
}

// push on point k from points [b, e): sum over j != k with 0 < d < md of
// -(p_j - p_k) / d * (md - d) / 2, in double
void reference(const Points& p, std::size_t k, std::size_t b, std::size_t e, double md, double out[3], int& hits) {
  out[0] = out[1] = out[2] = 0.0;
  hits = 0;
  for (std::size_t j = b; j < e; ++j) {
    if (j == k) continue;
    const double dx = double(p.x[j]) - p.x[k], dy = double(p.y[j]) - p.y[k], dz = double(p.z[j]) - p.z[k];
    const double d = std::sqrt(dx * dx + dy * dy + dz * dz);
    if (!(d > 0.0 && d < md)) continue;
    const double w = 0.5 * (md - d) / d;
    out[0] -= dx * w;
    out[1] -= dy * w;
    out[2] -= dz * w;
    ++hits;
  }
}

}  // namespace

namespace {

// mdeCellPairs on [2, 2 + n) of p (which has 8 more entries past the run, as UniformGrid's sorted copies), with
// px/py/pz/hits sentinels around the run
struct CellResult {
  std::vector<float> px, py, pz;
  std::vector<std::int32_t> hits;
  bool coincident = false;
};
CellResult cellPairs(const Points& p, std::size_t n, float md, swarmsim::LaneSet lanes) {
  CellResult r;
  r.px.assign(n + 10, 9.0f);
  r.py.assign(n + 10, 9.0f);
  r.pz.assign(n + 10, 9.0f);
  r.hits.assign(n + 10, 7);
  r.coincident = swarmsim::mdeCellPairs(p.x.data(), p.y.data(), p.z.data(), 2, static_cast<std::uint32_t>(2 + n), md,
                                        r.px.data(), r.py.data(), r.pz.data(), r.hits.data(), lanes);
  return r;
}

}  // namespace

TEST_CASE("MDE within a cell: every pair once, pushes equal the brute-force sums, the same bits on every lane set",
          "[mde]") {
  // sizes cover empty, single, partial chunks of eight, several chunks, and more close pairs per point than the
  // kernel's list holds (n = 700 in a small cube: its lists are flushed part way)
  const std::size_t n = GENERATE(0u, 1u, 2u, 3u, 7u, 8u, 9u, 16u, 17u, 31u, 64u, 101u, 700u);
  INFO("n = " << n);
  const float md = 0.3f;
  // a 0.6 m cube (0.25 m for the largest): most pairs are closer than md, so most lanes are close
  Points p = randomPoints(n + 10, n >= 700 ? 0.25f : 0.6f, static_cast<unsigned>(n) + 11u);
  const CellResult r = cellPairs(p, n, md, swarmsim::LaneSet::kSse);
  CHECK_FALSE(r.coincident);
  // nothing outside the run is written
  CHECK(r.px[0] == 9.0f);
  CHECK(r.hits[1] == 7);
  CHECK(r.px[n + 2] == 9.0f);
  CHECK(r.pz[n + 9] == 9.0f);
  CHECK(r.hits[n + 2] == 7);
  int totalHits = 0;
  for (std::size_t k = 2; k < 2 + n; ++k) {
    double want[3];
    int wantHits = 0;
    reference(p, k, 2, 2 + n, md, want, wantHits);
    CHECK(r.hits[k] == wantHits);
    CHECK(r.px[k] == Approx(want[0]).margin(1e-5));
    CHECK(r.py[k] == Approx(want[1]).margin(1e-5));
    CHECK(r.pz[k] == Approx(want[2]).margin(1e-5));
    totalHits += r.hits[k];
  }
  if (n >= 8) CHECK(totalHits > 0);  // the test is not vacuous
  if (n >= 700) CHECK(totalHits > 2 * 256 * static_cast<int>(n) / 4);  // many points with more than a list's pairs
  // pairwise pushes are equal and opposite: the run's pushes sum to ~0
  double sx = 0.0;
  for (std::size_t k = 2; k < 2 + n; ++k) sx += r.px[k];
  CHECK(sx == Approx(0.0).margin(1e-3));
  // every lane set lists the same pairs, so gives the same bits
  for (const auto lanes : {swarmsim::LaneSet::kAvx, swarmsim::LaneSet::kAvx2, swarmsim::LaneSet::kAvx512}) {
    if (lanes > swarmsim::laneSet()) continue;
    const CellResult o = cellPairs(p, n, md, lanes);
    CHECK(std::memcmp(o.px.data(), r.px.data(), r.px.size() * sizeof(float)) == 0);
    CHECK(std::memcmp(o.py.data(), r.py.data(), r.py.size() * sizeof(float)) == 0);
    CHECK(std::memcmp(o.pz.data(), r.pz.data(), r.pz.size() * sizeof(float)) == 0);
    CHECK(o.hits == r.hits);
  }
}

TEST_CASE("MDE within a cell reports exactly coincident points and leaves their pair to the caller", "[mde]") {
  const std::size_t n = GENERATE(12u, 30u);
  Points p = randomPoints(n + 10, 0.5f, 3u);
  // points 2 + 4 and 2 + 9 of the run coincide
  p.x[11] = p.x[6];
  p.y[11] = p.y[6];
  p.z[11] = p.z[6];
  for (const auto lanes : {swarmsim::LaneSet::kSse, swarmsim::laneSet()}) {
    const CellResult r = cellPairs(p, n, 0.3f, lanes);
    CHECK(r.coincident);
    for (std::size_t k = 2; k < 2 + n; ++k) {
      CHECK(std::isfinite(r.px[k]));
      double want[3];
      int wantHits = 0;
      reference(p, k, 2, 2 + n, 0.3, want, wantHits);  // (the reference skips distance 0 as well)
      CHECK(r.hits[k] == wantHits);
      CHECK(r.px[k] == Approx(want[0]).margin(1e-5));
    }
  }
  // without the coincidence: not reported
  p.x[11] += 0.01f;
  CHECK_FALSE(cellPairs(p, n, 0.3f, swarmsim::laneSet()).coincident);
}

TEST_CASE("MDE push from several runs equals the brute-force sum", "[mde]") {
  const float md = 0.25f;
  Points p = randomPoints(200, 1.0f, 5u);
  // runs of assorted lengths (SIMD blocks and tails), the query inside one of them
  const std::vector<std::pair<std::uint32_t, std::uint32_t>> runs = {{0, 3}, {10, 27}, {40, 40}, {50, 59}, {100, 200}};
  for (std::uint32_t k : {0u, 12u, 55u, 150u, 199u}) {
    swarmsim::MdePush push(md);
    push.start(p.x[k], p.y[k], p.z[k]);
    double want[3] = {0, 0, 0};
    int wantHits = 0;
    for (const auto& [b, e] : runs) {
      push.add(p.x.data(), p.y.data(), p.z.data(), b, e);
      double part[3];
      int h = 0;
      reference(p, k, b, e, md, part, h);
      for (int a = 0; a < 3; ++a) want[a] += part[a];
      wantHits += h;
    }
    INFO("query " << k);
    const swarmsim::Vec3 got = push.push();
    CHECK(push.hits() == wantHits);
    CHECK(push.zeros() == 1);  // the query itself
    CHECK(got.x() == Approx(want[0]).margin(1e-5));
    CHECK(got.y() == Approx(want[1]).margin(1e-5));
    CHECK(got.z() == Approx(want[2]).margin(1e-5));
  }
}
