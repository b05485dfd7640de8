// libFuzzer target: the path from scenario JSON text to a checked Scenario,
// as `swarmsim validate` takes it: parseJsonText, then parseScenario (which
// loads the obstacle meshes a scenario names, with loadObj).
//
// The input is treated as the text of the file <dir>/fuzz_input.json, where
// <dir> is SWARMSIM_FUZZ_SCENARIO_DIR from the environment or else the
// repository's scenarios/ folder (compiled in). The file itself is never
// written; it only makes relative mesh paths ("../data/ball.obj") resolve to
// the real meshes in data/, so mesh loading is exercised.
//
// Findings: see fuzz_util.hpp. On success the Scenario is checked against what
// parseScenario promises (and later stages rely on) and its resolved JSON is
// rendered as `validate` renders it.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <system_error>

#include "core/json_reader.hpp"
#include "fuzz_util.hpp"
#include "geometry/mesh.hpp"
#include "geometry/obstacles.hpp"
#include "io/scenario.hpp"

namespace fs = std::filesystem;
using swarmsim_fuzz::finding;

namespace {

std::string gScenarioFile;  // <dir>/fuzz_input.json

// Mesh paths that would make a run hang or read without bound instead of
// testing the parser: an existing file that is not a regular file or folder
// (/dev/zero, a FIFO, /dev/stdin) or is larger than 1 MiB. Such inputs are
// skipped. Resolution as in parseScenario: relative to the scenario's folder.
bool meshPathsAreHarmless(const swarmsim::Json& json) {
  if (!json.is_object()) return true;
  const auto obstacles = json.find("obstacles");
  if (obstacles == json.end() || !obstacles->is_array()) return true;
  for (const auto& o : *obstacles) {
    if (!o.is_object()) continue;
    const auto file = o.find("file");
    if (file == o.end() || !file->is_string()) continue;
    const std::string rel = file->get<std::string>();
    if (rel.empty()) continue;
    const fs::path path = fs::path(rel).is_relative() ? fs::path(gScenarioFile).parent_path() / rel : fs::path(rel);
    std::error_code ec;
    const fs::file_status st = fs::status(path, ec);
    if (ec || !fs::exists(st) || fs::is_directory(st)) continue;  // loadObj reports these
    if (!fs::is_regular_file(st)) return false;
    const auto size = fs::file_size(path, ec);
    if (ec || size > (1u << 20)) return false;
  }
  return true;
}

bool finite3(const swarmsim::Vec3d& v) { return v.allFinite(); }

void checkMesh(const swarmsim::TriangleMesh& m) {
  if (m.triangles.empty()) finding("parseScenario accepted a mesh without triangles: " + m.source);
  for (const auto& v : m.vertices) {
    if (!finite3(v)) finding("parseScenario accepted a mesh with a non-finite vertex: " + m.source);
  }
  for (const auto& t : m.triangles) {
    for (const std::uint32_t i : t) {
      if (i >= m.vertices.size()) finding("mesh triangle index out of range: " + m.source);
    }
  }
}

// what parseScenario checks, so what a Simulation may assume
void checkScenario(const swarmsim::Scenario& sc) {
  if (!(sc.dt > 0.0) || !std::isfinite(sc.dt)) finding("accepted dt <= 0 or not finite");
  if (sc.frames < 1 || sc.stepsPerFrame < 1) finding("accepted frames or steps_per_frame < 1");
  if (sc.name.empty()) finding("accepted an empty name");
  for (int a = 0; a < 3; ++a) {
    if (!(sc.domain.max[a] > sc.domain.min[a])) finding("accepted a domain with max <= min");
  }
  if (!finite3(sc.domain.min) || !finite3(sc.domain.max)) finding("accepted a non-finite domain");
  if (sc.swarms.empty()) finding("accepted a scenario without swarms");
  std::int64_t total = 0;
  for (const auto& s : sc.swarms) {
    if (s.count < 1) finding("accepted a swarm count < 1");
    total += s.count;
    if (!s.config) finding("a swarm without parsed model parameters");
    if (s.name.empty()) finding("accepted an empty swarm name");
  }
  if (total != sc.agentCount() || total > 200'000'000) finding("agent total out of range");
  if (!sc.obstacles) finding("no obstacles object");
  for (const auto& m : sc.obstacles->meshes) checkMesh(m);
  for (const auto& s : sc.obstacles->spheres) {
    if (!(s.radius > 0.0) || !std::isfinite(s.radius) || !finite3(s.center)) finding("accepted a bad sphere obstacle");
  }
  for (const auto& b : sc.obstacles->boxes) {
    for (int a = 0; a < 3; ++a) {
      if (!(b.max[a] > b.min[a])) finding("accepted a box obstacle with max <= min");
    }
  }
  if (sc.output.quantities.empty()) finding("accepted an empty output.quantities");
  if (sc.output.compression < 0 || sc.output.compression > 9) finding("accepted a compression outside 0-9");
  // `validate` prints this; a run stores it in the output file
  const std::string printed = sc.resolved.dump(2);
  if (printed.empty()) finding("empty resolved scenario");
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  const char* dir = std::getenv("SWARMSIM_FUZZ_SCENARIO_DIR");
  gScenarioFile = (fs::path(dir && *dir ? dir : SWARMSIM_FUZZ_SCENARIO_DIR) / "fuzz_input.json").string();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  int result = 0;
  swarmsim_fuzz::expectOnlySwarmsimErrors([&] {
    const swarmsim::Json json = swarmsim::parseJsonText(text, gScenarioFile);
    if (!meshPathsAreHarmless(json)) {
      result = -1;  // not a parser test; keep it out of the corpus
      return;
    }
    const swarmsim::Scenario sc = swarmsim::parseScenario(json, gScenarioFile);
    checkScenario(sc);
  });
  return result;
}
