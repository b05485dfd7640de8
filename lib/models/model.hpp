#pragma once
// The model interface. A model is created in two stages:
//   1. its ModelConfig is parsed from the swarm's `params` JSON (cheap, checks
//      every value; used by `swarmsim validate`);
//   2. ModelConfig::build() makes the Model, doing any precomputation.
// Model::step() reads the world, the swarm's current state and (if it looks at
// other swarms) their snapshots in StepInfo::seen, and writes only that
// swarm's state. It must be two-phase (every new velocity from the old
// state, then apply) and use counter-based random numbers, so results do not
// depend on the number of threads.
#include <memory>
#include <string>
#include <vector>

#include "core/json_reader.hpp"
#include "core/state_buffer.hpp"
#include "core/swarm_state.hpp"
#include "core/world.hpp"

namespace swarmsim {

class Model {
 public:
  virtual ~Model() = default;
  // advance the swarm by one time step world.dt
  virtual void step(const World& world, SwarmState& state, const StepInfo& info) = 0;
  // names of the per-frame statistics this model reports (e.g. "mde_fraction");
  // each becomes a dataset /swarms/<name>/stats/<stat> with one value per frame
  virtual std::vector<std::string> statNames() const { return {}; }
  // the statistics over the steps since the last call, in statNames() order
  virtual void takeFrameStats(std::vector<double>& values) { values.clear(); }
  // facts for `swarmsim bench` (grid sizes, preprocessing split...), a JSON object
  virtual Json benchInfo() const { return Json::object(); }
  // `swarmsim bench --skip`: the timed steps begin now, after untimed ones; the per-phase timers that
  // benchInfo reports start again from zero
  virtual void restartBenchTimers() {}
  // facts about the built model worth keeping with its output (e.g. how a
  // target mesh was scaled), a JSON object stored as the swarm's `model_facts`
  // attribute (docs/output.md); empty: none
  virtual Json facts() const { return Json::object(); }

  // Checkpoints (`swarmsim run --resume`, docs/architecture.md#checkpoints): a
  // model that carries anything from one step to the next besides the
  // SwarmState (a re-solved field, a per-insect choice, accumulated frame
  // statistics) writes it here and reads it back in loadState, which is called
  // on a freshly built model (after its precomputation) before the next step.
  // The resumed run must then be bit-identical to one that never stopped.
  // Whatever can be recomputed from the world, the parameters, the step and
  // the counter-based random numbers needs no saving. Default: nothing to save.
  virtual void saveState(StateOut& out) const { (void)out; }
  virtual void loadState(StateIn& in, const World& world) { (void)in, (void)world; }

  // A model that places its agents itself (ModelEntry::placesAgents, e.g. `replay`) sets their state
  // at simulated time `time` here; called once after the model is built, before frame 0. Others: unused.
  virtual void place(const World& world, SwarmState& state, double time) { (void)world, (void)state, (void)time; }
};

class ModelConfig {
 public:
  virtual ~ModelConfig() = default;
  virtual std::unique_ptr<Model> build(const World& world) const = 0;
  // a model whose registry entry says placesAgents: how many agents it places (Model::place)
  virtual std::int64_t placedAgents() const { return 0; }
};

// what a model's parser may know about the scenario (for defaults)
struct ModelContext {
  const World& world;
  const std::string& scenarioFile;     // relative file names in `params` resolve against its folder
  std::int64_t count;                  // agents of the swarm (0 for a model that places its agents)
  double seconds;                      // simulated time of the last frame (frames - 1 of them after frame 0)
  std::vector<std::string>& warnings;  // non-fatal findings, reported by run and validate
};

// one registered model: its scenario name and parser
struct ModelEntry {
  const char* name;
  const char* summary;
  std::shared_ptr<const ModelConfig> (*parse)(JsonReader& params, const ModelContext& context);
  // the model looks at the swarms named in its swarm's "sees" list (StepInfo::seen); "sees" on any other
  // model is refused
  bool looksAtOthers = false;
  // the model places its agents itself (ModelConfig::placedAgents, Model::place): its swarm has no "spawn"
  bool placesAgents = false;
};

// every registered model, in registry order
const std::vector<ModelEntry>& modelRegistry();
// the entry named `name`, or null
const ModelEntry* findModel(const std::string& name);

}  // namespace swarmsim
