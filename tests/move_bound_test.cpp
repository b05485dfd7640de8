// The shape model's local move bound (lib/models/shape/move_bound.hpp), checked against every pair of insects:
// an insect within reach() of insect i at the end of the step changed its offset to i by at most local[i].
#include "models/shape/move_bound.hpp"

#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <random>
#include <vector>

#include "core/parallel.hpp"

using namespace swarmsim;

namespace {

struct Swarm {
  std::vector<float> x, y, z, move;  // move: 3 n + 1
  float lo[3], hi[3];
};

// n insects in a box of the given size; each moves by a rotation about the z axis (a swarm that turns:
// the farther from the axis, the larger its move), a shear along x that grows with z, and a random jitter
Swarm turning(std::size_t n, float size, float turn, float jitter, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, size), j(-jitter, jitter);
  Swarm s;
  s.move.assign(3 * n + 1, 0.0f);
  for (std::size_t k = 0; k < n; ++k) {
    s.x.push_back(u(rng));
    s.y.push_back(u(rng));
    s.z.push_back(u(rng));
    const float cx = s.x[k] - 0.5f * size, cy = s.y[k] - 0.5f * size;
    s.move[3 * k] = -turn * cy + turn * s.z[k] + j(rng);
    s.move[3 * k + 1] = turn * cx + j(rng);
    s.move[3 * k + 2] = j(rng);
  }
  for (int a = 0; a < 3; ++a) {
    const std::vector<float>& p = a == 0 ? s.x : a == 1 ? s.y : s.z;
    s.lo[a] = *std::min_element(p.begin(), p.end());
    s.hi[a] = *std::max_element(p.begin(), p.end());
  }
  return s;
}

double maxMove(const Swarm& s) {
  double m = 0.0;
  for (std::size_t k = 0; k < s.x.size(); ++k) {
    m = std::max(m, std::sqrt(static_cast<double>(s.move[3 * k]) * s.move[3 * k] +
                              static_cast<double>(s.move[3 * k + 1]) * s.move[3 * k + 1] +
                              static_cast<double>(s.move[3 * k + 2]) * s.move[3 * k + 2]));
  }
  return m * (1.0 + 1e-6);
}

// every pair within reach at the end: |d_j - d_i| <= local[i]; returns how many pairs were checked
std::size_t checkPairs(const Swarm& s, const std::vector<float>& local, double reach) {
  std::size_t pairs = 0;
  const std::size_t n = s.x.size();
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = 0; j < n; ++j) {
      if (i == j) continue;
      double e2 = 0.0, c2 = 0.0;
      for (int a = 0; a < 3; ++a) {
        const double p = (a == 0 ? s.x : a == 1 ? s.y : s.z)[j] - (a == 0 ? s.x : a == 1 ? s.y : s.z)[i];
        const double dd = static_cast<double>(s.move[3 * j + a]) - s.move[3 * i + a];
        e2 += (p + dd) * (p + dd);
        c2 += dd * dd;
      }
      if (std::sqrt(e2) > reach) continue;
      ++pairs;
      if (!(std::sqrt(c2) <= static_cast<double>(local[i]))) {
        FAIL_CHECK("pair " << i << ", " << j << ": offset changed by " << std::sqrt(c2) << " > local bound "
                           << local[i]);
        return pairs;
      }
    }
  }
  return pairs;
}

}  // namespace

TEST_CASE("local move bound: every insect within reach changed its offset by at most the bound, any thread count",
          "[shape][near_list]") {
  const int threadsBefore = threadCount();
  for (const int threads : {1, 2, 3}) {
    setThreadCount(threads);
    for (const std::size_t n : {std::size_t{1}, std::size_t{40}, std::size_t{3000}}) {
      CAPTURE(threads, n);
      const Swarm s = turning(n, 6.0f, 0.02f, 0.004f, static_cast<std::uint32_t>(n));
      const double mm = maxMove(s), edge = 0.6 + 2.0 * mm;
      std::vector<float> local(n, -1.0f);
      LocalMoveBound bound;
      REQUIRE(bound.compute(n, s.x.data(), s.y.data(), s.z.data(), s.lo, s.hi, s.move.data(), edge, mm, 1 << 20,
                            local.data()));
      REQUIRE(bound.reach() > 0.5);
      REQUIRE(bound.reach() < edge - 2.0 * mm);
      checkPairs(s, local, bound.reach());
      if (n == 3000) {
        // tighter than the global bound: the largest move relative to the middle of all, for every insect
        // (the swarm turns by 2 cm per metre from its axis, the blocks are 0.6 m)
        std::vector<float> sorted = local;
        std::sort(sorted.begin(), sorted.end());
        CHECK(sorted[n / 2] < 0.5 * mm);
        // and the bound is what the blocks give, identical for any thread count (min and max only)
        static std::vector<float> first;
        if (threads == 1) first = local;
        CHECK(local == first);
      }
    }
  }
  setThreadCount(threadsBefore);
}

TEST_CASE("local move bound: a box given larger than the insects', one point, a flat swarm, too many blocks",
          "[shape][near_list]") {
  Swarm s = turning(500, 3.0f, 0.05f, 0.01f, 9);
  const double mm = maxMove(s), edge = 0.5 + 2.0 * mm;
  std::vector<float> local(s.x.size());
  LocalMoveBound bound;
  SECTION("a larger box") {
    const float lo[3] = {-2.0f, -1.0f, -3.0f}, hi[3] = {5.0f, 4.0f, 2.0f};
    REQUIRE(bound.compute(s.x.size(), s.x.data(), s.y.data(), s.z.data(), lo, hi, s.move.data(), edge, mm, 1 << 20,
                          local.data()));
    CHECK(checkPairs(s, local, bound.reach()) > 500);
  }
  SECTION("every insect at one point") {
    std::fill(s.x.begin(), s.x.end(), 1.0f);
    std::fill(s.y.begin(), s.y.end(), 1.0f);
    std::fill(s.z.begin(), s.z.end(), 1.0f);
    const float p[3] = {1.0f, 1.0f, 1.0f};
    REQUIRE(bound.compute(s.x.size(), s.x.data(), s.y.data(), s.z.data(), p, p, s.move.data(), edge, mm, 1 << 20,
                          local.data()));
    CHECK(bound.blocks() == 1);
    CHECK(checkPairs(s, local, bound.reach()) == 500 * 499);
  }
  SECTION("a flat swarm") {
    std::fill(s.z.begin(), s.z.end(), 0.5f);
    s.lo[2] = s.hi[2] = 0.5f;
    REQUIRE(bound.compute(s.x.size(), s.x.data(), s.y.data(), s.z.data(), s.lo, s.hi, s.move.data(), edge, mm, 1 << 20,
                          local.data()));
    CHECK(checkPairs(s, local, bound.reach()) > 500);
  }
  SECTION("more blocks than allowed, or a box that is not finite: no bound") {
    CHECK_FALSE(bound.compute(s.x.size(), s.x.data(), s.y.data(), s.z.data(), s.lo, s.hi, s.move.data(), 0.01, mm, 1000,
                              local.data()));
    CHECK(bound.reach() < 0.0);
    const float inf[3] = {s.hi[0], INFINITY, s.hi[2]};
    CHECK_FALSE(bound.compute(s.x.size(), s.x.data(), s.y.data(), s.z.data(), s.lo, inf, s.move.data(), edge, mm,
                              1 << 20, local.data()));
  }
}
