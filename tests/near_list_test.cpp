// The shape model's neighbour lists (lib/models/shape/near_list.hpp): sortById puts sorted positions in
// ascending order of their ids on every lane set (the rank counts of AVX2 or AVX-512 for short lists, std::sort
// else), and a list built from the grid holds exactly the points within its radius, in id order, whatever the
// lanes.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cstdint>
#include <numeric>
#include <random>
#include <vector>

#include "core/lanes.hpp"
#include "lane_sets.hpp"
#include "models/shape/near_list.hpp"
#include "spatial/uniform_grid.hpp"

using namespace swarmsim;

TEST_CASE("near lists: sortById orders positions by id on every lane set, at every length", "[shape][near_list]") {
  std::mt19937 rng(7);
  // ids of 5,000 points: a shuffled range with some ids at the top of the 32-bit range (the unsigned compare)
  std::vector<std::uint32_t> idOf(5000);
  std::iota(idOf.begin(), idOf.end(), 0u);
  for (std::size_t i = 0; i < 40; ++i) idOf[i] = 0xffffffffu - static_cast<std::uint32_t>(i);
  std::shuffle(idOf.begin(), idOf.end(), rng);
  int checked = 0, wrong = 0;
  for (const LaneSet lanes : swarmsim_test::laneSetsOfThisCpu()) {
    // lengths around the lanes (8) and the rank sort's limit (128), and beyond it
    for (const std::size_t m : {0, 1, 2, 7, 8, 9, 15, 16, 17, 40, 63, 64, 65, 127, 128, 129, 300}) {
      for (int trial = 0; trial < 20; ++trial) {
        std::vector<std::uint32_t> all(idOf.size());
        std::iota(all.begin(), all.end(), 0u);
        std::shuffle(all.begin(), all.end(), rng);
        std::vector<std::uint32_t> pos(all.begin(), all.begin() + static_cast<std::ptrdiff_t>(m));
        std::vector<std::uint32_t> want = pos;
        std::sort(want.begin(), want.end(), [&](std::uint32_t a, std::uint32_t b) { return idOf[a] < idOf[b]; });
        std::vector<std::uint64_t> keys;
        sortById(pos, idOf.data(), keys, lanes);
        ++checked;
        wrong += pos == want ? 0 : 1;
      }
    }
  }
  CHECK(checked == static_cast<int>(swarmsim_test::laneSetsOfThisCpu().size()) * 17 * 20);
  CHECK(wrong == 0);
}

TEST_CASE("near lists: a built list holds the points within its radius, in id order, on every lane set",
          "[shape][near_list]") {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(-4.0f, 4.0f);
  const std::size_t n = 3000;
  std::vector<float> x(n), y(n), z(n);
  for (std::size_t i = 0; i < n; ++i) {
    x[i] = u(rng);
    y[i] = u(rng);
    z[i] = u(rng);
  }
  UniformGrid grid;
  grid.build(x.data(), y.data(), z.data(), n, 0.7f);
  // ids by sorted position: a shuffle
  std::vector<std::uint32_t> idOf(n);
  std::iota(idOf.begin(), idOf.end(), 0u);
  std::shuffle(idOf.begin(), idOf.end(), rng);
  const float* sx = grid.sortedX().data();
  const float* sy = grid.sortedY().data();
  const float* sz = grid.sortedZ().data();
  int lists = 0, wrong = 0;
  for (const LaneSet lanes : swarmsim_test::laneSetsOfThisCpu()) {
    NearLists nl;
    nl.reset(n, 200, 0.3f);
    std::vector<std::uint32_t> scratch;
    std::vector<std::uint64_t> keys;
    for (std::uint32_t k = 0; k < n; k += 7) {
      for (const float r : {0.3f, 0.9f, 1.6f}) {  // a few, some dozens, more than the 200 of a slot
        std::size_t m = 0;
        const std::uint32_t* got = nl.build(k, r, grid, idOf.data(), scratch, keys, m, lanes);
        std::vector<std::uint32_t> want;
        for (std::uint32_t j = 0; j < n; ++j) {
          const float dx = sx[j] - sx[k], dy = sy[j] - sy[k], dz = sz[j] - sz[k];
          if (j != k && dx * dx + dy * dy + dz * dz <= r * r) want.push_back(j);
        }
        std::sort(want.begin(), want.end(), [&](std::uint32_t a, std::uint32_t b) { return idOf[a] < idOf[b]; });
        ++lists;
        wrong += std::vector<std::uint32_t>(got, got + m) == want ? 0 : 1;
      }
    }
  }
  CHECK(lists > 1000);
  CHECK(wrong == 0);
}
