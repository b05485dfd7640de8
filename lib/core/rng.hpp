#pragma once
// Counter-based random numbers (Philox4x32-10, Salmon et al. 2011, "Parallel
// random numbers: as easy as 1, 2, 3"). A draw is a pure function of
// (seed, step, agent, purpose), so results never depend on thread count or order.
#include <array>
#include <cmath>
#include <cstdint>

#include "core/vec.hpp"

namespace swarmsim {

// what a random number is used for; each purpose gets an independent stream
enum class RngPurpose : std::uint32_t {
  kSpawnPosition = 1,
  kSpawnVelocity = 2,
  kJitter = 3,
  kNoise = 4,
  kPhototaxis = 5,
  kEscape = 6,
  kSurfaceSample = 7,  // shape model: stratified samples of a target mesh
  kBaseline = 8,       // eval: the Ornstein-Uhlenbeck baseline swarm (eval/baseline.hpp)
};

// Philox4x32's round multipliers and key increments (also core/rng_lanes.cpp's, on lanes)
inline constexpr std::uint32_t kPhiloxM0 = 0xD2511F53u, kPhiloxM1 = 0xCD9E8D57u;
inline constexpr std::uint32_t kPhiloxW0 = 0x9E3779B9u, kPhiloxW1 = 0xBB67AE85u;

namespace detail {
inline void philoxRound(std::array<std::uint32_t, 4>& c, const std::array<std::uint32_t, 2>& k) {
  const std::uint64_t p0 = std::uint64_t{kPhiloxM0} * c[0];
  const std::uint64_t p1 = std::uint64_t{kPhiloxM1} * c[2];
  c = {static_cast<std::uint32_t>(p1 >> 32) ^ c[1] ^ k[0], static_cast<std::uint32_t>(p1),
       static_cast<std::uint32_t>(p0 >> 32) ^ c[3] ^ k[1], static_cast<std::uint32_t>(p0)};
}
}  // namespace detail

// Philox4x32-10: four 32-bit random words from a 128-bit counter and a 64-bit key
inline std::array<std::uint32_t, 4> philox4x32(std::array<std::uint32_t, 4> ctr, std::uint64_t seed) {
  std::array<std::uint32_t, 2> key = {static_cast<std::uint32_t>(seed), static_cast<std::uint32_t>(seed >> 32)};
  for (int round = 0; round < 10; ++round) {
    if (round > 0) {
      key[0] += kPhiloxW0;
      key[1] += kPhiloxW1;
    }
    detail::philoxRound(ctr, key);
  }
  return ctr;
}

// The random stream of one agent at one step for one purpose. `stream` tells
// swarms (or other users) apart within a purpose. Counter layout: word 0-1 the
// step, word 2 the agent id, word 3 = purpose << 24 | stream << 8 | block, so a
// stream has 256 blocks (1,024 words) and `stream` must be < 65,536.
class AgentRng {
 public:
  AgentRng(std::uint64_t seed, std::uint64_t step, std::uint32_t agent, RngPurpose purpose, std::uint32_t stream = 0)
      : seed_(seed),
        ctr_{static_cast<std::uint32_t>(step), static_cast<std::uint32_t>(step >> 32), agent,
             firstWord3(purpose, stream)} {}

  // word 3 of a stream's first block
  static constexpr std::uint32_t firstWord3(RngPurpose purpose, std::uint32_t stream) {
    return (static_cast<std::uint32_t>(purpose) << 24) ^ (stream << 8);
  }
  // a random word's uniform in [0, 1): its top 24 bits, exactly
  static constexpr float kUniformScale = 1.0f / 16777216.0f;
  static constexpr int kUniformShift = 8;

  // uniform in [0, 1)
  float uniform() {
    if (used_ == 4) refill();
    return static_cast<float>(words_[used_++] >> kUniformShift) * kUniformScale;
  }
  // uniform in [a, b)
  float uniform(float a, float b) { return a + (b - a) * uniform(); }
  // standard normal (Box-Muller)
  float normal() {
    const float u1 = 1.0f - uniform();  // (0, 1]
    const float u2 = uniform();
    return std::sqrt(-2.0f * std::log(u1)) * std::cos(6.2831853f * u2);
  }
  // three independent standard normals (Box-Muller on one Philox block)
  Vec3 normal3() {
    const float u1 = 1.0f - uniform(), u2 = uniform(), u3 = 1.0f - uniform(), u4 = uniform();
    const float r1 = std::sqrt(-2.0f * std::log(u1)), r2 = std::sqrt(-2.0f * std::log(u3));
    return {r1 * std::cos(6.2831853f * u2), r1 * std::sin(6.2831853f * u2), r2 * std::cos(6.2831853f * u4)};
  }
  // uniform direction on the unit sphere
  Vec3 unitVector() {
    const float z = uniform(-1.0f, 1.0f);
    const float phi = 6.2831853f * uniform();
    const float r = std::sqrt(std::max(0.0f, 1.0f - z * z));
    return {r * std::cos(phi), r * std::sin(phi), z};
  }
  // uniform point in the unit ball
  Vec3 inUnitBall() {
    const float r = std::cbrt(uniform());
    return unitVector() * r;
  }

 private:
  void refill() {
    words_ = philox4x32(ctr_, seed_);
    ctr_[3] += 1;  // low byte of word 3 counts blocks within one stream
    used_ = 0;
  }
  std::uint64_t seed_;
  std::array<std::uint32_t, 4> ctr_;
  std::array<std::uint32_t, 4> words_{};
  int used_ = 4;
};

}  // namespace swarmsim
