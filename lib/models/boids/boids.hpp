#pragma once
// Three-zone boids in 3-D (blog2018 "Swarm behaviour", after Reynolds 1987).
//
// Zones around agent i, with widths that add up (radii R1 < R2 < R3):
//   repulsion   0  < d <= R1 = w_rep
//   alignment   R1 < d <= R2 = w_rep + w_ali
//   attraction  R2 < d <= R3 = w_rep + w_ali + w_att, only for neighbours inside
//               the field of view: angle(v_i, x_j - x_i) <= fov / 2
// Target velocity (every term is a velocity in m/s; per-zone weights are summed
// once per neighbour, as in the blog):
//   u_i = s v̂_i + f_r Σ_rep (x_i - x_j)/d + f_a Σ_ali v̂_j + f_t Σ_att (x_j - x_i)/d
//         + f_c min(1, |c - x_i|/R_c) (c - x_i)/|c - x_i| + f_w w(x_i) + σ k ξ_i
// with w the soft-wall push (linear in the depth inside the wall margin) and ξ a
// standard normal 3-vector (counter-based). Then, with α = 1 - exp(-dt/τ)
// (α = 1 for τ = 0, the blog's instantaneous update),
//   v_i' = v_i + (u_i - v_i) α
// where k = sqrt((2 - α)/α) makes σ the stationary standard deviation of the
// noise part of the velocity whatever dt is,
// and v_i' is clamped to s <= |v_i'| <= s_max; finally x_i' = x_i + v_i' dt.
#include <memory>

#include "models/model.hpp"

namespace swarmsim {

struct BoidsParams {
  double speed = 0.3;            // s: cruising and minimum speed, m/s
  double maxSpeed = 1.0;         // s_max: maximum speed, m/s
  double repulsionZone = 0.05;   // w_rep = R1, m
  double alignmentZone = 0.10;   // w_ali, m (R2 = R1 + w_ali)
  double attractionZone = 0.15;  // w_att, m (R3 = R2 + w_att)
  double fieldOfView = 270.0;    // full attraction view angle, degrees
  double repulsion = 1.0;        // f_r, m/s per neighbour
  double alignment = 0.01;       // f_a, m/s per neighbour
  double attraction = 0.0005;      // f_t, m/s per neighbour
  double centering = 0.1;        // f_c: pull toward `center`, m/s
  double centeringRadius = 0.0;  // R_c: inside it the pull falls linearly to 0, m (0 = constant, the blog)
  Vec3d center = Vec3d::Zero();  // c, m (default: domain centre)
  double wallMargin = 0.0;       // soft-wall band inside the domain, m (default: 10% of smallest extent)
  double wallForce = 1.0;        // f_w: push at the domain boundary (depth = margin), m/s
  double jitter = 0.0;           // σ: std. dev. of the random part of the velocity per axis, m/s
  double responseTime = 0.0;     // τ: velocity relaxation time, s (0 = instantaneous)
};

BoidsParams readBoidsParams(JsonReader& params, const ModelContext& context);
std::shared_ptr<const ModelConfig> parseBoids(JsonReader& params, const ModelContext& context);
std::unique_ptr<Model> makeBoids(const BoidsParams& params);

}  // namespace swarmsim
