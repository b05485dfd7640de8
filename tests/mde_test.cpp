// MDE kernels of the field model (lib/models/field/mde.hpp) against a
// brute-force double-precision reference: the SIMD blocks, the scalar tails,
// the pair symmetry of the paper's within-cell rule and coincident points.
#include "models/field/mde.hpp"

#include <catch2/catch.hpp>
#include <cmath>
#include <cstdint>
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

TEST_CASE("MDE within a cell: every pair once, pushes equal the brute-force sums", "[mde]") {
  // sizes cover empty, single, tails of 1-3 and several SIMD blocks
  const std::size_t n = GENERATE(0u, 1u, 2u, 3u, 4u, 5u, 7u, 8u, 9u, 31u, 64u, 101u);
  INFO("n = " << n);
  const float md = 0.3f;
  // a 0.6 m cube: most pairs are closer than md, so most lanes are active
  Points p = randomPoints(n + 3, 0.6f, static_cast<unsigned>(n) + 11u);
  std::vector<float> px(n + 3, 9.0f), py(n + 3, 9.0f), pz(n + 3, 9.0f);
  std::vector<std::int32_t> hits(n + 3, 7);
  // the run is [2, 2 + n): values outside it must stay untouched
  const bool coincident =
      swarmsim::mdeWithinRun(p.x.data(), p.y.data(), p.z.data(), 2, static_cast<std::uint32_t>(2 + n), md, px.data(),
                             py.data(), pz.data(), hits.data());
  CHECK_FALSE(coincident);
  CHECK(px[0] == 9.0f);
  CHECK(hits[1] == 7);
  CHECK(px[n + 2] == 9.0f);
  int totalHits = 0;
  for (std::size_t k = 2; k < 2 + n; ++k) {
    double want[3];
    int wantHits = 0;
    reference(p, k, 2, 2 + n, md, want, wantHits);
    CHECK(hits[k] == wantHits);
    CHECK(px[k] == Approx(want[0]).margin(1e-5));
    CHECK(py[k] == Approx(want[1]).margin(1e-5));
    CHECK(pz[k] == Approx(want[2]).margin(1e-5));
    totalHits += hits[k];
  }
  if (n >= 8) CHECK(totalHits > 0);  // the test is not vacuous
  // pairwise pushes are equal and opposite: the run's pushes sum to ~0
  double sx = 0.0;
  for (std::size_t k = 2; k < 2 + n; ++k) sx += px[k];
  CHECK(sx == Approx(0.0).margin(1e-4));
}

TEST_CASE("MDE within a cell reports exactly coincident points", "[mde]") {
  Points p = randomPoints(12, 0.5f, 3u);
  p.x[9] = p.x[4];
  p.y[9] = p.y[4];
  p.z[9] = p.z[4];
  std::vector<float> px(12), py(12), pz(12);
  std::vector<std::int32_t> hits(12);
  CHECK(swarmsim::mdeWithinRun(p.x.data(), p.y.data(), p.z.data(), 0, 12, 0.3f, px.data(), py.data(), pz.data(),
                               hits.data()));
  for (float v : px) CHECK(std::isfinite(v));
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
