#pragma once
// Shape-constrained flying insects (Chen, Wang, Li, Wang, Hu 2019, "A robust
// multi-agent model for large-scale controllable shape constrained simulation
// of flying insects"). Per insect i and step (unit mass):
//   F_i = α F_internal + (1 − α) F_external                                   (eq. 1)
//   F_internal = F_int + F_cur
//     F_int = Σ_k ω_k / N_k Σ_{j in zone k} ( S_k r̂_ij + (1 − S_k²) û_ji )   (eq. 2-3; bswarm's interaction.hpp)
//     F_cur = ∇ × (η p(r_i / ρ)),  p = three Perlin noises                    (eq. 4; noise_field.hpp)
//   F_external = F_con + F_dis
//     F_con = w_con / N_i Σ_{j: M_ij < k h} r̂_ji exp(−M_ij² / 2σ²),  h = sqrt(A / N), σ = ω h   (eq. 5)
//     F_dis = ω_dis (4 (d − 0.5)³ + 0.5) unit(s_i − r_i)  for 0 < d ≤ 1, else 0,  d = |s_i − r_i| / L_dis  (eq. 6-7)
//   v ← clamp(v + F dt, max speed); near obstacles v ← v − (1 − ramp(D / L)) n min(n·v, 0)  (eq. 8-9)
//   x ← x + v dt, then minimum distance enforcement and obstacle clearance.
// s_i is the insect's sample point on the target mesh (stratified sampling,
// near-optimal assignment); targets are keyframed meshes (an animated sequence
// of one topology keeps each sample's barycentric coordinates; a new topology
// re-assigns), optionally carried along a cubic B-spline path.
// docs/models/shape.md has the equations as implemented, our readings of the
// garbled ones, units and every parameter.
#include <array>
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "geometry/mesh.hpp"
#include "models/model.hpp"

namespace swarmsim {

// one target keyframe: from `time` on (s), the swarm forms `mesh`
struct ShapeKey {
  double time = 0.0;
  std::shared_ptr<const TriangleMesh> mesh;  // placed in the world (metres), scaled for the swarm's spacing
  bool sameTopology = false;                 // same vertex count and faces as the previous key: animated, interpolated
  double scaleUp = 1.0;                      // the factor the mesh was enlarged by to keep the minimum spacing
  Vec3d scaleCentre = Vec3d::Zero();         // about this point
};

struct ShapePathSpec {
  std::vector<Vec3d> points;  // control points, m (empty: no path)
  double speed = 1.0;         // m/s along the curve
  double start = 0.0;         // s: when the shape starts moving
  bool turn = true;           // the shape turns (about z) with the curve's heading
};

struct ShapeParams {
  double alpha = 0.7;  // α, eq. 1: weight of the internal force, in [0, 1]
  // interaction zones (eq. 2-3): radii in m, weights in m/s^2
  double rRep = 0.3, rAli = 10.0, rAtt = 30.0;
  double wRep = 0.2, wAli = 3.0, wAtt = 13.0;
  // F_int's neighbours: the `neighbours` nearest insects within r_att (section 7: "nearest neighbors
  // search ... when computing the attractive force"); 0: every insect within r_att (eq. 2 read literally),
  // with the far-field approximation `theta` (0: exact; bswarm's interaction.hpp)
  int neighbours = 10;
  double theta = 1.0;
  // curl noise (eq. 4)
  double rho = 0.32;    // ρ, m: the noise's length scale (lattice cell)
  double eta = 0.125;   // η, m^2/s^2: the potential's magnitude (|F_cur| ~ η/ρ)
  std::array<std::uint64_t, 3> seeds = {1, 2, 3};
  std::array<int, 3> noiseCells = {0, 0, 0};  // default: 3 samples per lattice cell when that fits
  // shape-constrained force (eq. 5)
  double k = 2.0;      // neighbour threshold k h (Manhattan)
  double omega = 0.9;  // σ = ω h
  double wCon = 1.0;   // weight of F_con (1 in the paper)
  // distance force (eq. 6-7)
  double wDis = 4.0;           // ω_dis, m/s^2
  double disRange = 0.0;       // L_dis, m: the distance that normalises d (0: the domain's diagonal)
  double maxSpeed = 0.75;      // m/s
  double minDistance = 0.05;   // MDE distance between insects, m (0: off); also the smallest sample spacing
  double obstacleRange = 1.0;  // L, m: the obstacle ramp's influence length (eq. 8-9)
  double agentRadius = 0.01;   // clearance kept from obstacles, m
  std::array<int, 3> sdfCells = {0, 0, 0};  // obstacle distance grid (default: from the domain)
  // the near lists' skin (near_list.hpp): lists are built at (1 + skin) times the radius needed. Speed
  // only: any value gives the same bits
  double listSkin = 0.3;
  // the grid keeps its cells while the insects have moved less than this many cells since it was built (0:
  // a new grid every step); speed only
  double gridDrift = 0.25;
  std::uint64_t sampleSeed = 0;             // seed of the stratified sampling (default: the scenario's)
  std::vector<ShapeKey> keys;               // at least one
  std::int64_t count = 1;                   // insects of the swarm (one sample each)
  ShapePathSpec path;
};

ShapeParams readShapeParams(JsonReader& params, const ModelContext& context);
std::shared_ptr<const ModelConfig> parseShape(JsonReader& params, const ModelContext& context);
std::unique_ptr<Model> makeShape(const ShapeParams& params, const World& world);

// eq. 6's magnitude profile: 4 (d − 0.5)³ + 0.5 for 0 < d ≤ 1, else 0 (H(d) of eq. 7 folded in)
inline float distanceProfile(float d) {
  if (!(d > 0.0f && d <= 1.0f)) return 0.0f;
  const float e = d - 0.5f;
  return 4.0f * e * e * e + 0.5f;
}

// F_dis (eq. 6-7) on an insect at x with sample point s: ω_dis profile(|s − x| / range) toward s
inline Vec3 distanceForce(const Vec3& x, const Vec3& s, float wDis, float invRange) {
  const Vec3 to = s - x;
  const float e = to.norm();
  return e > 0.0f ? Vec3(to * (wDis * distanceProfile(e * invRange) / e)) : Vec3::Zero();
}

// F_int (eq. 2-3) of one insect over a given set of neighbours: add(d, d2, dv) per
// neighbour j with d = r_j − r_i, d2 = |d|², dv = v_j − v_i; then
// force() = Σ_k ω_k / N_k Σ_{j in zone k} (S_k d̂ + (1 − S_k²) dv̂) with zones
// rep [0, r_rep) S = −1, ali [r_rep, r_ali) S = 0, att [r_ali, r_att] S = +1
// (beyond r_att: no zone). A zero d or dv adds a zero vector but counts.
struct ZonalSum {
  float rRep2, rAli2, rAtt2;
  float w[3];
  Vec3 sum[3] = {Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};
  int count[3] = {0, 0, 0};
  ZonalSum(float rRep, float rAli, float rAtt, float wRep, float wAli, float wAtt)
      : rRep2(rRep * rRep), rAli2(rAli * rAli), rAtt2(rAtt * rAtt), w{wRep, wAli, wAtt} {}
  void add(float dx, float dy, float dz, float d2, float dvx, float dvy, float dvz) {
    if (!(d2 <= rAtt2)) return;
    if (d2 < rAli2 && d2 >= rRep2) {  // alignment: toward the neighbour's velocity
      const float v2 = dvx * dvx + dvy * dvy + dvz * dvz;
      if (v2 > 0.0f) sum[1] += Vec3(dvx, dvy, dvz) / std::sqrt(v2);
      ++count[1];
      return;
    }
    const int zone = d2 < rRep2 ? 0 : 2;
    if (d2 > 0.0f) sum[zone] += Vec3(dx, dy, dz) * ((zone == 0 ? -1.0f : 1.0f) / std::sqrt(d2));
    ++count[zone];
  }
  Vec3 force() const {
    Vec3 f = Vec3::Zero();
    for (int z = 0; z < 3; ++z) {
      if (count[z] > 0) f += sum[z] * (w[z] / static_cast<float>(count[z]));
    }
    return f;
  }
};

// F_con (eq. 5) of one insect, one neighbour at a time: add(d) with d = r_j − r_i
// (any candidate; those at Manhattan distance M >= threshold, or at the insect's
// own position, are skipped), then force(w_con) = w_con / N Σ −d̂ exp(−M² / 2σ²)
struct ShapeConstraintSum {
  float threshold, inv2s2;  // k h and 1 / (2 σ²)
  Vec3 sum = Vec3::Zero();
  int count = 0;
  ShapeConstraintSum(float thresholdManhattan, float sigma)
      : threshold(thresholdManhattan), inv2s2(1.0f / (2.0f * sigma * sigma)) {}
  void add(float dx, float dy, float dz, float d2) {
    const float m = std::abs(dx) + std::abs(dy) + std::abs(dz);
    if (!(m < threshold) || !(d2 > 0.0f)) return;
    sum -= Vec3(dx, dy, dz) * (std::exp(-m * m * inv2s2) / std::sqrt(d2));
    ++count;
  }
  Vec3 force(float wCon) const { return count > 0 ? Vec3(sum * (wCon / static_cast<float>(count))) : Vec3::Zero(); }
};

}  // namespace swarmsim
