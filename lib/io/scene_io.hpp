#pragma once
// The scene and the input files stored in an output (docs/output.md#scene-and-inputs):
//   /scene/obstacles/NNNN   every obstacle, in scenario order, as a world-space triangle mesh
//                           (spheres and boxes tessellated), for viewers and exports;
//   /inputs/NNNN            the bytes of every mesh file (OBJ) the scenario read, with its path,
//                           so that `swarmsim run --from OUT.h5` re-runs the stored scenario anywhere.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/input_files.hpp"
#include "io/hdf5_handle.hpp"
#include "io/scenario.hpp"

namespace swarmsim {

// one obstacle of /scene/obstacles
struct SceneObstacle {
  std::string name;    // "0000", "0001", ...
  std::string type;    // "mesh", "sphere", "box"
  std::string params;  // the scenario's obstacle entry, resolved, as compact JSON
  std::vector<double> vertices;        // 3 per vertex, metres
  std::vector<std::uint32_t> faces;    // 3 per triangle, 0-based
};

// write /scene and /inputs into an open file being created; throws OutputError
void writeScene(hid_t file, const Scenario& scenario);
// the obstacles of an output file's /scene (empty when it has none: older files); throws InputError
std::vector<SceneObstacle> readScene(const std::string& path);

// what `run --from` needs: the stored resolved scenario and the stored input files
struct StoredScenario {
  nlohmann::json scenario;
  std::shared_ptr<InputFiles> inputs;
};
// throws InputError when `path` is not a swarmsim output or its scenario attribute is not JSON
StoredScenario readStoredScenario(const std::string& path);

}  // namespace swarmsim
