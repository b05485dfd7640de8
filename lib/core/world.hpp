#pragma once
// The read-only world every model sees: domain bounds and time stepping.
// Built once from the scenario; never changed by a step.
#include <cstdint>
#include <memory>
#include <vector>

#include "core/vec.hpp"

namespace swarmsim {

struct Obstacles;  // geometry/obstacles.hpp

struct Aabb {
  Vec3d min = Vec3d::Zero();
  Vec3d max = Vec3d::Zero();
  Vec3d center() const { return 0.5 * (min + max); }
  Vec3d extent() const { return max - min; }
};

struct World {
  Aabb domain;             // metres
  double dt = 0.0;         // seconds per step
  std::uint64_t seed = 0;  // scenario seed
  std::shared_ptr<const Obstacles> obstacles;  // never null once built from a scenario
};

struct SwarmState;  // core/swarm_state.hpp

// The other swarms a model looks at (its swarm's "sees" list, docs/architecture.md#swarms-that-see-each-other):
// read-only snapshots taken at the start of the step, before any swarm moved, in the order of the list. An
// agent whose position is not finite is absent at that step (a replayed track that has not started yet).
struct SeenSwarms {
  std::vector<const SwarmState*> swarms;
  std::size_t size() const { return swarms.size(); }
  bool empty() const { return swarms.empty(); }
};

// what a model needs to know about the step it is taking
struct StepInfo {
  std::uint64_t step = 0;          // index of the step being taken (0 = first)
  std::uint32_t swarmIndex = 0;    // which swarm of the scenario, for random streams
  double time = 0.0;               // simulated time at the start of the step, s
  const SeenSwarms* seen = nullptr;  // the swarms this one sees (null or empty: none)
};

}  // namespace swarmsim
