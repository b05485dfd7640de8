#pragma once
// Scenario: the plain description of a run, loaded from JSON and fully checked.
// See docs/scenario.md for the schema.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/json_reader.hpp"
#include "core/world.hpp"
#include "models/model.hpp"

namespace swarmsim {

struct SpawnRegion {
  enum class Kind { kBox, kSphere, kTracks, kModel };  // kModel: no spawn, the model places its agents
  Kind kind = Kind::kBox;
  Vec3d min = Vec3d::Zero(), max = Vec3d::Zero();  // box, metres
  Vec3d center = Vec3d::Zero();                    // sphere, metres
  double radius = 0.0;                             // sphere, metres
  // tracks: the individuals present at one sample of a track file (eval/tracks.hpp), in the order the file
  // first names them: 3 per agent, m and m/s
  std::string file;
  std::int64_t sample = 0;
  std::shared_ptr<const std::vector<float>> positions, velocities;
};

struct SwarmSpec {
  std::string name;
  std::int64_t count = 0;
  SpawnRegion spawn;
  double initialSpeed = 0.0;  // m/s, random directions
  std::string model;
  std::shared_ptr<const ModelConfig> config;  // parsed model parameters
  std::vector<std::uint32_t> sees;            // indices of the swarms its model looks at ("sees"), in list order
};

struct OutputSpec {
  std::string path;                     // resolved (absolute or relative to the working directory)
  std::vector<std::string> quantities;  // subset of {"position", "velocity"}
  int compression = 0;                  // gzip level 0-9 (0 = none)
};

struct Scenario {
  std::string file;  // the scenario file as given (kStdinName for standard input)
  std::vector<std::string> warnings;  // non-fatal findings (e.g. a mesh that is not watertight)
  std::string name;
  std::uint64_t seed = 0;
  double dt = 0.0;
  std::int64_t frames = 0;
  std::int64_t stepsPerFrame = 1;
  Aabb domain;
  std::shared_ptr<const Obstacles> obstacles;  // loaded meshes, spheres, boxes
  std::vector<SwarmSpec> swarms;
  OutputSpec output;
  Json resolved;  // the scenario with every default filled in, every file path absolute
  std::shared_ptr<InputFiles> inputs;  // the mesh files it read (stored in the output)

  World world() const { return World{domain, dt, seed, obstacles}; }
  std::int64_t agentCount() const;
};

// Apply one `--set PATH=VALUE` override to raw scenario JSON. PATH uses dots
// and [index] (e.g. swarms[0].count); VALUE is JSON, or a plain string.
void applyOverride(Json& scenario, const std::string& assignment);
// Scale every swarm's count so the total is `agents`, and the spawn regions and
// domain about their centres so the density stays the same (for bench).
void rescaleAgents(Json& scenario, std::int64_t agents, const std::string& file);

// Check raw scenario JSON and build the Scenario. `file` names the source in
// error messages and relative paths resolve against its folder (against the
// working folder for kStdinName). Mesh files embedded in `inputs` are taken
// from there instead of the disk.
Scenario parseScenario(const Json& json, const std::string& file, std::shared_ptr<InputFiles> inputs = nullptr);
// read ("-": standard input), override, parse
Scenario loadScenario(const std::string& file, const std::vector<std::string>& overrides = {});

}  // namespace swarmsim
