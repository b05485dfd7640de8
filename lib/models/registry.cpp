// The one place models are registered: one line per model.
#include "models/boids/boids.hpp"
#include "models/bswarm/bswarm.hpp"
#include "models/fastswarm/fastswarm.hpp"
#include "models/field/field.hpp"
#include "models/model.hpp"
#include "models/replay/replay.hpp"
#include "models/shape/shape.hpp"

namespace swarmsim {

const std::vector<ModelEntry>& modelRegistry() {
  static const std::vector<ModelEntry> entries = {
      {"boids", "three-zone boids (repulsion, alignment, attraction), blog2018", &parseBoids},
      {"field", "curl noise + fast-marching cost field with MDE, wang2014", &parseField},
      {"bswarm", "zonal forces + friction + stimuli + curl noise, ORCA collision avoidance, wang2015", &parseBswarm},
      {"shape", "insects forming keyframed target meshes along a B-spline path, chen2019", &parseShape},
      {"fastswarm", "velocities picked from real (v, a) samples by energy minimisation, Xiang et al.", &parseFastswarm, true},
      {"replay", "agents that follow recorded tracks (CSV or HDF5), for mixing real and simulated insects", &parseReplay, false, true},
  };
  return entries;
}

const ModelEntry* findModel(const std::string& name) {
  for (const auto& e : modelRegistry()) {
    if (name == e.name) return &e;
  }
  return nullptr;
}

}  // namespace swarmsim
