#pragma once
// FASTSWARM (Xiang, Yao, Wang, Jin): each step every agent takes the velocity v of the reference sample
// d_v = [v, a] (real insects, reference.hpp) that minimises
//   E = E_rep + E_oa + E_cos + E_dir + E_acc + E_env + E_n + E_user                  (eq. 2-15; energy.hpp)
// over the samples of its speed group and the neighbouring groups (about `candidates` samples), then
// p += v Δt; with stimuli also E_env (eq. 11-12: attractors, and predators within d_danger, which switch a
// startled agent to its "in danger" weights), with user control E_user toward the agent's goal keypoint
// (eq. 14-15). Neighbours come from the step's uniform grid, together with the agents of the swarms named in
// the swarm's "sees" list (a `replay` swarm of real insects, say: section 5.2.3's mixing), which count in
// E_rep and E_oa like its own. docs/models/fastswarm.md has the equations as implemented and every parameter.
#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "models/fastswarm/energy.hpp"
#include "models/fastswarm/reference.hpp"
#include "models/model.hpp"
#include "models/params_util.hpp"

namespace swarmsim {

// user control (section 5.1.2): each agent traverses `points` in order, heading for its goal keypoint and
// taking the next one once within `radius`. Closed: after the last comes the first; open: the agent turns
// back at either end. Bidirectional: agents with odd ids go the other way round.
struct KeypointCurve {
  std::vector<Vec3d> points;  // at least 2, m
  bool closed = true;
  bool bidirectional = true;
  double radius = 0.3;  // m
};

// one agent's progress along the curve
struct KeypointTask {
  std::int32_t goal = -1;  // index of the goal keypoint (-1: not started)
  std::int32_t dir = 1;    // +1 or -1
};

namespace fastswarm {
// start a task for an agent at p with id `id`: the nearest keypoint (ties: the lower index) is its goal
KeypointTask startTask(const KeypointCurve& curve, const Vec3& p, std::uint32_t id);
// the task after one step at p: the next keypoint once p is within the radius of the goal (one per step)
void advanceTask(const KeypointCurve& curve, const Vec3& p, KeypointTask& task);
}  // namespace fastswarm

// a stimulus (eq. 11-12): an attractor draws the agents' heading toward it; a predator startles the agents
// within d_danger of it (of its surface, for a sphere)
struct FastswarmStimulus {
  bool predator = false;
  double radius = 0.0;  // 0: a point
  Keyed3 path;          // centre over time
};

struct FastswarmParams {
  std::string referencePath;  // resolved against the scenario's folder
  std::shared_ptr<const fastswarm::Reference> reference;
  fastswarm::EnergyParams energy;  // ρ, weights, d_rep, d_att,1 (dt: the scenario's)
  double dAtt2 = 0.6;              // d_att,2, m: outer radius of the attraction zone
  std::int64_t candidates = 300;   // k: samples searched per agent (whole speed groups about its own)
  // also search the sample that followed the agent's current one in its real track (Reference::next): not in
  // the paper; lets an agent go on flying a real insect's motion while nothing pulls it away
  bool successors = false;
  // with successors: the successor is taken when its E is below this many times the window's least E (1: only
  // when it is lower; larger: an agent keeps flying its real insect's motion until the other terms pull harder
  // than that). Not in the paper
  float successorMargin = 1.0f;
  std::optional<Vec3d> center;     // the swarm centre of E_cos; none: the swarm's centroid each step
  double noiseScale = 0.5;         // lattice cell of the curl noise, m
  std::optional<KeypointCurve> control;  // user control (E_user, eq. 14-15)
  std::vector<FastswarmStimulus> stimuli;
  // the weights of a startled agent (Table 1's "in danger" row): each set value replaces the weight
  std::optional<float> dangerRep, dangerOa, dangerCos, dangerDir, dangerAcc, dangerN;
  std::array<std::uint64_t, 3> seeds = {1, 2, 3};
};

FastswarmParams readFastswarmParams(JsonReader& params, const ModelContext& context);
std::shared_ptr<const ModelConfig> parseFastswarm(JsonReader& params, const ModelContext& context);
std::unique_ptr<Model> makeFastswarm(const FastswarmParams& params, const World& world);

namespace fastswarm {
// the groups searched for an agent of speed s: 2h + 1 whole groups about its own (h from k and the group
// size), shifted inward at the ends of the speed range; [first, last) in samples
void candidateRange(const Reference& ref, double speed, std::int64_t k, std::size_t& first, std::size_t& last);
}  // namespace fastswarm

}  // namespace swarmsim
