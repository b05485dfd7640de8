#pragma once
// Where the pieces meet: scenario -> world (read-only) + swarm states -> model
// steps -> writer.
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/swarm_state.hpp"
#include "core/threads.hpp"
#include "io/checkpoint.hpp"
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
  // every model's Model::restartBenchTimers (bench: timing starts after untimed steps)
  void restartBenchTimers() {
    for (auto& m : models_) m->restartBenchTimers();
  }
  // per swarm, the models' statistics since the last call (see Model::takeFrameStats)
  void takeFrameStats(std::vector<std::vector<double>>& out);
  // the state to continue from (steps, swarms, the models' saveState); frames,
  // hash and scenario are the caller's to fill in. It points at the live
  // swarms: write it before the next step.
  CheckpointView checkpoint() const;
  // continue from a checkpoint of the same scenario (throws InputError if it does not fit)
  void restore(const Checkpoint& c, const std::string& file);

 private:
  World world_;
  std::vector<SwarmState> swarms_;
  std::vector<std::unique_ptr<Model>> models_;
  std::vector<SwarmState> snapshots_;  // of the swarms some model sees, taken at the start of each step
  std::vector<char> watched_;          // per swarm: seen by some model
  std::vector<SeenSwarms> seen_;       // per swarm: its "sees" list, pointing into snapshots_
  std::uint64_t step_ = 0;
  double preprocessSeconds_ = 0.0;
};

struct RunOptions {
  std::string output;    // empty: the scenario's output path
  bool force = false;    // overwrite an existing output
  bool resume = false;   // continue an interrupted run of this output, if there is one
  double checkpointSeconds = 30.0;  // wall time between checkpoints (0: after every frame)
  bool progress = false; // progress lines on stderr
  bool quiet = false;    // no summary line
  bool json = false;     // the summary as one JSON line (summaryJson) on stdout instead
};

struct RunResult {
  std::int64_t frames = 0;
  std::int64_t agents = 0;
  double wallSeconds = 0.0;
  std::string path;
  std::uintmax_t bytes = 0;
  bool interrupted = false;
  std::int64_t resumedFrom = -1;  // frames kept from the interrupted run (-1: a fresh run)
  bool alreadyComplete = false;   // --resume found the output complete: nothing was done
  std::int64_t steps = 0;         // time steps this run computed
  double stepSeconds = 0.0;       // wall time of the step loop (writing frames included)
};

// the run's summary for `run --json` (docs/cli.md#run)
nlohmann::json summaryJson(const RunResult& r);

// Run the scenario, writing every frame (frame 0 is the initial state, so
// `frames` frames take (frames - 1) * steps_per_frame steps). A checkpoint is
// written after frame 0 and then every `checkpointSeconds`; SIGINT, SIGTERM
// and SIGHUP stop the run after the step in progress with a valid output of
// the frames written and a checkpoint beside it; SIGUSR1 asks for a checkpoint
// after the step in progress. docs/cli.md#resume.
RunResult runScenario(const Scenario& scenario, const RunOptions& options);

// install the handlers for SIGINT, SIGTERM, SIGHUP (stop), SIGUSR1
// (checkpoint) and ignore SIGXFSZ (a file-size limit becomes a write error);
// clears any earlier request
void installStopHandlers();

}  // namespace swarmsim
