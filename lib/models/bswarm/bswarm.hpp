#pragma once
// BSwarm force model (Wang, Ren, Jin, Manocha 2015, "BSwarm: biologically-
// plausible dynamics model of insect swarms"). Per insect and step:
//   a_i = F_int + F_fric + F_res + F_xi                                  (eq. 1-3, unit mass)
//   F_int  = Σ_k λ_k / N_k Σ_{j in zone k} ( g_k r̂_ji + (1 - |g_k|) v̂_ji )   (eq. 4; interaction.hpp)
//   F_fric = -γ |v_i| v_i
//   F_res  = λ_res Σ_e H(r_res - r_ie) ( s_e R(n, θ_i) r̂_ie - (1 - s_e) r̂_ie ),  r̂_ie from e to i
//   F_xi   = gain · C(r_i)   (curl noise; or Perlin, white, Gaussian white)
//   v_pref = v_i + a_i dt, then ORCA (lib/orca) turns the preferred velocities into
//   collision-free ones, and x_i += v_i dt.
// Stimuli are points or spheres, static or keyframed, predators (s_e = 1, escape)
// or attractors (s_e = 0, pursuit); one may be attached ahead of every insect
// (the paper's bats). Parameters can follow a schedule of keyframes (phase
// transition). docs/models/bswarm.md has the equations, units and every parameter.
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "models/model.hpp"
#include "models/params_util.hpp"

namespace swarmsim {

struct StimulusSpec {
  enum class Kind { kPredator, kAttractor };
  Kind kind = Kind::kAttractor;
  double radius = 0.0;        // 0: a point; > 0: a sphere (distance is to its surface)
  Keyed3 path;                // centre over time (one key: static)
  double visualRange = -1.0;  // r_res of this stimulus, m (< 0: the swarm's r_res)
  double weight = 1.0;        // multiplies λ_res
  bool solid = false;         // spheres only: also an obstacle for ORCA
};

// a stimulus carried ahead of each insect (the paper's bats): at x_i + distance R(axis, angle) v̂_i
struct AttachedStimulus {
  bool enabled = false;
  StimulusSpec::Kind kind = StimulusSpec::Kind::kAttractor;
  double distance = 1.0;        // m
  double angle = 0.0;           // degrees, about `axis`
  Vec3d axis = Vec3d::UnitZ();  // unit
  double weight = 1.0;
};

enum class BswarmNoise { kCurl, kPerlin, kWhite, kGaussian };

// the parameters a schedule may change over time
struct BswarmDynamic {
  double gamma = 10.0;      // friction coefficient γ, 1/m
  double gain = 1.0;        // noise force magnitude, m/s^2
  double lambdaRep = 5.0;   // λ_rep, m/s^2
  double lambdaAli = 0.0;   // λ_ali, m/s^2
  double lambdaAtt = 10.0;  // λ_att, m/s^2
  double rRep = 0.2;        // absolute radii, m
  double rAli = 0.2;
  double rAtt = 5.0;
  double lambdaRes = 0.0;  // λ_res, m/s^2
  double rRes = 0.0;       // visual range, m
};

struct BswarmSchedule {
  // per scheduled parameter (a field of BswarmDynamic by name): its keys
  struct Track {
    std::string name;
    std::vector<double> times, values;
  };
  std::vector<Track> tracks;
  void apply(double t, BswarmDynamic& d) const;
};

struct BswarmParams {
  BswarmDynamic dyn;
  BswarmSchedule schedule;
  // noise
  BswarmNoise noise = BswarmNoise::kCurl;
  double scale = 1.0;      // noise lattice cells per noise unit
  double noiseUnit = 1.0;  // length of the noise unit, m
  std::array<std::uint64_t, 3> seeds = {1, 2, 3};
  std::array<int, 3> noiseCells = {0, 0, 0};  // default: 3 samples per lattice cell, capped
  // stimuli
  std::vector<StimulusSpec> stimuli;
  AttachedStimulus attached;
  Vec3d escapeAxis = Vec3d::UnitZ();  // n of R(n, θ)
  double escapeAngleMin = -90.0;      // θ range, degrees
  double escapeAngleMax = 0.0;
  // collision avoidance (ORCA)
  double radius = 0.01;           // m
  double neighborDistance = 0.2;  // m
  int maxNeighbors = 10;
  double timeHorizon = 1.0;                 // s
  double timeHorizonObstacle = 0.5;         // s
  double maxSpeed = 2.0;                    // m/s
  std::array<int, 3> sdfCells = {0, 0, 0};  // obstacle/wall distance grid (default: from the domain)
  // far-field approximation of F_int (0: exact)
  double theta = 0.0;
};

BswarmParams readBswarmParams(JsonReader& params, const ModelContext& context);
std::shared_ptr<const ModelConfig> parseBswarm(JsonReader& params, const ModelContext& context);
std::unique_ptr<Model> makeBswarm(const BswarmParams& params, const World& world);

// F_fric = -γ |v| v
Vec3 frictionForce(const Vec3& v, float gamma);

// F_res for one insect at x with velocity v and escape angle θ (radians): the sum
// over the stimuli it sees (and the attached one) of λ_res w (s_e R(n, θ) r̂_ie - (1 - s_e) r̂_ie)
struct ResponseInputs {
  float lambdaRes = 0.0f;  // λ_res
  float rRes = 0.0f;       // default visual range, m
  const std::vector<StimulusSpec>* stimuli = nullptr;
  const Vec3* centers = nullptr;  // each stimulus's centre now
  const AttachedStimulus* attached = nullptr;
  Vec3 escapeAxis = Vec3::UnitZ();
};
Vec3 responseForce(const ResponseInputs& in, const Vec3& x, const Vec3& v, float theta);

// |mean of the unit velocities| (0 for an empty swarm; zero velocities count as
// zero vectors); summed in fixed blocks, so independent of threads
// (`scratch`, if given, holds the per-block sums so repeated calls do not allocate)
double polarisation(const float* vx, const float* vy, const float* vz, std::size_t n,
                    std::vector<Vec3d>* scratch = nullptr);

}  // namespace swarmsim
