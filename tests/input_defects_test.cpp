// Regression tests for reported input defects (D3, D4, D6, D7, D8, D11): bad
// input ends with exit code 2 and a message naming the file and the JSON path
// (or OBJ line); never a crash, never exit code 1 for something the parser
// could have refused. Most cases drive the built binary (SWARMSIM_EXE) with the
// reported command line; docs/scenario.md#limits describes the limits.
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "core/json_reader.hpp"
#include "fields/grid3.hpp"
#include "geometry/obstacles.hpp"
#include "geometry/signed_distance.hpp"
#include "io/scenario.hpp"
#include "test_util.hpp"

using Catch::Matchers::Contains;
using swarmsim::Json;
using swarmsim_test::CommandResult;
using swarmsim_test::shellQuote;
using swarmsim_test::TempDir;

namespace fs = std::filesystem;

namespace {

const std::string kExe = SWARMSIM_EXE;
const std::string kSourceDir = SWARMSIM_SOURCE_DIR;
const std::string kScenarios = kSourceDir + "/scenarios/";

// run `swarmsim ARGS` (ARGS already shell-quoted where needed) in `dir`
CommandResult runCli(const std::string& args, const TempDir& dir) {
  return swarmsim_test::runCommand("cd " + shellQuote(dir.path().string()) + " && " + shellQuote(kExe) + " " + args,
                                   dir.path());
}

// a shell command line (pipes, redirections) with the swarmsim binary as $SWARMSIM
CommandResult runShell(const std::string& script, const TempDir& dir) {
  return swarmsim_test::runCommand(
      "cd " + shellQuote(dir.path().string()) + " && SWARMSIM=" + shellQuote(kExe) + " sh -c " + shellQuote(script),
      dir.path());
}

std::string sets(const std::vector<std::string>& assignments) {
  std::string out;
  for (const auto& a : assignments) out += " --set " + shellQuote(a);
  return out;
}

// `swarmsim validate SCENARIO --set ...` and `swarmsim run SCENARIO --frames 2 --set ...`: both must
// refuse with exit code 2 and a message containing `expected`
void requireRefused(const std::string& scenario, const std::vector<std::string>& assignments,
                    const std::string& expected) {
  TempDir dir;
  for (const std::string cmd : {"validate", "run"}) {
    const std::string args = std::string(cmd) + " " + shellQuote(kScenarios + scenario) + sets(assignments) +
                             (std::string(cmd) == "run" ? " --frames 2 -o out.h5" : "");
    INFO("swarmsim " << args);
    const CommandResult r = runCli(args, dir);
    INFO("stderr: " << r.err);
    CHECK(r.exitCode == 2);
    CHECK_THAT(r.err, Contains("swarmsim: error: " + kScenarios + scenario + ": " + expected));
    CHECK_FALSE(fs::exists(dir.file("out.h5")));
  }
}

// `swarmsim run SCENARIO --frames 2 --set ...` succeeds (exit code 0, output written)
void requireRuns(const std::string& scenario, const std::vector<std::string>& assignments) {
  TempDir dir;
  const std::string args =
      "run " + shellQuote(kScenarios + scenario) + sets(assignments) + " --frames 2 --quiet -o out.h5";
  INFO("swarmsim " << args);
  const CommandResult r = runCli(args, dir);
  INFO("stderr: " << r.err);
  CHECK(r.exitCode == 0);
  CHECK(fs::exists(dir.file("out.h5")));
}

std::string nested(std::size_t levels, const std::string& inner = "") {
  return std::string(levels, '[') + inner + std::string(levels, ']');
}

// the InputError message of parseJsonText, or "" (and a failed check) if it accepts the text
std::string jsonError(const std::string& text) {
  try {
    swarmsim::parseJsonText(text, "t.json");
  } catch (const swarmsim::InputError& e) {
    return e.what();
  }
  FAIL_CHECK("parseJsonText accepted the text");
  return "";
}

}  // namespace

// ---------------------------------------------------------------------------
// D3: an obstacle translated far outside the domain

TEST_CASE("D3: an obstacle translated to 1e200 is refused with its JSON path, not a crash", "[input]") {
  // reported: `run scenarios/two_blocks.json --frames 2 --set 'obstacles[0].translate=[1e200,0,0]'`
  // crashed (SIGSEGV; double-to-int overflow in GridSpec::cellOf) and validate accepted it
  requireRefused("two_blocks.json", {"obstacles[0].translate=[1e200,0,0]"},
                 "obstacles[0].translate[0]: expected a number in [-1e+09, 1e+09], got 1e+200");
  // a scale that throws the vertices out: the OBJ line of the first vertex placed beyond the limit
  requireRefused("two_blocks.json", {"obstacles[0].scale=1e300"}, "obstacles[0].file: ");
  {
    TempDir dir;
    const auto r = runCli(
        "validate " + shellQuote(kScenarios + "two_blocks.json") + sets({"obstacles[0].scale=[1e300, 1, 1]"}), dir);
    CHECK(r.exitCode == 2);
    CHECK_THAT(r.err, Contains("blocks.obj:"));
    CHECK_THAT(r.err, Contains("by translate, rotate and scale (expected every coordinate within +-1e+09 m)"));
  }
  // spheres and boxes
  requireRefused("two_blocks.json", {R"(obstacles=[{"type": "sphere", "center": [1e200, 0, 0], "radius": 1}])"},
                 "obstacles[0].center[0]: expected a number in [-1e+09, 1e+09], got 1e+200");
  requireRefused("two_blocks.json", {R"(obstacles=[{"type": "sphere", "center": [0, 0, 0], "radius": 1e200}])"},
                 "obstacles[0].radius: expected a number in [1e-06, 1e+09], got 1e+200");
  requireRefused("two_blocks.json", {R"(obstacles=[{"type": "box", "min": [1e200, 0, 0], "max": [2e200, 1, 1]}])"},
                 "obstacles[0].min[0]: expected a number in [-1e+09, 1e+09], got 1e+200");
}

TEST_CASE("D3: obstacles merely outside the domain still run", "[input]") {
  requireRuns("two_blocks.json", {"obstacles[0].translate=[1e8,0,0]"});
  requireRuns("two_blocks.json", {"obstacles[0].translate=[-9.9e8,3e8,-2e8]", "obstacles[0].rotate=[1e300,0,45]"});
  requireRuns("two_blocks.json", {R"(obstacles=[{"type": "sphere", "center": [9e8, 0, 0], "radius": 1e8},
                                                {"type": "box", "min": [-1e9, -1e9, -1e9], "max": [-9e8, 0, 0]}])"});
  requireRuns("midges_100.json", {"obstacles=[{\"type\": \"mesh\", \"file\": \"../data/blocks.obj\", "
                                  "\"translate\": [-1e9, 0, 0]}]"});
}

TEST_CASE("D3: grid index conversions are safe for any coordinate", "[input]") {
  const swarmsim::GridSpec g =
      swarmsim::GridSpec::covering(swarmsim::Vec3d(0, 0, 0), swarmsim::Vec3d(10, 20, 30), {10, 20, 30});
  const double inf = std::numeric_limits<double>::infinity(), nan = std::numeric_limits<double>::quiet_NaN();
  CHECK(g.cellOf(swarmsim::Vec3d(1e200, 1e300, inf)) == std::array<int, 3>{9, 19, 29});
  CHECK(g.cellOf(swarmsim::Vec3d(-1e200, -inf, nan)) == std::array<int, 3>{0, 0, 0});
  CHECK(g.cellOf(swarmsim::Vec3d(3e9, 5.5, -3e9)) == std::array<int, 3>{9, 5, 0});

  // the signed distance of obstacles far outside the grid (the crash of the report, below the parser)
  swarmsim::Obstacles obs;
  swarmsim::TriangleMesh tet;
  tet.vertices = {{1e200, 0, 0}, {1e200 + 1e190, 0, 0}, {1e200, 1e190, 0}, {1e200, 0, 1e190}};
  tet.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  obs.meshes.push_back(tet);
  obs.spheres.push_back({swarmsim::Vec3d(-1e300, 0, 0), 1e299});
  obs.boxes.push_back({swarmsim::Vec3d(0, 0, 1e300), swarmsim::Vec3d(1, 1, 1.5e300)});
  const swarmsim::Grid3<float> sdf = swarmsim::signedDistance(obs, g);
  REQUIRE(sdf.data.size() == g.size());
  for (const float d : sdf.data) {
    REQUIRE(std::isfinite(d));
    REQUIRE(d > 0.0f);
  }
}

// ---------------------------------------------------------------------------
// D4: deeply nested JSON

TEST_CASE("D4: JSON nested 70,000 levels deep is refused with the JSON path, not a stack overflow", "[input]") {
  TempDir dir;
  SECTION("in a scenario file") {
    const std::string file = dir.file("deep.json");
    swarmsim_test::writeText(file, "{\"dt\": 0.01, \"description\": " + nested(70000) + "}\n");
    const auto r = runCli("validate " + shellQuote(file), dir);
    INFO("stderr: " << r.err);
    CHECK(r.exitCode == 2);
    CHECK_THAT(r.err, Contains(file + ": description[0][0]"));
    CHECK_THAT(r.err, Contains("nested deeper than 256 levels"));
  }
  SECTION("in a --set value (65,000 levels: as long as an argument can be)") {
    const auto r = runCli(
        "validate " + shellQuote(kScenarios + "default.json") + " --set " + shellQuote("x=" + nested(65000)), dir);
    INFO("stderr: " << r.err.substr(0, 300));
    CHECK(r.exitCode == 2);
    CHECK_THAT(r.err, Contains("swarmsim: error: --set x: x[0][0]"));
    CHECK_THAT(r.err, Contains("nested deeper than 256 levels"));
  }
  SECTION("a --set path deeper than the limit") {
    std::string path = "a";
    for (int i = 0; i < 300; ++i) path += ".a";
    const auto r =
        runCli("validate " + shellQuote(kScenarios + "default.json") + " --set " + shellQuote(path + "=1"), dir);
    CHECK(r.exitCode == 2);
    CHECK_THAT(r.err, Contains("expected at most 256"));
  }
}

TEST_CASE("D4: the nesting limit is 256 levels of arrays and objects", "[input]") {
  // 256 levels parse (the top-level array counts as one)
  const Json ok = swarmsim::parseJsonText(nested(256, "1"), "t.json");
  CHECK(ok.dump().size() == 2 * 256 + 1);
  CHECK_THAT(jsonError(nested(257)), Contains("t.json: [0][0][0]"));
  CHECK_THAT(jsonError(nested(257)), Contains("nested deeper than 256 levels"));
  CHECK_THAT(jsonError("{\"a\": {\"b\": " + nested(255) + "}}"), Contains("t.json: a.b[0]"));
  // in a --set value, the levels above the value count too: x is in the 4th level (the scenario,
  // swarms, swarms[0], params)
  Json sc = swarmsim::parseJsonText(R"({"swarms": [{"params": {}}]})", "t.json");
  swarmsim::applyOverride(sc, "swarms[0].params.x=" + nested(252));
  CHECK_THROWS_WITH(swarmsim::applyOverride(sc, "swarms[0].params.x=" + nested(253)),
                    Contains("--set swarms[0].params.x: swarms[0].params.x[0]"));
}

// ---------------------------------------------------------------------------
// D11a: duplicate keys

TEST_CASE("D11a: duplicate JSON keys are refused with the JSON path", "[input]") {
  TempDir dir;
  const std::string file = dir.file("dup.json");
  std::string text = swarmsim_test::readText(kScenarios + "default.json");
  const auto at = text.find("\"count\": 2000,");
  REQUIRE(at != std::string::npos);
  text.insert(at, "\"count\": 5, ");
  swarmsim_test::writeText(file, text);
  auto r = runCli("validate " + shellQuote(file), dir);
  CHECK(r.exitCode == 2);
  CHECK_THAT(r.err, Contains("swarmsim: error: " + file + ": duplicate key \"count\" in swarms[0]"));
  r = runCli("run " + shellQuote(file) + " --frames 2 -o out.h5", dir);
  CHECK(r.exitCode == 2);
  CHECK_FALSE(fs::exists(dir.file("out.h5")));

  CHECK_THAT(jsonError(R"({"dt": 1, "frames": 2, "dt": 3})"),
             Contains("t.json: duplicate key \"dt\" at the top level"));
  CHECK_THAT(jsonError(R"({"a": [{}, {"b": {"c": 1, "c": 1}}]})"), Contains("t.json: duplicate key \"c\" in a[1].b"));
  // the same key in different objects is fine
  CHECK(swarmsim::parseJsonText(R"({"a": {"k": 1}, "b": {"k": 2}, "k": [{"k": 3}, {"k": 4}]})", "t.json").size() == 3);

  // in a --set value
  r = runCli("validate " + shellQuote(kScenarios + "default.json") +
                 sets({R"(swarms[0].spawn={"type": "sphere", "center": [0, 0, 2], "radius": 1, "radius": 2})"}),
             dir);
  CHECK(r.exitCode == 2);
  CHECK_THAT(r.err, Contains("--set swarms[0].spawn: duplicate key \"radius\" in swarms[0].spawn"));
}

TEST_CASE("D11a: malformed JSON still reports file:line:column", "[input]") {
  CHECK_THAT(jsonError("{\n  \"dt\": 0.1,,\n}\n"), Contains("t.json:2:13: malformed JSON: "));
  CHECK_THAT(jsonError("{\n  \"dt\": 0.1\n"), Contains("t.json:3:1: malformed JSON: "));
  CHECK_THAT(jsonError("{\n  \"a\": 1,\n  \"dt\": 1e999\n}"),
             Contains("t.json:3:9: expected a finite number, got 1e999 (out of range: it would be Inf)"));
  CHECK_THAT(jsonError("[1] x"), Contains("t.json:1:5: malformed JSON: "));
}

// ---------------------------------------------------------------------------
// D11b: directories, endless files, pipes

TEST_CASE("D11b: a directory as scenario is reported as a directory", "[input]") {
  TempDir dir;
  for (const std::string cmd : {"validate ", "run "}) {
    const auto r = runCli(cmd + shellQuote(kScenarios) + (cmd == "run " ? " -o out.h5" : ""), dir);
    INFO("stderr: " << r.err);
    CHECK(r.exitCode == 2);
    CHECK_THAT(r.err, Contains(kScenarios + ": cannot read file (it is a directory; expected a JSON scenario file)"));
    CHECK_THAT(r.err, !Contains("malformed"));
  }
}

TEST_CASE("D11b: /dev/zero is refused at the size limit instead of reading until bad_alloc", "[input]") {
  TempDir dir;
  const auto r = runCli("validate /dev/zero", dir);
  CHECK(r.exitCode == 2);
  CHECK_THAT(r.err, Contains("/dev/zero: file is larger than 64 MiB"));
  // a file just over the limit too; one at the limit is read (and parsed)
  const std::size_t limit = std::size_t{64} << 20;  // swarmsim::kMaxJsonFileBytes, documented
  const std::string big = dir.file("big.json");
  swarmsim_test::writeText(big, "[" + std::string(limit - 2, ' ') + "]");
  CHECK(swarmsim::readJsonFile(big) == Json::array());
  swarmsim_test::writeText(big, "[" + std::string(limit - 1, ' ') + "]");
  CHECK_THROWS_WITH(swarmsim::readJsonFile(big), Contains(big + ": file is larger than 64 MiB"));
}

TEST_CASE("D11b: scenarios from pipes still work", "[input]") {
  TempDir dir;
  const std::string scenario = shellQuote(kScenarios + "default.json");
  auto r = runShell("cat " + scenario + " | \"$SWARMSIM\" validate /dev/stdin", dir);
  INFO("stderr: " << r.err);
  CHECK(r.exitCode == 0);
  CHECK_THAT(r.out, Contains("\"count\": 2000"));
  r = runShell("\"$SWARMSIM\" validate /dev/fd/3 3< " + scenario, dir);
  CHECK(r.exitCode == 0);
  r = runShell("cat " + scenario + " | \"$SWARMSIM\" run /dev/stdin --frames 2 --quiet -o out.h5", dir);
  CHECK(r.exitCode == 0);
  CHECK(fs::exists(dir.file("out.h5")));
}

// ---------------------------------------------------------------------------
// D6: values validate accepted that made run fail later (exit 1)

TEST_CASE("D6: the reported values that cannot run are refused by the parser", "[input]") {
  // dt = 1e-20: the boids blend 1 - exp(-dt / response_time) rounds to 0, its noise term to Inf
  requireRefused("default.json", {"dt=1e-20"}, "dt: expected a number in [1e-06, 1000], got 1e-20");
  // dt = 1e39, dt = 1e300: Inf as the float every model steps with (ORCA: "dt must be > 0")
  requireRefused("default.json", {"dt=1e39"}, "dt: expected a number in [1e-06, 1000], got 1e+39");
  requireRefused("midges_100.json", {"dt=1e300"}, "dt: expected a number in [1e-06, 1000], got 1e+300");
  // speeds and sizes beyond float
  requireRefused("default.json", {"swarms[0].initial_speed=1e39"},
                 "swarms[0].initial_speed: expected a number in [0, 1e+06], got 1e+39");
  requireRefused("default.json", {"swarms[0].spawn.radius=1e308"},
                 "swarms[0].spawn.radius: expected a number in [0, 1e+09], got 1e+308");
  requireRefused("two_blocks.json",
                 {"swarms[0].spawn.min=[-1e300,-1e300,-1e300]", "swarms[0].spawn.max=[1e300,1e300,1e300]"},
                 "swarms[0].spawn.min[0]: expected a number in [-1e+09, 1e+09], got -1e+300");
  // a ball reaching beyond the coordinate limit
  requireRefused("default.json", {"swarms[0].spawn.center=[0,0,9e8]", "swarms[0].spawn.radius=2e8"},
                 "swarms[0].spawn.radius: expected the ball within the coordinate limit");
}

TEST_CASE("D6: values just inside the limits run", "[input]") {
  requireRuns("default.json", {"dt=1e-6"});
  requireRuns("default.json", {"dt=1000"});
  requireRuns("default.json", {"swarms[0].initial_speed=1e6", "swarms[0].params.max_speed=1e6"});
  requireRuns("default.json", {"swarms[0].spawn.center=[0,0,0]", "swarms[0].spawn.radius=1e9"});
  requireRuns("default.json", {"swarms[0].params.response_time=1e9", "dt=1e-6"});
  requireRuns("midges_100.json", {"dt=1000"});
  requireRuns("midges_100.json", {"dt=1e-6"});
  requireRuns("two_blocks.json", {"dt=1000"});
  requireRuns("two_blocks.json", {"swarms[0].spawn.min=[-1e9,-1e9,-1e9]", "swarms[0].spawn.max=[1e9,1e9,1e9]"});
  requireRuns("two_blocks.json",
              {"domain.min=[-1e9,-1e9,-1e9]", "domain.max=[1e9,1e9,1e9]", "swarms[0].spawn.min=[-1e9,-1e9,-1e9]",
               "swarms[0].spawn.max=[1e9,1e9,1e9]", "swarms[0].params.speed=1e6", "dt=1000"});
}

// ---------------------------------------------------------------------------
// D7: the seed

TEST_CASE("D7: a JSON seed is any integer in [0, 2^64 - 1], kept exactly", "[input]") {
  TempDir dir;
  const std::string scenario = swarmsim_test::readText(kScenarios + "default.json");
  const auto withSeed = [&](const std::string& seed) {
    std::string text = scenario;
    const auto at = text.find("\"seed\": 1,");
    REQUIRE(at != std::string::npos);
    text.replace(at, 10, "\"seed\": " + seed + ",");
    const std::string file = dir.file("seed.json");
    swarmsim_test::writeText(file, text);
    return file;
  };
  for (const std::string bad : {"18446744073709551616", "-1", "-1e30", "1.5", "1e30", "\"7\""}) {
    const std::string file = withSeed(bad);
    const auto r = runCli("validate " + shellQuote(file), dir);
    INFO("seed " << bad << ": " << r.err);
    CHECK(r.exitCode == 2);
    CHECK_THAT(r.err, Contains(file + ": seed: expected an integer " +
                               (bad[0] == '-' ? ">= 0" : "in [0, 18446744073709551615]") + ", got "));
  }
  const auto r = runCli("validate " + shellQuote(withSeed("18446744073709551615")), dir);
  REQUIRE(r.exitCode == 0);
  const Json resolved = Json::parse(r.out);
  REQUIRE(resolved.at("seed").is_number_unsigned());
  CHECK(resolved.at("seed").get<std::uint64_t>() == std::numeric_limits<std::uint64_t>::max());
  CHECK_THAT(r.out, Contains("\"seed\": 18446744073709551615"));
  // and through --set
  const auto s =
      runCli("validate " + shellQuote(kScenarios + "default.json") + sets({"seed=18446744073709551615"}), dir);
  CHECK(s.exitCode == 0);
  CHECK_THAT(s.out, Contains("\"seed\": 18446744073709551615"));
  CHECK(runCli("validate " + shellQuote(kScenarios + "default.json") + sets({"seed=18446744073709551616"}), dir)
            .exitCode == 2);
}

// ---------------------------------------------------------------------------
// D8: --set indices

TEST_CASE("D8: a --set index too large for a long, or beyond the array, is exit code 2", "[input]") {
  TempDir dir;
  auto r = runCli(
      "validate " + shellQuote(kScenarios + "default.json") + sets({"swarms[99999999999999999999].count=5"}), dir);
  CHECK(r.exitCode == 2);
  CHECK_THAT(r.err, Contains("--set swarms[99999999999999999999].count: index [99999999999999999999] is out of range "
                             "(1 elements)"));
  CHECK_THAT(r.err, !Contains("stol"));
  r = runCli("validate " + shellQuote(kScenarios + "default.json") + sets({"swarms[1].count=5"}), dir);
  CHECK(r.exitCode == 2);
  CHECK_THAT(r.err, Contains("--set swarms[1].count: index [1] is out of range (1 elements)"));
  r = runCli("run " + shellQuote(kScenarios + "default.json") + sets({"swarms[00000000000000000000000001].count=5"}) +
                 " -o out.h5",
             dir);
  CHECK(r.exitCode == 2);
  CHECK_THAT(r.err, Contains("index [00000000000000000000000001] is out of range (1 elements)"));
  // a long index with leading zeros that is in range
  CHECK(runCli("validate " + shellQuote(kScenarios + "default.json") + sets({"swarms[000000000000000000000].count=5"}),
               dir)
            .exitCode == 0);
}
