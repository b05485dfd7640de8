#pragma once
// Where the pieces meet: scenario -> world (read-only) + swarm states -> model
// steps -> writer.
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/swarm_state.hpp"
#include "io/scenario.hpp"
#include "models/model.hpp"

namespace swarmsim {

// spawn a swarm's agents in its region (counter-based random numbers)
SwarmState spawnSwarm(const SwarmSpec& spec, std::uint64_t seed, std::uint32_t swarmIndex);

class Simulation {
 public:
  // spawns the swarms and builds the models (their precomputation)
  explicit Simulation(const Scenario& scenario);
  // advance every swarm by one step
  void step();

  const World& world() const { return world_; }
  const std::vector<SwarmState>& swarms() const { return swarms_; }
  std::uint64_t stepsDone() const { return step_; }
  double time() const { return static_cast<double>(step_) * world_.dt; }
  double preprocessSeconds() const { return preprocessSeconds_; }
  const Model& model(std::size_t swarm) const { return *models_[swarm]; }
  // per swarm, the models' statistics since the last call (see Model::takeFrameStats)
  void takeFrameStats(std::vector<std::vector<double>>& out);

 private:
  World world_;
  std::vector<SwarmState> swarms_;
  std::vector<std::unique_ptr<Model>> models_;
  std::uint64_t step_ = 0;
  double preprocessSeconds_ = 0.0;
};

struct RunOptions {
  std::string output;    // empty: the scenario's output path
  bool force = false;    // overwrite an existing output
  bool progress = false; // progress lines on stderr
  bool quiet = false;    // no summary line
};

struct RunResult {
  std::int64_t frames = 0;
  std::int64_t agents = 0;
  double wallSeconds = 0.0;
  std::string path;
  std::uintmax_t bytes = 0;
  bool interrupted = false;
};

// Run the scenario, writing every frame (frame 0 is the initial state, so
// `frames` frames take (frames - 1) * steps_per_frame steps). SIGINT/SIGTERM
// stop it at the next frame boundary with a valid file.
RunResult runScenario(const Scenario& scenario, const RunOptions& options);

// install SIGINT/SIGTERM handlers that request a stop at the next frame
// boundary; clears any earlier request
void installStopHandlers();

}  // namespace swarmsim
