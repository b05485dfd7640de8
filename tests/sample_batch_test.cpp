// sampleBatch (lib/fields/sample_batch.hpp): the same bits as Grid3<Vec3>::Sampler point by point, on every lane
// set (each padded with a 0), for points inside the grid, on and beyond its borders, in its last cells, and not finite.
#include "fields/sample_batch.hpp"

#include <array>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

namespace {

using swarmsim::Grid3;
using swarmsim::GridSpec;
using swarmsim::Vec3;

Grid3<Vec3> randomGrid(const std::array<int, 3>& n, unsigned seed) {
  GridSpec spec = GridSpec::covering(swarmsim::Vec3d(-1.0, 2.0, 0.5), swarmsim::Vec3d(3.0, 4.5, 2.0), n);
  Grid3<Vec3> g(spec, Vec3::Zero());
  std::mt19937 gen(seed);
  std::uniform_real_distribution<float> u(-5.0f, 5.0f);
  for (Vec3& v : g.data) v = Vec3(u(gen), u(gen), u(gen));
  return g;
}

}  // namespace

TEST_CASE("sampleBatch gives the sampler's bits point by point on every lane set", "[grid3]") {
  // grids with one cell along an axis too (its neighbour offset is 0)
  const auto n = GENERATE(std::array<int, 3>{9, 7, 5}, std::array<int, 3>{1, 6, 4}, std::array<int, 3>{5, 1, 1});
  const Grid3<Vec3> g = randomGrid(n, static_cast<unsigned>(n[0] * 100 + n[1] * 10 + n[2]));
  const auto s = g.sampler();
  std::mt19937 gen(7);
  // points over a box larger than the grid's (-1..3, 2..4.5, 0.5..2), so some lie beyond each border
  std::uniform_real_distribution<float> ux(-2.0f, 4.0f), uy(1.0f, 5.5f), uz(0.0f, 2.5f);
  std::vector<float> x, y, z;
  for (int i = 0; i < 1000; ++i) {
    x.push_back(ux(gen));
    y.push_back(uy(gen));
    z.push_back(uz(gen));
  }
  // exactly on the first and last cell centres and on the borders, in the last cell (the sampler's own path
  // for the data's last value), and not finite
  const float inf = std::numeric_limits<float>::infinity(), nan = std::numeric_limits<float>::quiet_NaN();
  const Vec3 special[] = {{-1.0f, 2.0f, 0.5f},   {3.0f, 4.5f, 2.0f}, {2.99f, 4.49f, 1.99f}, {2.9f, 4.4f, 1.9f},
                          {-0.8f, 2.2f, 0.6f},   {nan, 3.0f, 1.0f},  {1.0f, inf, 1.0f},     {1.0f, 3.0f, -inf},
                          {1e30f, -1e30f, 1.0f}, {0.0f, 3.0f, nan}};
  for (const Vec3& p : special) {
    x.push_back(p.x());
    y.push_back(p.y());
    z.push_back(p.z());
  }
  const std::size_t count = x.size();
  std::vector<Vec3> want(count);
  for (std::size_t i = 0; i < count; ++i) want[i] = s(Vec3(x[i], y[i], z[i]));
  // the samples are not all alike (the test would pass on a constant)
  CHECK(want[0] != want[1]);
  for (const auto lanes :
       {swarmsim::LaneSet::kSse, swarmsim::LaneSet::kAvx, swarmsim::LaneSet::kAvx2, swarmsim::LaneSet::kAvx512}) {
    if (lanes > swarmsim::laneSet()) continue;
    // every count of points, for the eights and the tail
    for (const std::size_t m :
         {std::size_t{0}, std::size_t{1}, std::size_t{7}, std::size_t{8}, std::size_t{13}, count}) {
      // the sampler's bits, then 0; nothing written past the m points
      std::vector<swarmsim::PaddedVec3> got(count, swarmsim::PaddedVec3{{9.0f, 9.0f, 9.0f, 9.0f}});
      swarmsim::sampleBatch(s, x.data(), y.data(), z.data(), m, got.data(), lanes);
      INFO("lanes " << static_cast<int>(lanes) << ", " << m << " points");
      for (std::size_t i = 0; i < m; ++i) {
        CHECK(std::memcmp(got[i].v, want[i].data(), sizeof(Vec3)) == 0);
        CHECK(got[i].v[3] == 0.0f);
      }
      if (m < count) {
        CHECK(Vec3(got[m].v[0], got[m].v[1], got[m].v[2]) == Vec3(9.0f, 9.0f, 9.0f));
        CHECK(got[m].v[3] == 9.0f);
      }
    }
  }
}
