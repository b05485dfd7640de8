#pragma once
// The boids model's agent update (docs/models/boids.md#equations) after the neighbour sums, eight agents at a
// time on SIMD lanes (core/lanes.hpp: AVX or SSE chosen at run time, the same bits with each): the target
// velocity from the sums, the centre pull, the soft walls and the jitter (Box-Muller on lanes:
// logUnitLanes, cosSinTurnLanes), then the blend and the speed limits. Each agent's result depends on its own
// inputs only.
#include <cstddef>

#include "core/lanes.hpp"
#include "core/vec.hpp"

namespace swarmsim {

struct BoidsUpdateParams {
  float smin = 0.0f, smax = 0.0f;                                    // cruise and top speed (m/s)
  float fr = 0.0f, fa = 0.0f, ft = 0.0f;                             // zone weights (m/s per neighbour)
  float fc = 0.0f, invCr = 0.0f;                                     // centre pull (m/s) and 1 / its radius (0: none)
  float fw = 0.0f, margin = 1.0f;                                    // wall weight (m/s) and margin (m)
  float blend = 1.0f, noise = 0.0f;                                  // α and the jitter's σ k (m/s)
  Vec3 center = Vec3::Zero(), lo = Vec3::Zero(), hi = Vec3::Zero();  // centre, domain corners
};

// m agents, index i of each array: positions p, unit velocities u (the old heading), velocities v (read, then
// written with the new ones), the neighbour sums sums[0..8][i] (boidsCellSums: repulsion before its negation,
// alignment, attraction), and, where `jitter` is given (not null), four uniforms per agent in [0, 1) from its random
// stream: jitter[0..3][i], the Box-Muller draws (1 − u0, u1) and (1 − u2, u3).
struct BoidsUpdateRow {
  const float *px, *py, *pz;
  const float *ux, *uy, *uz;
  float *vx, *vy, *vz;
  const float* sums[9];
  const float* jitter[4];
};
void boidsUpdate(const BoidsUpdateRow& row, std::size_t m, const BoidsUpdateParams& p, LaneSet lanes);

// u[i] = normalizedOrZero(v[i]) for i < m, eight at a time where AVX is there (the same bits)
void unitVelocities(const float* vx, const float* vy, const float* vz, std::size_t m, float* ux, float* uy, float* uz,
                    LaneSet lanes);

}  // namespace swarmsim
