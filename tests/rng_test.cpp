// Philox4x32-10 known answers and the AgentRng streams built on it.
#include "core/rng.hpp"

#include <array>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <set>
#include <vector>

#include "core/rng_lanes.hpp"
#include "lane_sets.hpp"

using swarmsim::AgentRng;
using swarmsim::LaneSet;
using swarmsim::philox4x32;
using swarmsim::RngPurpose;
using Words = std::array<std::uint32_t, 4>;

namespace {

// a Random123 key (two 32-bit words) as the 64-bit seed philox4x32 takes:
// key word 0 is the low half of the seed (see philox4x32 in core/rng.hpp)
std::uint64_t seedFromKey(std::uint32_t k0, std::uint32_t k1) {
  return static_cast<std::uint64_t>(k0) | (static_cast<std::uint64_t>(k1) << 32);
}

std::vector<float> uniforms(AgentRng rng, int n) {
  std::vector<float> out;
  for (int i = 0; i < n; ++i) out.push_back(rng.uniform());
  return out;
}

}  // namespace

TEST_CASE("Philox4x32-10 Random123 known-answer vectors", "[rng]") {
  // Random123 kat_vectors: "philox4x32 10 <ctr x4> <key x2> <expected x4>"
  CHECK(philox4x32(Words{0, 0, 0, 0}, seedFromKey(0, 0)) == Words{0x6627e8d5u, 0xe169c58du, 0xbc57ac4cu, 0x9b00dbd8u});
  CHECK(philox4x32(Words{0xffffffffu, 0xffffffffu, 0xffffffffu, 0xffffffffu}, seedFromKey(0xffffffffu, 0xffffffffu)) ==
        Words{0x408f276du, 0x41c83b0eu, 0xa20bc7c6u, 0x6d5451fdu});
  CHECK(seedFromKey(0xffffffffu, 0xffffffffu) == 0xffffffffffffffffull);
  // the digits-of-pi vector has different key words, so it pins the key layout
  CHECK(philox4x32(Words{0x243f6a88u, 0x85a308d3u, 0x13198a2eu, 0x03707344u}, seedFromKey(0xa4093822u, 0x299f31d0u)) ==
        Words{0xd16cfe09u, 0x94fdccebu, 0x5001e420u, 0x24126ea1u});
  // and with the key words swapped the output must differ
  CHECK(philox4x32(Words{0x243f6a88u, 0x85a308d3u, 0x13198a2eu, 0x03707344u}, seedFromKey(0x299f31d0u, 0xa4093822u)) !=
        Words{0xd16cfe09u, 0x94fdccebu, 0x5001e420u, 0x24126ea1u});
}

TEST_CASE("AgentRng draws come from Philox on its counter", "[rng]") {
  // the first four uniforms are the four words of the first block, top 24 bits
  const std::uint64_t seed = 0x0123456789abcdefull;
  AgentRng rng(seed, 5, 17, RngPurpose::kJitter, 2);
  const Words w = philox4x32(Words{5u, 0u, 17u, (3u << 24) ^ (2u << 8)}, seed);
  for (int i = 0; i < 4; ++i) {
    CHECK(rng.uniform() == static_cast<float>(w[static_cast<std::size_t>(i)] >> 8) / 16777216.0f);
  }
}

TEST_CASE("AgentRng uniform lies in 0 to 1 with the right moments", "[rng]") {
  const int perAgent = 16;  // several blocks per stream
  const int agents = 8000;
  double sum = 0.0, sum2 = 0.0;
  float lo = 1.0f, hi = 0.0f;
  int bins[10] = {};
  for (int a = 0; a < agents; ++a) {
    AgentRng rng(42, 3, static_cast<std::uint32_t>(a), RngPurpose::kSpawnPosition);
    for (int i = 0; i < perAgent; ++i) {
      const float u = rng.uniform();
      lo = std::min(lo, u);
      hi = std::max(hi, u);
      sum += u;
      sum2 += static_cast<double>(u) * u;
      ++bins[std::min(9, static_cast<int>(u * 10.0f))];
    }
  }
  const double n = static_cast<double>(perAgent) * agents;
  const double mean = sum / n, var = sum2 / n - mean * mean;
  CHECK(lo >= 0.0f);
  CHECK(hi < 1.0f);
  // standard error of the mean: sqrt(1/12 / n) = 0.0008; allow ~6 sigma
  CHECK(mean == Approx(0.5).margin(0.005));
  CHECK(var == Approx(1.0 / 12.0).margin(0.003));
  // each decile holds 10% +- 0.5% (sigma 0.08%)
  for (int b : bins) CHECK(static_cast<double>(b) / n == Approx(0.1).margin(0.005));

  // uniform(a, b) maps into [a, b)
  AgentRng r2(1, 0, 0, RngPurpose::kJitter);
  for (int i = 0; i < 1000; ++i) {
    const float v = r2.uniform(-2.0f, 3.0f);
    CHECK((v >= -2.0f && v < 3.0f));
  }
}

TEST_CASE("AgentRng normals have mean 0 and variance 1", "[rng]") {
  const int agents = 20000;
  double s = 0, s2 = 0, s4 = 0;
  double c[3] = {0, 0, 0}, c2[3] = {0, 0, 0}, cross01 = 0, cross02 = 0, cross12 = 0;
  bool finite = true;
  for (int a = 0; a < agents; ++a) {
    AgentRng rng(7, 11, static_cast<std::uint32_t>(a), RngPurpose::kJitter);
    for (int i = 0; i < 4; ++i) {
      const double v = rng.normal();
      finite = finite && std::isfinite(v);
      s += v;
      s2 += v * v;
      s4 += v * v * v * v;
    }
    AgentRng r3(7, 12, static_cast<std::uint32_t>(a), RngPurpose::kJitter);
    for (int i = 0; i < 2; ++i) {
      const swarmsim::Vec3 v = r3.normal3();
      finite = finite && v.allFinite();
      for (int k = 0; k < 3; ++k) {
        c[k] += v[k];
        c2[k] += static_cast<double>(v[k]) * v[k];
      }
      cross01 += static_cast<double>(v[0]) * v[1];
      cross02 += static_cast<double>(v[0]) * v[2];
      cross12 += static_cast<double>(v[1]) * v[2];
    }
  }
  CHECK(finite);
  const double n = 4.0 * agents;
  // standard errors: mean 1/sqrt(n) = 0.0035, variance sqrt(2/n) = 0.005
  CHECK(s / n == Approx(0.0).margin(0.02));
  CHECK(s2 / n == Approx(1.0).margin(0.03));
  CHECK(s4 / n == Approx(3.0).margin(0.15));  // a normal's fourth moment
  const double m = 2.0 * agents;
  for (int k = 0; k < 3; ++k) {
    INFO("normal3 component " << k);
    CHECK(c[k] / m == Approx(0.0).margin(0.03));
    CHECK(c2[k] / m == Approx(1.0).margin(0.04));
  }
  CHECK(cross01 / m == Approx(0.0).margin(0.03));
  CHECK(cross02 / m == Approx(0.0).margin(0.03));
  CHECK(cross12 / m == Approx(0.0).margin(0.03));
}

TEST_CASE("AgentRng directions and balls", "[rng]") {
  double mean[3] = {0, 0, 0};
  const int n = 20000;
  for (int a = 0; a < n; ++a) {
    AgentRng rng(3, 0, static_cast<std::uint32_t>(a), RngPurpose::kSpawnVelocity);
    const swarmsim::Vec3 u = rng.unitVector();
    CHECK(u.norm() == Approx(1.0f).margin(1e-5));
    for (int k = 0; k < 3; ++k) mean[k] += u[k];
    const swarmsim::Vec3 b = rng.inUnitBall();
    CHECK(b.norm() <= 1.0f + 1e-6f);
  }
  for (int k = 0; k < 3; ++k) CHECK(mean[k] / n == Approx(0.0).margin(0.03));  // sigma 1/sqrt(3n) = 0.004
}

TEST_CASE("AgentRng streams are reproducible and independent", "[rng]") {
  const int draws = 12;  // three blocks
  const auto base = uniforms(AgentRng(9, 100, 5, RngPurpose::kJitter, 0), draws);

  SECTION("same key, same numbers") {
    CHECK(uniforms(AgentRng(9, 100, 5, RngPurpose::kJitter, 0), draws) == base);
    AgentRng a(9, 100, 5, RngPurpose::kJitter, 0), b(9, 100, 5, RngPurpose::kJitter, 0);
    for (int i = 0; i < 50; ++i) {
      const swarmsim::Vec3 va = a.normal3(), vb = b.normal3();
      CHECK(va == vb);
    }
  }
  SECTION("any change of seed, step, agent, purpose or stream changes the numbers") {
    const std::vector<std::vector<float>> others = {
        uniforms(AgentRng(10, 100, 5, RngPurpose::kJitter, 0), draws),
        uniforms(AgentRng(9 + (1ull << 32), 100, 5, RngPurpose::kJitter, 0), draws),  // high seed word
        uniforms(AgentRng(9, 101, 5, RngPurpose::kJitter, 0), draws),
        uniforms(AgentRng(9, 100 + (1ull << 32), 5, RngPurpose::kJitter, 0), draws),  // high step word
        uniforms(AgentRng(9, 100, 6, RngPurpose::kJitter, 0), draws),
        uniforms(AgentRng(9, 100, 5, RngPurpose::kSpawnPosition, 0), draws),
        uniforms(AgentRng(9, 100, 5, RngPurpose::kSpawnVelocity, 0), draws),
        uniforms(AgentRng(9, 100, 5, RngPurpose::kJitter, 1), draws),
    };
    for (std::size_t i = 0; i < others.size(); ++i) {
      INFO("variant " << i);
      int equal = 0;
      for (int k = 0; k < draws; ++k) equal += others[i][static_cast<std::size_t>(k)] == base[static_cast<std::size_t>(k)];
      CHECK(equal <= 1);  // 24-bit values: a coincidental match is ~1e-7 likely
    }
  }
  SECTION("successive blocks of one stream differ") {
    // every draw distinct (12 draws from 24-bit values: a repeat is ~4e-6 likely)
    CHECK(std::set<float>(base.begin(), base.end()).size() == base.size());
  }
  SECTION("many agents at one step: no two share a first draw pattern") {
    std::set<std::vector<float>> seen;
    for (std::uint32_t a = 0; a < 5000; ++a) seen.insert(uniforms(AgentRng(1, 0, a, RngPurpose::kJitter, 0), 2));
    CHECK(seen.size() == 5000u);
  }
}

TEST_CASE("firstUniforms gives AgentRng's first four uniforms of every agent on every lane set", "[rng][lanes]") {
  std::mt19937 gen(3);
  std::vector<std::uint32_t> ids;
  for (int i = 0; i < 1000; ++i) ids.push_back(static_cast<std::uint32_t>(gen()));
  ids[0] = 0;
  ids[1] = 0xffffffffu;
  for (const std::uint64_t seed : {std::uint64_t{0}, std::uint64_t{12345}, std::uint64_t{0xfedcba9876543210ull}}) {
    for (const std::uint64_t step : {std::uint64_t{0}, std::uint64_t{77}, std::uint64_t{0x1'0000'0005ull}}) {
      for (const std::size_t m : {std::size_t{0}, std::size_t{5}, std::size_t{17}, std::size_t{1000}}) {
        std::vector<float> want[4];
        for (std::size_t i = 0; i < m; ++i) {
          AgentRng rng(seed, step, ids[i], RngPurpose::kJitter, 3);
          for (auto& w : want) w.push_back(rng.uniform());
        }
        for (const LaneSet set : swarmsim_test::laneSetsOfThisCpu()) {
          std::vector<float> got[4];
          float* out[4];
          for (int w = 0; w < 4; ++w) {
            got[w].assign(m, -1.0f);
            out[w] = got[w].data();
          }
          swarmsim::firstUniforms(seed, step, ids.data(), m, RngPurpose::kJitter, 3, out, set);
          INFO("seed " << seed << ", step " << step << ", " << m << " agents, lane set " << static_cast<int>(set));
          for (int w = 0; w < 4; ++w)
            CHECK((m == 0 || std::memcmp(got[w].data(), want[w].data(), m * sizeof(float)) == 0));
        }
      }
    }
  }
}
