// The boids model's neighbour sums (lib/models/boids/boids_kernel.hpp): against a brute-force sum in double
// over every pair, and the same bits from every instruction set (SSE, AVX, AVX2 where the CPU has them).
#include <catch2/catch.hpp>

#include <array>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <random>
#include <vector>

#include "core/lanes.hpp"
#include "lane_sets.hpp"
#include "models/boids/boids_kernel.hpp"
#include "spatial/uniform_grid.hpp"

using namespace swarmsim;

namespace {

struct Cloud {
  std::vector<float> x, y, z, ux, uy, uz;
};

// n agents uniform in a cube of edge `edge`, unit velocities uniform on the sphere
Cloud randomCloud(std::size_t n, float edge, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, edge);
  std::normal_distribution<float> g(0.0f, 1.0f);
  Cloud c;
  for (std::size_t i = 0; i < n; ++i) {
    c.x.push_back(u(rng));
    c.y.push_back(u(rng));
    c.z.push_back(u(rng));
    const double a = g(rng), b = g(rng), d = g(rng), len = std::sqrt(a * a + b * b + d * d);
    c.ux.push_back(static_cast<float>(a / len));
    c.uy.push_back(static_cast<float>(b / len));
    c.uz.push_back(static_cast<float>(d / len));
  }
  return c;
}

// every agent's nine sums by the kernel, in the grid's sorted order (the grid is built here). The kernel reads
// the positions from `sorted`, arrays of exactly n (as the model's state): a load past them is a fault under
// the address sanitizer.
std::vector<std::array<float, 9>> kernelSums(const Cloud& c, const BoidsZones& zones, float r3, LaneSet lanes,
                                             UniformGrid& grid, BoidsLanesInput& in, std::vector<float> sorted[3]) {
  const std::size_t n = c.x.size();
  grid.build(c.x.data(), c.y.data(), c.z.data(), n, r3);
  for (int a = 0; a < 3; ++a) {
    const std::vector<float>& from = a == 0 ? grid.sortedX() : a == 1 ? grid.sortedY() : grid.sortedZ();
    sorted[a].assign(from.begin(), from.begin() + static_cast<std::ptrdiff_t>(n));
  }
  in.prepare(sorted[0].data(), sorted[1].data(), sorted[2].data(), n);
  for (std::size_t k = 0; k < n; ++k) {
    const std::uint32_t i = grid.order()[k];
    in.ux[k] = c.ux[i];
    in.uy[k] = c.uy[i];
    in.uz[k] = c.uz[i];
  }
  std::vector<std::array<float, 9>> out(n);
  BoidsScratch scratch;
  std::vector<float> cell[9];
  std::size_t cells = 0;
  CellBlock block;
  for (std::size_t row = 0; row < grid.rowCount(); ++row) {
    grid.forEachCellOfRow(row, r3, scratch.runs, [&](std::size_t cc, const std::uint32_t* runs, std::size_t nRuns) {
      const std::uint32_t a0 = grid.cellBegin(cc), a1 = grid.cellEnd(cc);
      // the runs are the rows gatherCell gathers, in its order, empty ones left out
      grid.gatherCell(cc, r3, block);
      std::vector<std::uint32_t> got;
      for (std::size_t i = 0; i < nRuns; ++i) {
        CHECK(runs[2 * i] < runs[2 * i + 1]);
        for (std::uint32_t k = runs[2 * i]; k < runs[2 * i + 1]; ++k) got.push_back(k);
      }
      CHECK(got == std::vector<std::uint32_t>(block.index.begin(), block.index.begin() + static_cast<std::ptrdiff_t>(block.size)));
      // (arrays of exactly the cell's agents: a write past them is a fault under the address sanitizer)
      for (auto& a : cell) a.assign(a1 - a0, 0.0f);
      float* const at[9] = {cell[0].data(), cell[1].data(), cell[2].data(), cell[3].data(), cell[4].data(),
                            cell[5].data(), cell[6].data(), cell[7].data(), cell[8].data()};
      boidsCellSums(in, a0, a1, runs, nRuns, zones, lanes, scratch, at);
      for (std::uint32_t k = a0; k < a1; ++k) {
        for (std::size_t a = 0; a < 9; ++a) out[k][a] = cell[a][k - a0];
      }
      cells += 1;
    });
  }
  std::size_t occupied = 0;  // every non-empty cell was visited
  for (std::size_t cc = 0; cc < grid.cellCount(); ++cc) occupied += grid.cellBegin(cc) < grid.cellEnd(cc) ? 1 : 0;
  CHECK(cells == occupied);
  return out;
}

// the same sums in double over every pair (sorted position k against every j), and how many neighbours
std::array<double, 9> bruteSums(const BoidsLanesInput& in, std::size_t n, std::size_t k, const BoidsZones& z,
                                int& neighbours) {
  std::array<double, 9> s{};
  neighbours = 0;
  for (std::size_t j = 0; j < n; ++j) {
    // the kernel's test in float: which pairs are in which zone
    const float fx = in.x[j] - in.x[k], fy = in.y[j] - in.y[k], fz = in.z[j] - in.z[k];
    const float d2 = fx * fx + fy * fy + fz * fz;
    if (j == k || !(d2 > 0.0f) || d2 > z.r3sq) continue;
    ++neighbours;
    const double len = std::sqrt(static_cast<double>(d2));
    const double ex = fx / len, ey = fy / len, ez = fz / len;
    if (d2 <= z.r1sq) {
      s[0] += ex, s[1] += ey, s[2] += ez;
    } else if (d2 <= z.r2sq) {
      s[3] += in.ux[j], s[4] += in.uy[j], s[5] += in.uz[j];
    } else if (in.ux[k] * ex + in.uy[k] * ey + in.uz[k] * ez >= z.cosHalfFov) {
      s[6] += ex, s[7] += ey, s[8] += ez;
    }
  }
  return s;
}

void checkAgainstBrute(const Cloud& c, const BoidsZones& zones, float r3, int minNeighbours) {
  UniformGrid grid;
  BoidsLanesInput in;
  std::vector<float> sorted[3];
  const std::size_t n = c.x.size();
  std::vector<std::vector<std::array<float, 9>>> bySet;
  for (const LaneSet set : swarmsim_test::laneSetsOfThisCpu()) {
    bySet.push_back(kernelSums(c, zones, r3, set, grid, in, sorted));
  }
  // every instruction set: the same bits
  for (std::size_t s = 1; s < bySet.size(); ++s) {
    INFO("lane set " << s);
    CHECK(std::memcmp(bySet[s].data(), bySet[0].data(), n * sizeof(bySet[0][0])) == 0);
  }
  int most = 0;
  double worst = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    int neighbours = 0;
    const std::array<double, 9> want = bruteSums(in, n, k, zones, neighbours);
    most = std::max(most, neighbours);
    for (int a = 0; a < 9; ++a) {
      // float sums of at most `neighbours` unit-length terms
      const double tol = 1e-6 * (4.0 + neighbours);
      worst = std::max(worst, std::abs(bySet[0][k][a] - want[a]) / tol);
    }
  }
  CHECK(most >= minNeighbours);
  CHECK(worst <= 1.0);
}

}  // namespace

TEST_CASE("boids kernel: the neighbour sums equal a brute-force sum, with the same bits on every lane set",
          "[boids][lanes]") {
  // the default zones (R1 0.05, R2 0.15, R3 0.3 m) and a 270-degree view
  const BoidsZones zones = {0.05f * 0.05f, 0.15f * 0.15f, 0.3f * 0.3f, static_cast<float>(std::cos(0.75 * M_PI))};
  SECTION("about ten neighbours each (the bench density)") {
    // 4000 agents in a 3.6 m cube: 86 per m^3, 9.7 within 0.3 m
    checkAgainstBrute(randomCloud(4000, 3.6f, 11), zones, 0.3f, 20);
  }
  SECTION("a dense clump: hundreds of neighbours per agent (the candidates' buffer grows)") {
    // 700 agents in a 0.2 m cube: each sees all the others
    checkAgainstBrute(randomCloud(700, 0.2f, 12), zones, 0.3f, 699);
  }
  SECTION("coincident agents are skipped, as is the agent itself") {
    Cloud c = randomCloud(300, 1.0f, 13);
    for (int i = 0; i < 50; ++i) {  // 50 pairs on the same spot
      c.x.push_back(c.x[static_cast<std::size_t>(i)]);
      c.y.push_back(c.y[static_cast<std::size_t>(i)]);
      c.z.push_back(c.z[static_cast<std::size_t>(i)]);
      c.ux.push_back(0.0f);
      c.uy.push_back(1.0f);
      c.uz.push_back(0.0f);
    }
    checkAgainstBrute(c, zones, 0.3f, 2);
  }
  SECTION("tiny swarms: fewer than a lane's eight agents, and just over (no load reads past the last agent)") {
    // all within 0.3 m of each other: every agent sees every other
    for (const std::size_t n : {2, 5, 7, 8, 9, 13}) {
      INFO(n << " agents");
      checkAgainstBrute(randomCloud(n, 0.15f, 14 + static_cast<unsigned>(n)), zones, 0.3f, static_cast<int>(n) - 1);
    }
  }
}
