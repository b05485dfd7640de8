// Scenario loading: every error is an InputError (exit code 2) naming the file
// and the JSON path; defaults are filled into Scenario::resolved; --set overrides.
#include <filesystem>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "core/error.hpp"
#include "io/scenario.hpp"
#include "test_util.hpp"

using swarmsim::InputError;
using swarmsim::Json;
using swarmsim::Scenario;
using swarmsim::parseScenario;
using swarmsim_test::TempDir;
using Catch::Matchers::Contains;

namespace {

const char* const kFile = "some/dir/scen.json";

// a small valid scenario: swarm "a" (sphere, one param set), swarm "b" (box, no params)
Json baseScenario() {
  return Json::parse(R"({
    "name": "t",
    "seed": 3,
    "dt": 0.01,
    "frames": 4,
    "domain": {"min": [-1, -1, -1], "max": [1, 1, 3]},
    "swarms": [
      {"name": "a", "count": 10, "model": "boids",
       "spawn": {"type": "sphere", "center": [0, 0, 0], "radius": 0.5},
       "params": {"speed": 0.2}},
      {"name": "b", "count": 5, "model": "boids",
       "spawn": {"type": "box", "min": [0, 0, 0], "max": [0.5, 0.5, 0.5]}}
    ]
  })");
}

// the message of the InputError parseScenario throws (the test fails if it throws nothing or something else)
std::string parseError(const Json& json, const std::string& file = kFile) {
  try {
    parseScenario(json, file);
  } catch (const InputError& e) {
    CHECK(e.code() == swarmsim::kExitInvalidInput);
    CHECK(static_cast<int>(e.code()) == 2);
    return e.what();
  }
  FAIL("parseScenario accepted the scenario; expected an InputError");
  return "";
}

// the message of the InputError loadScenario throws for this file text
std::string loadError(const std::string& text, std::string* fileOut = nullptr) {
  static int counter = 0;
  TempDir dir;
  const std::string file = dir.file("scenario" + std::to_string(++counter) + ".json");
  swarmsim_test::writeText(file, text);
  if (fileOut) *fileOut = file;
  try {
    swarmsim::loadScenario(file);
  } catch (const InputError& e) {
    CHECK(e.code() == swarmsim::kExitInvalidInput);
    return e.what();
  }
  FAIL("loadScenario accepted the file; expected an InputError");
  return "";
}

std::string overrideError(Json& json, const std::string& assignment) {
  try {
    swarmsim::applyOverride(json, assignment);
  } catch (const InputError& e) {
    CHECK(e.code() == swarmsim::kExitInvalidInput);
    return e.what();
  }
  FAIL("applyOverride accepted \"" << assignment << "\"; expected an InputError");
  return "";
}

}  // namespace

TEST_CASE("Scenario base scenario is valid", "[scenario]") {
  const Scenario sc = parseScenario(baseScenario(), kFile);
  CHECK(sc.name == "t");
  CHECK(sc.seed == 3u);
  CHECK(sc.dt == 0.01);
  CHECK(sc.frames == 4);
  REQUIRE(sc.swarms.size() == 2u);
  CHECK(sc.agentCount() == 15);
}

TEST_CASE("Scenario unknown keys are reported with a suggestion", "[scenario]") {
  SECTION("extra key next to the real one in swarms[0]") {
    Json j = baseScenario();
    j["swarms"][0]["cout"] = 10;
    const std::string msg = parseError(j);
    CHECK_THAT(msg, Contains("some/dir/scen.json: swarms[0].cout: unknown key"));
    CHECK_THAT(msg, Contains("did you mean \"count\""));
  }
  SECTION("unknown key in params") {
    Json j = baseScenario();
    j["swarms"][0]["params"]["sped"] = 0.4;
    const std::string msg = parseError(j);
    CHECK_THAT(msg, Contains("some/dir/scen.json: swarms[0].params.sped: unknown key"));
    CHECK_THAT(msg, Contains("did you mean \"speed\""));
  }
  SECTION("unknown key in params of the second swarm") {
    Json j = baseScenario();
    j["swarms"][1]["params"] = {{"repulsion_zon", 0.1}};
    const std::string msg = parseError(j);
    CHECK_THAT(msg, Contains("swarms[1].params.repulsion_zon: unknown key"));
    CHECK_THAT(msg, Contains("did you mean \"repulsion_zone\""));
  }
  SECTION("unknown top-level key") {
    Json j = baseScenario();
    j["seeds"] = 4;
    const std::string msg = parseError(j);
    CHECK_THAT(msg, Contains("some/dir/scen.json: seeds: unknown key"));
    CHECK_THAT(msg, Contains("did you mean \"seed\""));
  }
  SECTION("unknown key in domain and spawn") {
    Json j = baseScenario();
    j["domain"]["mx"] = {1, 1, 1};
    CHECK_THAT(parseError(j), Contains("some/dir/scen.json: domain.mx: unknown key"));
    j = baseScenario();
    j["swarms"][0]["spawn"]["radus"] = 1;
    const std::string msg = parseError(j);
    CHECK_THAT(msg, Contains("swarms[0].spawn.radus: unknown key"));
    CHECK_THAT(msg, Contains("did you mean \"radius\""));
  }
  SECTION("a key far from every known key gets no suggestion") {
    Json j = baseScenario();
    j["swarms"][0]["params"]["xyzzyplugh"] = 1;
    const std::string msg = parseError(j);
    CHECK_THAT(msg, Contains("swarms[0].params.xyzzyplugh: unknown key"));
    CHECK_THAT(msg, !Contains("did you mean"));
  }
}

// LIB BUG (lib/io/scenario.cpp parseScenario + lib/core/json_reader.cpp
// JsonReader::finish): a typo of a *required* key is reported as a missing key
// ("swarms[0].count: missing required key ...") because requireInteger() throws
// before finish() gets to see the unknown key, so the message never names the
// typo "cout" nor suggests "count". Tagged  until fixed: remove
// the tag when the library reports the typo (the test then passes as written).
TEST_CASE("Scenario typo of a required key names the typo", "[scenario]") {
  Json j = baseScenario();
  j["swarms"][0].erase("count");
  j["swarms"][0]["cout"] = 10;
  const std::string msg = parseError(j);
  CHECK_THAT(msg, Contains("some/dir/scen.json: swarms[0].cout"));
  CHECK_THAT(msg, Contains("did you mean \"count\""));
}

TEST_CASE("Scenario wrong types", "[scenario]") {
  Json j = baseScenario();
  j["dt"] = "0.1";
  CHECK_THAT(parseError(j), Contains("some/dir/scen.json: dt: expected a number > 0, got \"0.1\""));

  j = baseScenario();
  j["swarms"][0]["params"]["speed"] = "fast";
  CHECK_THAT(parseError(j), Contains("some/dir/scen.json: swarms[0].params.speed: expected a number > 0, got \"fast\""));

  j = baseScenario();
  j["swarms"][1]["count"] = "ten";
  CHECK_THAT(parseError(j), Contains("some/dir/scen.json: swarms[1].count: expected an integer"));
  CHECK_THAT(parseError(j), Contains("got \"ten\""));

  j = baseScenario();
  j["frames"] = 2.5;
  CHECK_THAT(parseError(j), Contains("some/dir/scen.json: frames: expected an integer"));

  j = baseScenario();
  j["domain"] = Json::array({1, 2});
  CHECK_THAT(parseError(j), Contains("some/dir/scen.json: domain: expected an object"));

  j = baseScenario();
  j["domain"]["min"] = Json::array({0, 0});
  CHECK_THAT(parseError(j), Contains("some/dir/scen.json: domain.min: expected an array of 3 numbers"));

  j = baseScenario();
  j["swarms"] = Json::object();
  CHECK_THAT(parseError(j), Contains("some/dir/scen.json: swarms: expected an array of at least 1 object"));

  j = baseScenario();
  j["swarms"] = Json::array();
  CHECK_THAT(parseError(j), Contains("some/dir/scen.json: swarms: expected an array of at least 1 object"));

  j = baseScenario();
  j["swarms"][0]["spawn"]["center"][1] = true;
  CHECK_THAT(parseError(j), Contains("swarms[0].spawn.center[1]: expected"));

  CHECK_THAT(parseError(Json::array({1, 2})), Contains("some/dir/scen.json: expected a JSON object at the top level"));
}

TEST_CASE("Scenario missing required keys", "[scenario]") {
  const auto missing = [](Json j, const char* expected) {
    INFO("expecting: " << expected);
    CHECK_THAT(parseError(j), Contains(expected));
  };
  Json j = baseScenario();
  j.erase("dt");
  missing(j, "some/dir/scen.json: dt: missing required key");
  j = baseScenario();
  j.erase("frames");
  missing(j, "some/dir/scen.json: frames: missing required key");
  j = baseScenario();
  j.erase("swarms");
  missing(j, "some/dir/scen.json: swarms: missing required key");
  j = baseScenario();
  j.erase("domain");
  missing(j, "some/dir/scen.json: domain: missing required key");
  j = baseScenario();
  j["swarms"][0].erase("count");
  missing(j, "some/dir/scen.json: swarms[0].count: missing required key");
  j = baseScenario();
  j["swarms"][0].erase("model");
  missing(j, "some/dir/scen.json: swarms[0].model: missing required key");
  j = baseScenario();
  j["swarms"][1].erase("spawn");
  missing(j, "some/dir/scen.json: swarms[1].spawn: missing required key");
  j = baseScenario();
  j["swarms"][1]["spawn"].erase("max");
  missing(j, "some/dir/scen.json: swarms[1].spawn.max: missing required key");
  // null counts as missing
  j = baseScenario();
  j["dt"] = nullptr;
  missing(j, "some/dir/scen.json: dt: missing required key");
}

TEST_CASE("Scenario out-of-range values", "[scenario]") {
  Json j = baseScenario();
  j["swarms"][1]["params"] = {{"repulsion_zone", -1}};
  CHECK_THAT(parseError(j),
             Contains("some/dir/scen.json: swarms[1].params.repulsion_zone: expected a number >= 0, got -1"));

  j = baseScenario();
  j["dt"] = 0;
  CHECK_THAT(parseError(j), Contains("some/dir/scen.json: dt: expected a number > 0, got 0"));

  j = baseScenario();
  j["frames"] = 0;
  CHECK_THAT(parseError(j), Contains("some/dir/scen.json: frames: expected an integer in [1, 100000000], got 0"));

  j = baseScenario();
  j["swarms"][0]["count"] = 0;
  CHECK_THAT(parseError(j), Contains("some/dir/scen.json: swarms[0].count: expected an integer"));
  CHECK_THAT(parseError(j), Contains("got 0"));

  j = baseScenario();
  j["swarms"][0]["params"]["field_of_view"] = 400;
  CHECK_THAT(parseError(j), Contains("swarms[0].params.field_of_view: expected a number in [0, 360], got 400"));

  j = baseScenario();
  j["swarms"][0]["params"]["max_speed"] = 0.1;  // below speed 0.2
  CHECK_THAT(parseError(j), Contains("swarms[0].params.max_speed: expected a number >= speed"));

  j = baseScenario();
  j["seed"] = -1;
  CHECK_THAT(parseError(j), Contains("some/dir/scen.json: seed: expected an integer >= 0, got -1"));

  j = baseScenario();
  j["output"] = {{"compression", 10}};
  CHECK_THAT(parseError(j), Contains("some/dir/scen.json: output.compression: expected an integer in [0, 9], got 10"));

  j = baseScenario();
  j["output"] = {{"quantities", {"position", "acceleration"}}};
  CHECK_THAT(parseError(j), Contains("some/dir/scen.json: output.quantities[1]: expected"));

  j = baseScenario();
  j["swarms"][1]["spawn"]["max"] = {0.5, -0.5, 0.5};
  CHECK_THAT(parseError(j), Contains("some/dir/scen.json: swarms[1].spawn.max: expected max >= min"));
}

TEST_CASE("Scenario Inf literal is rejected with file and place", "[scenario]") {
  // 1e999 overflows a double: it must not become Inf, and the error must say
  // where (file:line:column of the literal, or the JSON path "dt")
  std::string file;
  const std::string msg = loadError(
      "{\n"
      "  \"dt\": 1e999,\n"  // the literal starts at line 2, column 9
      "  \"frames\": 3\n"
      "}\n",
      &file);
  CHECK_THAT(msg, Contains(file));
  const bool located = msg.find(file + ":2:9") != std::string::npos || msg.find(file + ": dt: ") != std::string::npos;
  INFO("message: " << msg);
  CHECK(located);

  // and inside a model's params
  std::string file2;
  const std::string msg2 = loadError(
      R"({"dt": 0.1, "frames": 2, "domain": {"min": [0, 0, 0], "max": [1, 1, 1]},
 "swarms": [{"count": 1, "model": "boids", "spawn": {"type": "sphere", "center": [0, 0, 0], "radius": 1},
             "params": {"speed": -1e999}}]})",
      &file2);
  CHECK_THAT(msg2, Contains(file2));
}

TEST_CASE("Scenario malformed JSON reports line and column", "[scenario]") {
  SECTION("a doubled comma") {
    std::string file;
    const std::string msg = loadError(
        "{\n"
        "  \"dt\": 0.1,\n"
        "  \"frames\": 3,,\n"  // the second comma is line 3, column 15
        "  \"domain\": {}\n"
        "}\n",
        &file);
    CHECK_THAT(msg, Contains(file + ":3:15:"));
    CHECK_THAT(msg, Contains("malformed JSON"));
  }
  SECTION("a colon where a value belongs") {
    std::string file;
    const std::string msg = loadError(
        "{\n"
        "  \"dt\": 0.1,\n"
        "  \"frames\": 3,\n"
        "\n"
        "  \"swarms\": [{\"count\": :}]\n"  // the second colon is line 5, column 24
        "}\n",
        &file);
    CHECK_THAT(msg, Contains(file + ":5:24:"));
  }
  SECTION("an empty file") {
    std::string file;
    const std::string msg = loadError("", &file);
    CHECK_THAT(msg, Contains(file + ":"));
    CHECK_THAT(msg, Contains("malformed JSON"));
  }
}

TEST_CASE("Scenario unknown model and duplicate names and bad domain", "[scenario]") {
  Json j = baseScenario();
  j["swarms"][1]["model"] = "boidz";
  std::string msg = parseError(j);
  CHECK_THAT(msg, Contains("some/dir/scen.json: swarms[1].model: expected one of \"boids\""));
  CHECK_THAT(msg, Contains("got \"boidz\""));

  j = baseScenario();
  j["swarms"][1]["name"] = "a";
  msg = parseError(j);
  CHECK_THAT(msg, Contains("some/dir/scen.json: swarms[1].name:"));
  CHECK_THAT(msg, Contains("\"a\""));

  // two swarms without names get distinct default names: fine
  j = baseScenario();
  j["swarms"][0].erase("name");
  j["swarms"][1].erase("name");
  CHECK_NOTHROW(parseScenario(j, kFile));

  j = baseScenario();
  j["swarms"][0]["name"] = "a/b";
  CHECK_THAT(parseError(j), Contains("some/dir/scen.json: swarms[0].name:"));

  j = baseScenario();
  j["domain"]["max"] = {1, -1, 3};  // y: max == min
  msg = parseError(j);
  CHECK_THAT(msg, Contains("some/dir/scen.json: domain.max: expected max > min"));

  j = baseScenario();
  j["domain"]["max"] = {1, 1, -2};  // z: max < min
  CHECK_THAT(parseError(j), Contains("some/dir/scen.json: domain.max: expected max > min"));
}

TEST_CASE("Scenario defaults are filled into resolved", "[scenario]") {
  const Scenario sc = parseScenario(baseScenario(), kFile);
  const Json& r = sc.resolved;
  CHECK(r.at("seed") == 3);
  CHECK(r.at("steps_per_frame") == 1);
  CHECK(sc.stepsPerFrame == 1);
  CHECK(r.at("description") == "");
  CHECK(r.at("output").at("quantities") == Json::array({"position", "velocity"}));
  CHECK(r.at("output").at("compression") == 0);
  // <name>.h5 in the working directory, made absolute
  CHECK(r.at("output").at("path") == (std::filesystem::current_path() / "t.h5").string());
  const Json& a = r.at("swarms").at(0);
  const Json& b = r.at("swarms").at(1);
  CHECK(a.at("params").at("speed") == 0.2);  // given
  CHECK(b.at("params").at("speed") == 0.3);  // BoidsParams default
  CHECK(b.at("params").at("max_speed") == 1.0);
  CHECK(b.at("params").at("repulsion_zone") == 0.05);
  CHECK(b.at("params").at("field_of_view") == 270.0);
  CHECK(b.at("params").at("jitter") == 0.0);
  // documented defaults from the domain [-1,1]x[-1,1]x[-1,3]: 10% of the
  // smallest extent, and the domain centre
  CHECK(b.at("params").at("wall_margin").get<double>() == Approx(0.2));
  CHECK(b.at("params").at("center") == Json::array({0.0, 0.0, 1.0}));
  CHECK(b.at("initial_speed") == 0.0);
  CHECK(b.at("spawn").at("type") == "box");
  CHECK(a.at("spawn").at("type") == "sphere");
  CHECK(a.at("name") == "a");

  // the resolved scenario is itself a valid scenario that resolves to itself
  // (except output.path: a relative path in a file resolves against the file's
  // folder, so it is not expected to survive a second resolution)
  const Scenario again = parseScenario(sc.resolved, kFile);
  Json a1 = again.resolved, a0 = sc.resolved;
  a1["output"].erase("path");
  a0["output"].erase("path");
  CHECK(a1 == a0);

  // without a name, the file's stem is the name
  Json j = baseScenario();
  j.erase("name");
  CHECK(parseScenario(j, "x/y/my_run.json").name == "my_run");
  // without swarm names: swarm<i>
  j = baseScenario();
  j["swarms"][1].erase("name");
  CHECK(parseScenario(j, kFile).swarms[1].name == "swarm1");
}

TEST_CASE("Scenario two swarms with different names", "[scenario]") {
  Json j = baseScenario();
  j["swarms"][0]["name"] = "midges";
  j["swarms"][1]["name"] = "gnats";
  const Scenario sc = parseScenario(j, kFile);
  REQUIRE(sc.swarms.size() == 2u);
  CHECK(sc.swarms[0].name == "midges");
  CHECK(sc.swarms[1].name == "gnats");
  CHECK(sc.swarms[0].count == 10);
  CHECK(sc.swarms[1].count == 5);
  CHECK(sc.swarms[0].model == "boids");
  CHECK(sc.swarms[0].spawn.kind == swarmsim::SpawnRegion::Kind::kSphere);
  CHECK(sc.swarms[0].spawn.radius == 0.5);
  CHECK(sc.swarms[1].spawn.kind == swarmsim::SpawnRegion::Kind::kBox);
  CHECK(sc.swarms[1].spawn.max == swarmsim::Vec3d(0.5, 0.5, 0.5));
  REQUIRE(sc.swarms[0].config);
  REQUIRE(sc.swarms[1].config);
}

TEST_CASE("Scenario output.path resolves against the scenario folder", "[scenario]") {
  TempDir dir;
  namespace fs = std::filesystem;
  fs::create_directories(dir.path() / "sub");
  const std::string file = (dir.path() / "sub" / "s.json").string();
  const auto load = [&](const Json& j) {
    swarmsim_test::writeText(file, j.dump());
    return swarmsim::loadScenario(file);
  };
  Json j = baseScenario();
  j["output"] = {{"path", "out/o.h5"}};
  CHECK(load(j).output.path == (dir.path() / "sub" / "out" / "o.h5").string());
  j["output"] = {{"path", "../o.h5"}};
  CHECK(load(j).output.path == (dir.path() / "o.h5").string());
  const std::string abs = (dir.path() / "abs.h5").string();
  j["output"] = {{"path", abs}};
  CHECK(load(j).output.path == abs);
  // no path: <name>.h5 in the working directory, not next to the file
  j.erase("output");
  CHECK(load(j).output.path == (fs::current_path() / "t.h5").string());
}

TEST_CASE("Scenario --set overrides", "[scenario]") {
  SECTION("swarms[0].count") {
    Json j = baseScenario();
    swarmsim::applyOverride(j, "swarms[0].count=7");
    CHECK(j["swarms"][0]["count"] == 7);
    const Scenario sc = parseScenario(j, kFile);
    CHECK(sc.swarms[0].count == 7);
    CHECK(sc.agentCount() == 12);
  }
  SECTION("a params value, existing and new") {
    Json j = baseScenario();
    swarmsim::applyOverride(j, "swarms[0].params.speed=0.25");
    swarmsim::applyOverride(j, "swarms[1].params.jitter=0.125");  // swarms[1] has no params object
    const Scenario sc = parseScenario(j, kFile);
    CHECK(sc.resolved["swarms"][0]["params"]["speed"] == 0.25);
    CHECK(sc.resolved["swarms"][1]["params"]["jitter"] == 0.125);
  }
  SECTION("values are JSON, else plain strings") {
    Json j = baseScenario();
    swarmsim::applyOverride(j, "name=hello world");
    swarmsim::applyOverride(j, "domain.max=[2, 2, 4]");
    swarmsim::applyOverride(j, "output.compression=4");
    CHECK(j["name"] == "hello world");
    const Scenario sc = parseScenario(j, kFile);
    CHECK(sc.name == "hello world");
    CHECK(sc.domain.max == swarmsim::Vec3d(2, 2, 4));
    CHECK(sc.output.compression == 4);
  }
  SECTION("an override to a bad value is reported at its JSON path") {
    Json j = baseScenario();
    swarmsim::applyOverride(j, "swarms[1].count=0");
    CHECK_THAT(parseError(j), Contains("some/dir/scen.json: swarms[1].count: expected an integer"));
  }
  SECTION("through loadScenario") {
    TempDir dir;
    const std::string file = dir.file("s.json");
    swarmsim_test::writeText(file, baseScenario().dump(2));
    const Scenario sc = swarmsim::loadScenario(file, {"frames=9", "swarms[1].count=3"});
    CHECK(sc.frames == 9);
    CHECK(sc.swarms[1].count == 3);
  }
}

TEST_CASE("Scenario --set errors", "[scenario]") {
  Json j = baseScenario();
  std::string msg = overrideError(j, "swarms[2].count=1");
  CHECK_THAT(msg, Contains("--set swarms[2].count: index [2] is out of range (2 elements)"));
  msg = overrideError(j, "name[0]=1");
  CHECK_THAT(msg, Contains("--set name[0]: index [0] is out of range (not an array)"));
  msg = overrideError(j, "swarms[0].count");
  CHECK_THAT(msg, Contains("--set swarms[0].count: expected PATH=VALUE"));
  msg = overrideError(j, "=5");
  CHECK_THAT(msg, Contains("expected PATH=VALUE"));
  msg = overrideError(j, "swarms[x].count=1");
  CHECK_THAT(msg, Contains("--set swarms[x].count: index is not a number"));
  msg = overrideError(j, "swarms[0.count=1");
  CHECK_THAT(msg, Contains("missing ']'"));
  msg = overrideError(j, "swarms[0]..count=1");
  CHECK_THAT(msg, Contains("empty key"));
  msg = overrideError(j, "swarms.count=1");
  CHECK_THAT(msg, Contains("'count' is inside a non-object value"));
  // a failed override leaves the scenario as it was
  CHECK(j == baseScenario());

  // loadScenario passes override errors through
  TempDir dir;
  const std::string file = dir.file("s.json");
  swarmsim_test::writeText(file, baseScenario().dump());
  CHECK_THROWS_AS(swarmsim::loadScenario(file, {"swarms[9].count=1"}), InputError);
}

TEST_CASE("Scenario nonexistent file", "[scenario]") {
  TempDir dir;
  const std::string file = dir.file("nope.json");
  try {
    swarmsim::loadScenario(file);
    FAIL("loadScenario accepted a missing file");
  } catch (const InputError& e) {
    CHECK(e.code() == swarmsim::kExitInvalidInput);
    CHECK_THAT(std::string(e.what()), Contains(file + ": cannot open file"));
  }
}
