// Trajectory files: run a tiny scenario, read it back, check shapes, values,
// attributes, overwrite protection and the temporary-file protocol.
#include <hdf5.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "core/error.hpp"
#include "io/scenario.hpp"
#include "io/trajectory_reader.hpp"
#include "io/output_target.hpp"
#include "io/trajectory_writer.hpp"
#include "run.hpp"
#include "test_util.hpp"

using swarmsim::Json;
using swarmsim::Scenario;
using swarmsim::parseScenario;
using swarmsim_test::TempDir;
using Catch::Matchers::Contains;

namespace {

// two swarms (sphere and box spawn), 5 frames of 3 steps each
Json tinyScenario() {
  return Json::parse(R"({
    "name": "tiny",
    "seed": 1234,
    "dt": 0.02,
    "frames": 5,
    "steps_per_frame": 3,
    "domain": {"min": [-2, -2, -2], "max": [2, 2, 2]},
    "swarms": [
      {"name": "midges", "count": 40, "model": "boids", "initial_speed": 0.3,
       "spawn": {"type": "sphere", "center": [0.1, -0.2, 0.3], "radius": 0.6},
       "params": {"jitter": 0.1, "response_time": 0.05}},
      {"name": "gnats", "count": 25, "model": "boids", "initial_speed": 0.5,
       "spawn": {"type": "box", "min": [-1, -1, 0], "max": [1, 0, 0.5]},
       "params": {"speed": 0.4}}
    ]
  })");
}

swarmsim::RunResult runTo(const Scenario& sc, const std::string& path, bool force = false) {
  swarmsim::RunOptions opt;
  opt.output = path;
  opt.force = force;
  opt.quiet = true;
  return swarmsim::runScenario(sc, opt);
}

// the rows of an (frames, agents, 3) dataset at one frame
struct Frame {
  const std::vector<float>& data;
  std::size_t agents;
  std::size_t frame;
  float at(std::size_t agent, int axis) const { return data[(frame * agents + agent) * 3 + static_cast<std::size_t>(axis)]; }
};

std::vector<std::uint32_t> readIds(const std::string& path, const std::string& dataset, H5T_class_t* cls,
                                   std::size_t* size, H5T_sign_t* sign) {
  const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(f >= 0);
  const hid_t ds = H5Dopen2(f, dataset.c_str(), H5P_DEFAULT);
  REQUIRE(ds >= 0);
  const hid_t type = H5Dget_type(ds);
  *cls = H5Tget_class(type);
  *size = H5Tget_size(type);
  *sign = H5Tget_sign(type);
  const hid_t space = H5Dget_space(ds);
  const hssize_t n = H5Sget_simple_extent_npoints(space);
  std::vector<std::uint32_t> ids(static_cast<std::size_t>(n));
  if (n > 0) REQUIRE(H5Dread(ds, H5T_NATIVE_UINT32, H5S_ALL, H5S_ALL, H5P_DEFAULT, ids.data()) >= 0);
  H5Sclose(space);
  H5Tclose(type);
  H5Dclose(ds);
  H5Fclose(f);
  return ids;
}

bool linkExists(const std::string& path, const std::string& name) {
  const hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(f >= 0);
  const bool exists = H5Lexists(f, name.c_str(), H5P_DEFAULT) > 0;
  H5Fclose(f);
  return exists;
}

// no temporary or stray files: exactly the expected names
void requireOnly(const TempDir& dir, std::vector<std::string> names) {
  std::sort(names.begin(), names.end());
  CHECK(dir.entries() == names);
}

}  // namespace

TEST_CASE("Trajectory shapes and time and attributes", "[io]") {
  TempDir dir;
  const Scenario sc = parseScenario(tinyScenario(), dir.file("tiny.json"));
  const std::string out = dir.file("traj.h5");
  const auto result = runTo(sc, out);
  CHECK(result.frames == 5);
  CHECK(result.agents == 65);
  CHECK_FALSE(result.interrupted);
  CHECK(result.path == out);
  requireOnly(dir, {"traj.h5"});  // no temporary file left behind

  const auto info = swarmsim::readTrajectoryInfo(out);
  CHECK(info.format == "swarmsim-trajectory");
  CHECK(info.formatVersion == 1);
  CHECK(info.seed == 1234u);
  CHECK(info.dt == 0.02);
  CHECK(info.stepsPerFrame == 3);
  CHECK(info.frameDt == Approx(0.06).epsilon(1e-12));
  CHECK(info.frames == 5);
  CHECK(info.complete);
  CHECK_FALSE(info.interrupted);
  CHECK(info.scenarioName == "tiny");
  REQUIRE(info.swarms.size() == 2u);
  CHECK(info.swarms[0].name == "midges");
  CHECK(info.swarms[1].name == "gnats");
  for (const auto& s : info.swarms) {
    CHECK(s.model == "boids");
    CHECK(s.frames == 5);
    CHECK(s.quantities == std::vector<std::string>{"position", "velocity"});
  }
  CHECK(info.swarms[0].agents == 40);
  CHECK(info.swarms[1].agents == 25);

  // the stored scenario is the resolved scenario; the file records where it
  // was written (RunOptions::output here, not the scenario's output.path)
  const Json stored = Json::parse(info.scenarioJson);
  Json expected = sc.resolved;
  expected["output"]["path"] = out;
  CHECK(stored == expected);
  CHECK(stored["swarms"][0]["params"]["speed"] == 0.3);  // a default, filled in

  // time: frame f is at f * dt * steps_per_frame
  const auto time = swarmsim::readDoubleDataset(out, "time");
  REQUIRE(time.size() == 5u);
  for (std::size_t f = 0; f < time.size(); ++f) {
    CHECK(time[f] == Approx(static_cast<double>(f) * 0.02 * 3.0).epsilon(1e-12).margin(1e-15));
  }

  for (const auto& [name, n] : std::vector<std::pair<std::string, std::uint64_t>>{{"midges", 40}, {"gnats", 25}}) {
    INFO("swarm " << name);
    for (const char* q : {"position", "velocity"}) {
      std::vector<std::uint64_t> shape;
      const auto data = swarmsim::readFloatDataset(out, "swarms/" + name + "/" + q, &shape);
      CHECK(shape == std::vector<std::uint64_t>{5, n, 3});
      CHECK(data.size() == 5 * n * 3);
      bool finite = true;
      for (float v : data) finite = finite && std::isfinite(v);
      CHECK(finite);
    }
    H5T_class_t cls;
    std::size_t size = 0;
    H5T_sign_t sign;
    const auto ids = readIds(out, "swarms/" + name + "/id", &cls, &size, &sign);
    CHECK(cls == H5T_INTEGER);
    CHECK(size == 4u);
    CHECK(sign == H5T_SGN_NONE);
    REQUIRE(ids.size() == n);
    for (std::size_t r = 0; r < ids.size(); ++r) CHECK(ids[r] == r);
  }
}

TEST_CASE("Trajectory frame 0 is the spawned state with rows keyed by id", "[io]") {
  TempDir dir;
  const Scenario sc = parseScenario(tinyScenario(), dir.file("tiny.json"));
  const std::string out = dir.file("traj.h5");
  runTo(sc, out);
  for (std::uint32_t s = 0; s < sc.swarms.size(); ++s) {
    const auto& spec = sc.swarms[s];
    INFO("swarm " << spec.name);
    const swarmsim::SwarmState spawned = swarmsim::spawnSwarm(spec, sc.seed, s);
    const std::size_t n = spawned.size();
    REQUIRE(n == static_cast<std::size_t>(spec.count));
    const auto pos = swarmsim::readFloatDataset(out, "swarms/" + spec.name + "/position");
    const auto vel = swarmsim::readFloatDataset(out, "swarms/" + spec.name + "/velocity");
    const Frame p0{pos, n, 0}, v0{vel, n, 0};
    std::size_t mismatches = 0, outside = 0, wrongSpeed = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t row = spawned.id[i];
      for (int a = 0; a < 3; ++a) {
        if (p0.at(row, a) != spawned.position(i)[a] || v0.at(row, a) != spawned.velocity(i)[a]) ++mismatches;
      }
      // independent checks of the spawn: inside the region, at the initial speed
      const swarmsim::Vec3 x(p0.at(row, 0), p0.at(row, 1), p0.at(row, 2));
      const swarmsim::Vec3 v(v0.at(row, 0), v0.at(row, 1), v0.at(row, 2));
      if (spec.spawn.kind == swarmsim::SpawnRegion::Kind::kSphere) {
        if ((x.cast<double>() - spec.spawn.center).norm() > spec.spawn.radius * (1 + 1e-5)) ++outside;
      } else {
        for (int a = 0; a < 3; ++a) {
          if (x[a] < spec.spawn.min[a] - 1e-6 || x[a] > spec.spawn.max[a] + 1e-6) ++outside;
        }
      }
      if (std::fabs(v.norm() - spec.initialSpeed) > 1e-5) ++wrongSpeed;
    }
    CHECK(mismatches == 0u);
    CHECK(outside == 0u);
    CHECK(wrongSpeed == 0u);
    // the simulation moved the agents after frame 0
    const Frame p4{pos, n, 4};
    std::size_t moved = 0;
    for (std::size_t r = 0; r < n; ++r) moved += p4.at(r, 0) != p0.at(r, 0) ? 1 : 0;
    CHECK(moved == n);
  }
}

TEST_CASE("Trajectory rows follow agents across frames", "[io]") {
  // with one step per frame, x(f+1) = x(f) + v(f+1) dt for every row: this only
  // holds if each row is the same agent in every frame although the model
  // reorders agents in memory every step
  TempDir dir;
  Json j = tinyScenario();
  j["steps_per_frame"] = 1;
  j["frames"] = 6;
  const Scenario sc = parseScenario(j, dir.file("tiny.json"));
  const std::string out = dir.file("traj.h5");
  runTo(sc, out);
  const float dt = 0.02f;
  for (const char* name : {"midges", "gnats"}) {
    INFO("swarm " << name);
    std::vector<std::uint64_t> shape;
    const auto pos = swarmsim::readFloatDataset(out, std::string("swarms/") + name + "/position", &shape);
    const auto vel = swarmsim::readFloatDataset(out, std::string("swarms/") + name + "/velocity");
    const std::size_t n = shape.at(1);
    std::size_t bad = 0;
    for (std::size_t f = 0; f + 1 < 6; ++f) {
      const Frame pa{pos, n, f}, pb{pos, n, f + 1}, vb{vel, n, f + 1};
      for (std::size_t r = 0; r < n; ++r)
        for (int a = 0; a < 3; ++a)
          if (std::fabs(pb.at(r, a) - (pa.at(r, a) + vb.at(r, a) * dt)) > 1e-6f) ++bad;
    }
    CHECK(bad == 0u);
  }
}

TEST_CASE("Trajectory overwrite needs force", "[io]") {
  TempDir dir;
  Json j = tinyScenario();
  j["frames"] = 2;
  const Scenario sc = parseScenario(j, dir.file("tiny.json"));
  const std::string out = dir.file("traj.h5");
  runTo(sc, out);
  const auto sizeBefore = std::filesystem::file_size(out);
  const std::string before = swarmsim_test::readText(out);

  SECTION("runScenario refuses without force") {
    try {
      runTo(sc, out);
      FAIL("runScenario overwrote an existing file without force");
    } catch (const swarmsim::OutputError& e) {
      CHECK(e.code() == swarmsim::kExitOutput);
      CHECK(static_cast<int>(e.code()) == 3);
      CHECK_THAT(std::string(e.what()), Contains(out));
      CHECK_THAT(std::string(e.what()), Contains("exists"));
    }
    CHECK(swarmsim_test::readText(out) == before);
    requireOnly(dir, {"traj.h5"});
  }
  SECTION("OutputTarget and TrajectoryWriter refuse without force") {
    std::vector<swarmsim::SwarmState> swarms;
    for (std::uint32_t s = 0; s < sc.swarms.size(); ++s) swarms.push_back(swarmsim::spawnSwarm(sc.swarms[s], sc.seed, s));
    CHECK_THROWS_AS(swarmsim::OutputTarget(out, false, false), swarmsim::OutputError);
    // the writer only ever creates a new file
    CHECK_THROWS_AS(swarmsim::TrajectoryWriter(out, sc, swarms, {}, swarmsim::TrajectoryWriter::Mode::kCreate),
                    swarmsim::OutputError);
    CHECK(swarmsim_test::readText(out) == before);
    requireOnly(dir, {"traj.h5"});
  }
  SECTION("force overwrites") {
    Json j3 = tinyScenario();
    j3["frames"] = 3;
    const Scenario sc3 = parseScenario(j3, dir.file("tiny.json"));
    const auto r = runTo(sc3, out, true);
    CHECK(r.frames == 3);
    CHECK(swarmsim::readTrajectoryInfo(out).frames == 3);
    CHECK(std::filesystem::file_size(out) != sizeBefore);
    requireOnly(dir, {"traj.h5"});
  }
}

TEST_CASE("Trajectory writer: only the partial file exists until the output is placed", "[io]") {
  TempDir dir;
  const Scenario sc = parseScenario(tinyScenario(), dir.file("tiny.json"));
  const std::string out = dir.file("sub/traj.h5");
  std::vector<swarmsim::SwarmState> swarms;
  for (std::uint32_t s = 0; s < sc.swarms.size(); ++s) swarms.push_back(swarmsim::spawnSwarm(sc.swarms[s], sc.seed, s));
  {
    const swarmsim::OutputTarget target(out, false, false);
    CHECK(target.partPath() == dir.file("sub/.traj.h5.part"));
    swarmsim::TrajectoryWriter w(target.partPath(), sc, swarms, {}, swarmsim::TrajectoryWriter::Mode::kCreate);
    w.writeFrame(0.0, swarms, {});
    CHECK(w.framesWritten() == 1);
    CHECK_FALSE(std::filesystem::exists(out));
    CHECK(std::filesystem::exists(dir.file("sub/.traj.h5.lock")));
    w.close(false);
    target.place(false);
    CHECK(std::filesystem::exists(out));
    CHECK_FALSE(std::filesystem::exists(target.partPath()));
  }  // the lock is released and its file removed
  CHECK_FALSE(std::filesystem::exists(dir.file("sub/.traj.h5.lock")));
  CHECK(swarmsim::readTrajectoryInfo(out).frames == 1);
  CHECK(swarmsim::readTrajectoryInfo(out).interrupted);
}

TEST_CASE("Trajectory h5dump reads the file", "[io]") {
  TempDir dir;
  Json j = tinyScenario();
  j["frames"] = 2;
  const Scenario sc = parseScenario(j, dir.file("tiny.json"));
  const std::string out = dir.file("traj.h5");
  runTo(sc, out);
  const auto r = swarmsim_test::runCommand("h5dump -H " + swarmsim_test::shellQuote(out), dir.path());
  INFO("h5dump stderr: " << r.err);
  CHECK(r.exitCode == 0);
  CHECK_THAT(r.out, Contains("DATASET \"position\""));
  CHECK_THAT(r.out, Contains("DATASET \"velocity\""));
  CHECK_THAT(r.out, Contains("DATASET \"time\""));
  CHECK_THAT(r.out, Contains("GROUP \"midges\""));
  CHECK_THAT(r.out, Contains("ATTRIBUTE \"format\""));
}

TEST_CASE("Trajectory position-only output has no velocity", "[io]") {
  TempDir dir;
  Json j = tinyScenario();
  j["frames"] = 3;
  j["output"] = {{"quantities", {"position"}}};
  const Scenario sc = parseScenario(j, dir.file("tiny.json"));
  const std::string out = dir.file("pos.h5");
  runTo(sc, out);
  const auto info = swarmsim::readTrajectoryInfo(out);
  for (const auto& s : info.swarms) {
    CHECK(s.quantities == std::vector<std::string>{"position"});
    CHECK(s.frames == 3);
  }
  CHECK(linkExists(out, "swarms/midges/position"));
  CHECK_FALSE(linkExists(out, "swarms/midges/velocity"));
  CHECK_FALSE(linkExists(out, "swarms/gnats/velocity"));
  CHECK_THROWS_AS(swarmsim::readFloatDataset(out, "swarms/midges/velocity"), swarmsim::InputError);

  // the positions are those of a run storing both quantities
  Json both = j;
  both.erase("output");
  const std::string out2 = dir.file("both.h5");
  runTo(parseScenario(both, dir.file("tiny.json")), out2);
  CHECK(swarmsim::readFloatDataset(out, "swarms/gnats/position") ==
        swarmsim::readFloatDataset(out2, "swarms/gnats/position"));
}

TEST_CASE("Trajectory compressed output holds the same data", "[io]") {
  TempDir dir;
  Json j = tinyScenario();
  j["frames"] = 3;
  const std::string plain = dir.file("plain.h5"), packed = dir.file("packed.h5");
  runTo(parseScenario(j, dir.file("tiny.json")), plain);
  j["output"] = {{"compression", 6}};
  runTo(parseScenario(j, dir.file("tiny.json")), packed);
  for (const char* d : {"swarms/midges/position", "swarms/midges/velocity", "swarms/gnats/position"}) {
    CHECK(swarmsim::readFloatDataset(plain, d) == swarmsim::readFloatDataset(packed, d));
  }
}

TEST_CASE("Trajectory reader rejects other files", "[io]") {
  TempDir dir;
  const std::string text = dir.file("not.h5");
  swarmsim_test::writeText(text, "not an HDF5 file\n");
  CHECK_THROWS_AS(swarmsim::readTrajectoryInfo(text), swarmsim::InputError);
  CHECK_THROWS_AS(swarmsim::readTrajectoryInfo(dir.file("missing.h5")), swarmsim::InputError);
  // an HDF5 file without the format attribute
  const std::string other = dir.file("other.h5");
  const hid_t f = H5Fcreate(other.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  REQUIRE(f >= 0);
  H5Fclose(f);
  try {
    swarmsim::readTrajectoryInfo(other);
    FAIL("accepted an HDF5 file that is not a trajectory");
  } catch (const swarmsim::InputError& e) {
    CHECK_THAT(std::string(e.what()), Contains("not a swarmsim trajectory"));
  }
}

TEST_CASE("Trajectory stores the resolved scenario", "[io]") {
  // written to the scenario's own output.path, the stored scenario is exactly
  // Scenario::resolved
  TempDir dir;
  Json j = tinyScenario();
  j["frames"] = 2;
  j["output"] = {{"path", "out/own.h5"}};  // relative: resolves against the scenario's folder
  const Scenario sc = parseScenario(j, dir.file("tiny.json"));
  REQUIRE(sc.output.path == dir.file("out/own.h5"));
  swarmsim::RunOptions opt;
  opt.quiet = true;
  const auto r = swarmsim::runScenario(sc, opt);
  CHECK(r.path == sc.output.path);
  const auto info = swarmsim::readTrajectoryInfo(sc.output.path);
  CHECK(Json::parse(info.scenarioJson) == sc.resolved);
  // and it is a valid scenario again
  CHECK_NOTHROW(parseScenario(Json::parse(info.scenarioJson), dir.file("again.json")));
}
