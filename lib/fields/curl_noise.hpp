#pragma once
// Curl-noise velocity field of wang2014, section 4 (after Bridson et al. 2007,
// "Curl-noise for procedural fluid flow").
//
//   P(x) = gain · (unit / scale) · (P1(u), P2(u), P3(u)),   u = scale · x / unit      (eq. 2 input)
//   N(x) = α P + (1 − α) (n · P) n,   α = ramp(d(x) / d0)                              (eq. 2)
//   ramp(r) = 15/8 r − 10/8 r^3 + 3/8 r^5 for 0 ≤ r < 1, 1 for r ≥ 1, 0 for r ≤ 0        (eq. 3)
//   V_l = ∇ × N                                                                         (eq. 1)
//
// P1..P3 are PerlinNoise3 with three seeds. `unit` is the length in metres of one grid
// unit (the cost grid's cell edge) and `scale` the noise frequency in lattice cells per
// grid unit; the factor unit/scale makes |∇ × P| ~ gain (m/s) whatever the scale.
// d(x) is the signed distance to the obstacles (negative inside) and n = ∇d/|∇d|. Far from
// obstacles α = 1 and N = P; at the surface α = 0, only the normal part of P survives, and
// its curl ∇(n·P) × n is tangential, so the flow does not cross the boundary.
//
// The discrete curl uses central differences, whose operators commute, so the central
// divergence of the discrete curl vanishes (up to rounding) two cells away from the border.
#include <array>
#include <cstddef>
#include <cstdint>

#include "core/vec.hpp"
#include "fields/grid3.hpp"
#include "fields/noise.hpp"

namespace swarmsim {

// eq. 3, the smooth ramp from 0 (r ≤ 0) to 1 (r ≥ 1); C1 at r = 1
double ramp(double r);

struct NoiseParams {
  double scale = 0.1;                              // noise lattice cells per grid unit (> 0)
  double gain = 1.0;                               // velocity magnitude, m/s
  std::array<std::uint64_t, 3> seeds = {1, 2, 3};  // one per component P1, P2, P3
  double unit = 1.0;                               // metres per grid unit (> 0)
  double d0 = 1.0;                                 // ramp distance, metres (> 0)
};

// P, N and the plain noise at arbitrary points (the grid functions below use it)
class NoisePotential {
 public:
  // throws std::invalid_argument unless scale, unit and d0 are positive and finite
  explicit NoisePotential(const NoiseParams& params);

  // (P1, P2, P3)(u), u = scale · x / unit: each component in [−1, 1]
  Vec3d noise(const Vec3d& x) const;
  // P(x), the unblended potential
  Vec3d raw(const Vec3d& x) const { return noise(x) * potentialFactor_; }
  // N(x), blended toward the obstacles of `sdf` (sampled trilinearly; null = no obstacles)
  Vec3d operator()(const Vec3d& x, const Grid3<float>* sdf) const;
  // ∇ × P(x), exact (from the noises' analytic gradients): the curl where the blend is 1
  Vec3d curlRaw(const Vec3d& x) const;
  // curlRaw at the n points (x[i], y[i], z[i]) into (cx[i], cy[i], cz[i]), equal to it bit for bit, computed
  // PerlinNoise3::kLanes points at a time on SIMD lanes (avx as in PerlinNoise3::withGradientLanes), or
  // kWideLanes at a time where avx and wide are set (wide: PerlinNoise3::batchWide(), which reads the environment,
  // asked once by the caller; vbmi: PerlinNoise3::batchVbmi(), likewise)
  void curlRawBatch(const double* x, const double* y, const double* z, std::size_t n, double* cx, double* cy,
                    double* cz, bool avx, bool wide, bool vbmi) const;
  double d0() const { return params_.d0; }

 private:
  NoiseParams params_;
  std::array<PerlinNoise3, 3> perlin_;
  double frequency_;        // scale / unit, lattice cells per metre
  double potentialFactor_;  // gain · unit / scale
};

// N at the cell centres of spec (parallel); `sdf` may be null
Grid3<Vec3> noisePotential(const GridSpec& spec, const NoiseParams& params, const Grid3<float>* sdf);

// ∇ × potential on its own grid: central differences inside, second-order one-sided at
// the border (first-order on an axis with 2 cells, zero derivative on an axis with 1)
Grid3<Vec3> curl(const Grid3<Vec3>& potential);

// the baseline of section 7.1, plain Perlin noise used as a velocity: gain · (P1, P2, P3)(u)
Grid3<Vec3> perlinVelocity(const GridSpec& spec, const NoiseParams& params);

// ∇ · v at cell (i, j, k) with the same differences as curl (central inside)
float divergence(const Grid3<Vec3>& v, int i, int j, int k);

}  // namespace swarmsim
