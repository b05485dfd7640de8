#pragma once
// Gradient noise in the style of Perlin's improved noise (Perlin 2002, "Improving noise").
//
// The lattice is the integer grid. Each lattice corner q gets a pseudo-random gradient
// g(q), one of the 12 edge midpoints of a cube, (±1, ±1, 0), (±1, 0, ±1), (0, ±1, ±1),
// picked by hashing q through a permutation table of 0..255 shuffled from the seed.
// For p in the cell with lower corner q0 and offset t = p − q0 in [0, 1)^3:
//   noise(p) = Σ_{corners c} w_c(t) · g(q0 + c) · (t − c),
//   w_c(t)   = Π_a (c_a ? s(t_a) : 1 − s(t_a)),   s(t) = 6t^5 − 15t^4 + 10t^3  (quintic fade)
// so noise is C2, zero at every lattice point and periodic with period 256.
//
// Range: the largest value any gradient assignment can reach is
//   max_t Σ_c w_c(t) · (sum of the two largest |t_a − c_a|) ≈ 1.036354
// (found numerically, near t = (0.355, 0.482, 0.5)); the sum is divided by 1.0364 so the
// output is guaranteed to lie in [−1, 1].
#include <array>
#include <cstdint>

#include "core/vec.hpp"

namespace swarmsim {

class PerlinNoise3 {
 public:
  // the permutation table is a Fisher–Yates shuffle driven by splitmix64(seed), so the
  // same seed gives the same noise on every platform and standard library
  explicit PerlinNoise3(std::uint64_t seed);

  // noise value at p (lattice units), in [−1, 1]
  double operator()(const Vec3d& p) const;
  // the value as operator() gives it, and its exact gradient (per lattice unit)
  // in `grad`: the derivative of the interpolation above, fade'(t) = 30 t^2 (t − 1)^2
  double withGradient(const Vec3d& p, Vec3d& grad) const;

  // the points one batch call evaluates together, one per SIMD lane
  static constexpr int kLanes = 4;
  // withGradient of noises[0], ..., noises[count - 1] at the kLanes points (px[l], py[l], pz[l]), equal to it bit
  // for bit: noise k's value at point l in value[k * kLanes + l] (value may be null) and its gradient in
  // (gx, gy, gz)[k * kLanes + l]. The same operations in the same order on SIMD lanes (table look-ups per lane);
  // the lattice cell and the fades, which depend on the point only, once for all the noises. avx: with AVX
  // instructions, which the CPU must have (batchAvx()), else SSE2 (same bits).
  static void withGradientLanes(const PerlinNoise3* noises, int count, const double* px, const double* py,
                                const double* pz, double* value, double* gx, double* gy, double* gz, bool avx);
  // whether batches should use AVX: the CPU has it and SWARMSIM_NO_AVX is not set (read at each call, so a
  // test can compare the two paths)
  static bool batchAvx();

  // the points one wide batch call evaluates together: eight doubles of an AVX-512 register
  static constexpr int kWideLanes = 8;
  // withGradientLanes' gradients at kWideLanes points, the same bits: noise k's gradient at point l in
  // (gx, gy, gz)[k * kWideLanes + l]. The hashes are looked up per lane, the gradients' rows by vector
  // permutes. Only where batchWide() says so.
  // vbmi: the hashes by byte permutes (batchVbmi(); the same bits as without)
  static void withGradientWide(const PerlinNoise3* noises, int count, const double* px, const double* py,
                               const double* pz, double* gx, double* gy, double* gz, bool vbmi);
  // whether the CPU has AVX-512 F and the lanes are not limited (laneSet() == kAvx512: neither
  // SWARMSIM_NO_AVX512 nor a narrower setting; read at each call)
  static bool batchWide();
  // whether the CPU has AVX-512 VBMI (with BW and VL) and SWARMSIM_NO_VBMI is not set (read at each call)
  static bool batchVbmi();

 private:
  struct Lanes;  // the SIMD code of withGradientLanes, one entry per instruction set (noise.cpp)

  std::array<std::uint8_t, 512> perm_{};  // the shuffled 0..255 twice, so perm_[a + b] needs no wrap
};

}  // namespace swarmsim
