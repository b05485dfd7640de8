#pragma once
// The shape model's per-insect update (eq. 1, 6-7, Newton's second law and the top speed), eight insects at a
// time on SIMD lanes (core/lanes.hpp: AVX or SSE chosen at run time). Every lane does the scalar code's
// operations in the scalar code's order (Eigen's 3-vector norm is sqrt(x² + (y² + z²))), so the result is the
// same bit for bit on every lane set and for any split of the insects into blocks. Likewise each insect's sample
// point at the step's time, eight at a time on AVX2.
#include <array>
#include <cstddef>
#include <cstdint>

#include "core/lanes.hpp"

namespace swarmsim {

// what the update reads and writes, by sorted position k (the arrays of the step)
struct InsectUpdate {
  std::array<const float *, 3> x{};       // positions at the start of the step
  std::array<const float *, 3> v{};       // velocities at the start of the step
  std::array<const float *, 3> noise{};   // each insect's curl noise (eq. 4)
  std::array<const float *, 3> sample{};  // each insect's sample point (read only when shaped)
  std::array<float *, 3> nv{};            // out: the new velocities
  std::array<float *, 3> t{};             // out: the moved positions x + v dt (before MDE, obstacles and walls)
  float alpha = 0.7f;            // α of eq. 1
  float wDis = 0.0f;             // ω_dis of eq. 6
  float invRange = 1.0f;         // 1 / the influence range of eq. 7, 1/m
  float maxSpeed = 0.75f;        // m/s
  float dt = 0.0f;               // s
  bool shaped = false;           // F_ext's terms (F_con, F_dis) apply
};

// For the insects first + i, i in [0, count): with F_int = (fInt[0][i], fInt[1][i], fInt[2][i]) and F_con's
//   F_int' = F_int + F_cur,  F_ext = 0 + F_con + F_dis (shaped only; F_dis of shape.hpp's distanceForce),
//   v' = v + (α F_int' + (1 − α) F_ext) dt, then v' scaled to the top speed if faster,
// into nv and t = x + v' dt. The obstacle ramp (eq. 8-9) is the caller's (it may change v' and t after this).
void updateInsects(const InsectUpdate &u, std::size_t first, std::size_t count, const float *const fInt[3],
                   const float *const fCon[3], LaneSet lanes);

// what the write of the step's end reads and writes, by sorted position k
struct InsectWrite {
  std::array<const float *, 3> t{};       // the moved positions (updateInsects' t, after the obstacle ramp)
  std::array<const float *, 3> start{};   // the positions at the start of the step (for `move`)
  std::array<const float *, 3> nv{};      // the new velocities
  std::array<const float *, 3> target{};  // each insect's sample point (read only when shaped)
  const std::uint32_t *ids = nullptr;
  float lo[3] = {}, hi[3] = {};  // the domain
  bool addZero = false;          // x = t + 0 (MDE's push of an insect with no one to push it), else x = t
  bool shaped = false;
  std::array<float *, 3> p{}, v{};  // out: the state's positions and velocities
  std::uint32_t *id = nullptr;      // out: the state's ids
  float *move = nullptr;            // out, unless null: x − start, three floats an insect
  std::uint8_t *moved = nullptr;    // out: 0 (not pushed)
  float *speed = nullptr;           // out: |nv|
  float *err = nullptr;             // out (shaped only): |target − x|
};

// For k in [first, first + count), the step's end of an insect that neither MDE nor an obstacle moves: x = t (+ 0
// where addZero) clamped to the domain as Eigen's cwiseMax(lo).cwiseMin(hi) clamps it (std::max, std::min), then
// the writes above, with the norms as Eigen's. The caller redoes the others.
void writeInsects(const InsectWrite &w, std::size_t first, std::size_t count, LaneSet lanes);

// the sample points of a step: keyframe interpolation between two keys, then the path's placement
struct TargetPlacement {
  const float *keyA = nullptr;  // the samples' positions at the two keys, x, y, z of each (3 floats a sample)
  const float *keyB = nullptr;
  std::size_t samples = 0;  // how many samples each key has (every index given is below it)
  float f = 0.0f;       // the interpolation weight of key B
  bool placed = false;  // false: no path (the placement is the identity)
  float rot[9] = {};    // the path's rotation, row by row
  float shift[3] = {};  // where the path is
  float pivot[3] = {};  // the path's start
};

// For k in [first, first + count): with i = sample[k], p = a + f (b − a) (a, b: sample i at keys A and B), the
// sample point shift + rot (p − pivot) (p itself unless placed) into (tx[k], ty[k], tz[k]); the products summed
// as Eigen's Matrix3f times Vector3f sums them, r0 q0 + (r1 q1 + r2 q2). On AVX2 (kAvx2, kAvx512) by gathers,
// where 3 samples fits in 31 bits (up to 715 million samples), else one at a time.
void placeTargets(const TargetPlacement &t, const std::uint32_t *sample, std::size_t first, std::size_t count,
                  float *tx, float *ty, float *tz, LaneSet lanes);

}  // namespace swarmsim
