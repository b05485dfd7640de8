#pragma once
// Field model (Wang, Jin, Deng, Zhou 2014, "Inherent noise-aware insect swarm
// simulation"): every insect follows one precomputed velocity field
//   V(x) = ∇×N(x) - ∇C(x)/|∇C(x)| s0                                   (eq. 9)
// with
//   N = α P + (1 - α)(n·P) n,  α = ramp(d(x)/d0)                        (eq. 2, 3)
//   P = gain (l/scale) (P1(u), P2(u), P3(u)),  u = scale x / l            (eq. 1, our reading)
//   |∇C| = A + B g(x),  g = h(φ(x) / (2a)),  C = 0 on the goals           (eq. 4, 6, 7)
// where P1..3 are Perlin noises with three seeds, l the cost grid's cell edge,
// d the distance to the nearest boundary (obstacles and the domain walls), n its
// normal, φ the signed distance to the obstacles (eq. 5), h the bell of eq. 6,
// a the cell diagonal; C is solved by fast marching with obstacle cells
// impassable. After each move, minimum distance enforcement (MDE, section 6)
// pushes apart pairs closer than min_distance, and agents are kept out of
// obstacles and inside the domain. Each swarm has its own goals and therefore
// its own cost field; a goal can follow keyframes (the cost field is re-solved
// when it has moved by half a cell); phototaxis adds, with a probability per
// step, an extra speed toward a light (section 7). The curl noise can be
// replaced by plain Perlin or white noise (section 7.1 baselines).
// docs/models/field.md has the derivations and every parameter.
#include <array>
#include <memory>
#include <string>
#include <vector>

#include "models/model.hpp"

namespace swarmsim {

struct GoalSpec {
  enum class Kind { kSphere, kBox };
  Kind kind = Kind::kSphere;
  Vec3d center = Vec3d::Zero();  // sphere centre, or box centre
  double radius = 0.0;           // sphere
  Vec3d halfSize = Vec3d::Zero();  // box
  std::vector<double> keyTimes;    // s, increasing (empty: static)
  std::vector<Vec3d> keyCenters;   // centre at each key time

  // centre at time t (piecewise linear between keyframes, held outside them)
  Vec3d centerAt(double t) const;
  bool contains(const Vec3d& p, const Vec3d& c) const;
};

enum class NoiseKind { kCurl, kPerlin, kWhite };
// which pairs MDE examines: all pairs closer than min_distance, or (the paper's
// rule) only pairs within the same cell of the cost grid's size
enum class MdePairs { kNeighbours, kSameCell };

struct FieldParams {
  double speed = 1.5;                       // s0, m/s
  std::array<int, 3> costCells = {0, 0, 0};  // cost grid over the domain (required)
  int costOrder = 1;                        // fast marching's order of accuracy (1 or 2; fast_marching.hpp)
  NoiseKind noise = NoiseKind::kCurl;
  double scale = 0.4;                       // noise frequency per cost cell
  double gain = 0.25;                       // noise speed scale, m/s
  std::array<std::uint64_t, 3> seeds = {1, 2, 3};
  std::array<int, 3> noiseCells = {0, 0, 0};  // noise grid (default: 3 samples per noise unit)
  double rampDistance = 0.0;                // d0, m (default: one cost cell)
  double pathWeight = 0.6;                  // A
  double repulsionWeight = 0.4;             // B
  std::vector<GoalSpec> goals;
  double minDistance = 0.0;                 // MDE threshold, m (0: off)
  double agentRadius = 0.0;                 // clearance kept from obstacles, m (default: min_distance / 2)
  MdePairs mdePairs = MdePairs::kSameCell;
  bool phototaxis = false;
  Vec3d light = Vec3d::Zero();              // m
  double phototaxisProbability = 0.0;       // per step
  double phototaxisSpeed = 0.0;             // m/s
};

FieldParams readFieldParams(JsonReader& params, const ModelContext& context);
std::shared_ptr<const ModelConfig> parseField(JsonReader& params, const ModelContext& context);
std::unique_ptr<Model> makeField(const FieldParams& params, const World& world);

// the repulsion bell of eq. 6 (Wyvill et al. 1986): 1 for r < 0,
// 1 - 4/9 r^6 + 17/9 r^4 - 22/9 r^2 on [0, 1], 0 for r > 1
double bell(double r);

}  // namespace swarmsim
