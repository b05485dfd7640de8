// The swarmsim command: exit codes, messages, every shipped scenario, bench,
// --set, and interruption by SIGINT. Drives the built binary (SWARMSIM_EXE).
#include <fcntl.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <filesystem>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <catch2/catch.hpp>

#include "io/scenario.hpp"
#include "swarmsim/version.hpp"
#include "test_util.hpp"

using swarmsim::Json;
using swarmsim_test::CommandResult;
using swarmsim_test::shellQuote;
using swarmsim_test::TempDir;
using Catch::Matchers::Contains;

namespace fs = std::filesystem;

namespace {

const std::string kExe = SWARMSIM_EXE;
const std::string kSourceDir = SWARMSIM_SOURCE_DIR;
const std::string kTiny = kSourceDir + "/tests/data/tiny.json";
const std::string kBadParam = kSourceDir + "/tests/data/bad_param.json";

// run `swarmsim ARGS` (ARGS already shell-quoted where needed) in `dir`
CommandResult runCli(const std::string& args, const TempDir& dir) { return swarmsim_test::runSwarmsim(args, dir.path()); }

Json parseJsonOrFail(const std::string& text) {
  const Json j = Json::parse(text, nullptr, false);
  INFO("output: " << text);
  REQUIRE_FALSE(j.is_discarded());
  return j;
}

Json infoJson(const std::string& file, const TempDir& dir) {
  const auto r = runCli("info --json " + shellQuote(file), dir);
  INFO("stderr: " << r.err);
  REQUIRE(r.exitCode == 0);
  return parseJsonOrFail(r.out);
}

std::vector<std::string> shippedScenarios() {
  std::vector<std::string> files;
  for (const auto& e : fs::directory_iterator(kSourceDir + "/scenarios")) {
    if (e.path().extension() == ".json") files.push_back(e.path().string());
  }
  std::sort(files.begin(), files.end());
  return files;
}

// a partial output, lock or checkpoint left beside an output
bool hasTmpFile(const TempDir& dir) {
  for (const auto& name : dir.entries()) {
    for (const char* mark : {".tmp", ".part", ".lock", ".ckpt"}) {
      if (name.find(mark) != std::string::npos) return true;
    }
  }
  return false;
}
}  // namespace

TEST_CASE("CLI version and help", "[cli]") {
  TempDir dir;
  auto r = runCli("--version", dir);
  CHECK(r.exitCode == 0);
  CHECK_THAT(r.out, Contains(std::string("swarmsim ") + swarmsim::kVersion));

  r = runCli("--help", dir);
  CHECK(r.exitCode == 0);
  CHECK_THAT(r.out, Contains("Usage"));
  for (const char* sub : {"run", "validate", "info", "bench"}) {
    INFO("subcommand " << sub);
    CHECK_THAT(r.out, Contains(sub));  // listed in the top-level help
    const auto s = runCli(std::string(sub) + " --help", dir);
    CHECK(s.exitCode == 0);
    CHECK_THAT(s.out, Contains("Usage"));
    CHECK_THAT(s.out, Contains(std::string(" ") + sub + " "));
  }
  CHECK_THAT(runCli("run --help", dir).out, Contains("--force"));
  CHECK_THAT(runCli("run --help", dir).out, Contains("--set"));
  CHECK_THAT(runCli("bench --help", dir).out, Contains("--agents"));
}

TEST_CASE("CLI runs every shipped scenario", "[cli]") {
  const auto files = shippedScenarios();
  REQUIRE_FALSE(files.empty());
  for (const auto& file : files) {
    DYNAMIC_SECTION(fs::path(file).filename().string()) {
      TempDir dir;
      const std::string out = dir.file("x.h5");
      const auto r = runCli("run " + shellQuote(file) + " --frames 3 -o " + shellQuote(out), dir);
      INFO("stderr: " << r.err);
      REQUIRE(r.exitCode == 0);
      CHECK_THAT(r.out, Contains("done"));
      CHECK_FALSE(hasTmpFile(dir));
      const Json info = infoJson(out, dir);
      CHECK(info.at("frames") == 3);
      CHECK(info.at("complete") == true);
      CHECK(info.at("interrupted") == false);
      CHECK(info.at("format") == "swarmsim-trajectory");
      const swarmsim::Scenario sc = swarmsim::loadScenario(file);
      REQUIRE(info.at("swarms").size() == sc.swarms.size());
      for (std::size_t i = 0; i < sc.swarms.size(); ++i) {
        CHECK(info.at("swarms")[i].at("name") == sc.swarms[i].name);
        CHECK(info.at("swarms")[i].at("agents") == sc.swarms[i].count);
        CHECK(info.at("swarms")[i].at("frames") == 3);
      }

      // validate prints the resolved scenario as JSON
      const auto v = runCli("validate " + shellQuote(file), dir);
      INFO("validate stderr: " << v.err);
      CHECK(v.exitCode == 0);
      const Json resolved = parseJsonOrFail(v.out);
      CHECK(resolved == sc.resolved);
    }
  }
}

TEST_CASE("CLI invalid input exits with code 2", "[cli]") {
  TempDir dir;
  SECTION("bad scenario: stderr names the file and the JSON path") {
    for (const std::string& args : {"run " + shellQuote(kBadParam) + " -o " + shellQuote(dir.file("o.h5")),
                                   "validate " + shellQuote(kBadParam)}) {
      INFO("swarmsim " << args);
      const auto r = runCli(args, dir);
      CHECK(r.exitCode == 2);
      CHECK_THAT(r.err, Contains(kBadParam + ": swarms[0].params.repulsion_zone: expected a number >= 0, got -1"));
    }
    CHECK_FALSE(fs::exists(dir.file("o.h5")));
  }
  SECTION("malformed scenario file") {
    const std::string file = dir.file("broken.json");
    swarmsim_test::writeText(file, "{\n  \"dt\": 0.1,,\n}\n");
    const auto r = runCli("run " + shellQuote(file) + " -o " + shellQuote(dir.file("o.h5")), dir);
    CHECK(r.exitCode == 2);
    CHECK_THAT(r.err, Contains(file + ":2:13"));  // the second comma
  }
  SECTION("nonexistent scenario file") {
    const std::string missing = dir.file("no_such_scenario.json");
    const auto r = runCli("run " + shellQuote(missing) + " -o " + shellQuote(dir.file("o.h5")), dir);
    CHECK(r.exitCode == 2);
    CHECK_THAT(r.err, Contains(missing));
    CHECK(runCli("validate " + shellQuote(missing), dir).exitCode == 2);
  }
  SECTION("bad options") {
    CHECK(runCli("run " + shellQuote(kTiny) + " --bogus -o x.h5", dir).exitCode == 2);
    CHECK(runCli("run", dir).exitCode == 2);                    // missing scenario
    CHECK(runCli("frobnicate", dir).exitCode == 2);             // unknown subcommand
    CHECK(runCli("", dir).exitCode == 2);                       // no subcommand
    CHECK(runCli("run " + shellQuote(kTiny) + " --frames 0 -o x.h5", dir).exitCode == 2);
    CHECK(runCli("run " + shellQuote(kTiny) + " --frames many -o x.h5", dir).exitCode == 2);
    CHECK(runCli("run " + shellQuote(kTiny) + " --threads 0 -o x.h5", dir).exitCode == 2);
    CHECK(runCli("bench --agents 10,abc " + shellQuote(kTiny), dir).exitCode == 2);
    const auto set = runCli("run " + shellQuote(kTiny) + " --set 'swarms[9].count=1' -o x.h5", dir);
    CHECK(set.exitCode == 2);
    CHECK_THAT(set.err, Contains("swarms[9]"));
    CHECK_FALSE(fs::exists(dir.file("x.h5")));
    CHECK_FALSE(hasTmpFile(dir));
  }
  SECTION("info on a file that is not a trajectory") {
    swarmsim_test::writeText(dir.file("plain.txt"), "hello\n");
    CHECK(runCli("info " + shellQuote(dir.file("plain.txt")), dir).exitCode == 2);
    CHECK(runCli("info " + shellQuote(dir.file("missing.h5")), dir).exitCode == 2);
  }
}

TEST_CASE("CLI existing output needs --force", "[cli]") {
  TempDir dir;
  const std::string out = dir.file("out.h5");
  const std::string run = "run " + shellQuote(kTiny) + " --frames 2 -o " + shellQuote(out);
  REQUIRE(runCli(run, dir).exitCode == 0);
  const std::string before = swarmsim_test::readText(out);

  const auto again = runCli(run, dir);
  CHECK(again.exitCode == 3);
  CHECK_THAT(again.err, Contains(out));
  CHECK_THAT(again.err, Contains("exists"));
  CHECK(swarmsim_test::readText(out) == before);

  const auto forced = runCli("run " + shellQuote(kTiny) + " --frames 4 --force -o " + shellQuote(out), dir);
  CHECK(forced.exitCode == 0);
  CHECK(infoJson(out, dir).at("frames") == 4);

  // an output path that is a folder cannot be written either
  fs::create_directories(dir.path() / "folder.h5");
  CHECK(runCli("run " + shellQuote(kTiny) + " --frames 2 --force -o " + shellQuote(dir.file("folder.h5")), dir)
            .exitCode == 3);
  CHECK_FALSE(hasTmpFile(dir));
}

TEST_CASE("CLI --set changes the scenario", "[cli]") {
  TempDir dir;
  const std::string out = dir.file("set.h5");
  const auto r = runCli("run " + shellQuote(kTiny) + " --frames 2 --set 'swarms[0].count=7' --set 'swarms[1].params.speed=0.5' -o " +
                              shellQuote(out),
                          dir);
  INFO("stderr: " << r.err);
  REQUIRE(r.exitCode == 0);
  const Json info = infoJson(out, dir);
  CHECK(info.at("swarms")[0].at("agents") == 7);
  CHECK(info.at("swarms")[1].at("agents") == 50);  // unchanged
  // the stored scenario records the overrides
  const auto v = runCli("validate " + shellQuote(kTiny) + " --set 'swarms[0].count=7' --set 'swarms[1].params.speed=0.5'", dir);
  REQUIRE(v.exitCode == 0);
  const Json resolved = parseJsonOrFail(v.out);
  CHECK(resolved["swarms"][0]["count"] == 7);
  CHECK(resolved["swarms"][1]["params"]["speed"] == 0.5);
  // --seed overrides the seed
  const std::string out2 = dir.file("seed.h5");
  REQUIRE(runCli("run " + shellQuote(kTiny) + " --frames 2 --seed 99 -o " + shellQuote(out2), dir).exitCode == 0);
  CHECK(infoJson(out2, dir).at("seed") == 99);
}

TEST_CASE("CLI bench prints JSON lines", "[cli]") {
  TempDir dir;
  const auto r = runCli("bench --agents 2000 --frames 2 --repeat 1 --json " + shellQuote(kTiny), dir);
  INFO("stdout: " << r.out << "\nstderr: " << r.err);
  REQUIRE(r.exitCode == 0);
  std::istringstream lines(r.out);
  std::string line;
  int rows = 0;
  while (std::getline(lines, line)) {
    if (line.empty()) continue;
    const Json j = parseJsonOrFail(line);
    ++rows;
    CHECK(j.at("agents") == 2000);
    CHECK(j.at("scenario") == "tiny");
    CHECK(j.at("model") == "boids");
    CHECK(j.at("steps_per_s").get<double>() > 0.0);
    CHECK(j.at("steps") == 4);  // 2 frames of 2 steps
  }
  CHECK(rows == 1);
}

TEST_CASE("CLI bench --skip times the frames after the skipped ones, the model's phases too", "[cli][shape]") {
  TempDir dir;
  const std::string moon = kSourceDir + "/scenarios/moon.json";
  const auto r =
      runCli("bench " + shellQuote(moon) + " --set 'swarms[0].count=400' --skip 3 --frames 2 --repeat 1 --json", dir);
  INFO("stdout: " << r.out << "\nstderr: " << r.err);
  REQUIRE(r.exitCode == 0);
  const Json j = parseJsonOrFail(r.out.substr(0, r.out.find('\n')));
  CHECK(j.at("steps") == 4);          // 2 frames of 2 steps
  CHECK(j.at("skipped_steps") == 6);  // 3 frames
  const Json& info = j.at("model_info").at(0);
  CHECK(info.at("timed_steps") == 4);  // the model's phases over the timed steps only
  // per timed step: fractions of steps and insects, so at most 1
  CHECK(info.at("grid_builds").get<double>() <= 1.0);
  CHECK(info.at("list_rebuilds").get<double>() <= 1.0);
  CHECK(info.at("ms_forces").get<double>() > 0.0);
  CHECK(runCli("bench " + shellQuote(moon) + " --skip -1", dir).exitCode == 2);
}

TEST_CASE("CLI bench --case runs only the built-in cases named", "[cli]") {
  TempDir dir;
  // two of the four, at a small size: only their rows
  const auto r = runCli("bench --case boids-100k,orca-100k --agents 3000 --frames 2 --repeat 1 --json", dir);
  INFO("stdout: " << r.out << "\nstderr: " << r.err);
  REQUIRE(r.exitCode == 0);
  std::istringstream lines(r.out);
  std::vector<std::string> names;
  for (std::string line; std::getline(lines, line);) {
    if (!line.empty()) names.push_back(parseJsonOrFail(line).at("scenario").get<std::string>());
  }
  CHECK(names == std::vector<std::string>{"boids-100k", "orca-100k"});
  // a variant without its base case
  const auto v = runCli("bench --case fmm-128-order2 --agents 1 --frames 1 --repeat 1 --json", dir);
  REQUIRE(v.exitCode == 0);
  CHECK_THAT(v.out, Contains("fmm-128-order2"));
  CHECK_THAT(v.out, !Contains("\"fmm-128\""));
  // an unknown name and a case with a file are refused, naming what is expected
  const auto bad = runCli("bench --case boids-1m", dir);
  CHECK(bad.exitCode == 2);
  CHECK_THAT(bad.err, Contains("boids-1m") && Contains("orca-100k"));
  CHECK(runCli("bench --case orca-100k " + shellQuote(kTiny), dir).exitCode == 2);
}

TEST_CASE("CLI SIGINT stops a run with a valid file", "[cli]") {
  TempDir dir;
  const std::string out = dir.file("long.h5");
  // a run that would take hours: 2,000 agents, 50 steps per frame, 10^8 frames
  const std::vector<std::string> args = {kExe,        "run",       kTiny,
                                         "--frames",  "100000000", "--set",
                                         "swarms[0].count=2000", "--set", "steps_per_frame=50",
                                         "-o",        out};
  const std::string outLog = dir.file("run.stdout"), errLog = dir.file("run.stderr");
  const pid_t pid = fork();
  REQUIRE(pid >= 0);
  if (pid == 0) {
    const int o = open(outLog.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int e = open(errLog.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (o < 0 || e < 0 || dup2(o, 1) < 0 || dup2(e, 2) < 0 || chdir(dir.path().c_str()) != 0) _exit(127);
    std::vector<char*> argv;
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    execv(kExe.c_str(), argv.data());
    _exit(127);
  }
  using Clock = std::chrono::steady_clock;
  // wait until the run writes (its temporary file appears), at most 10 s
  const auto t0 = Clock::now();
  bool started = false;
  while (Clock::now() - t0 < std::chrono::seconds(10)) {
    if (fs::exists(dir.file(".long.h5.part"))) {
      started = true;
      break;
    }
    int status = 0;
    if (waitpid(pid, &status, WNOHANG) == pid) FAIL("the run ended before it was interrupted: " << swarmsim_test::readText(errLog));
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  CHECK(started);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // a few frames
  REQUIRE(kill(pid, SIGINT) == 0);

  // it must stop at the next frame boundary; give it 30 s, then kill it
  int status = 0;
  bool exited = false;
  while (Clock::now() - t0 < std::chrono::seconds(40)) {
    if (waitpid(pid, &status, WNOHANG) == pid) {
      exited = true;
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  if (!exited) {
    kill(pid, SIGKILL);
    waitpid(pid, &status, 0);
    FAIL("swarmsim did not stop within 30 s of SIGINT");
  }
  INFO("stderr: " << swarmsim_test::readText(errLog));
  REQUIRE(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) == 4);
  CHECK_THAT(swarmsim_test::readText(outLog), Contains("interrupted"));
  REQUIRE(fs::exists(out));
  // beside the interrupted output: only its checkpoint (for --resume)
  CHECK(fs::exists(dir.file(".long.h5.ckpt")));
  CHECK_FALSE(fs::exists(dir.file(".long.h5.part")));
  CHECK_FALSE(fs::exists(dir.file(".long.h5.lock")));
  const Json info = infoJson(out, dir);
  CHECK(info.at("frames").get<long long>() >= 1);
  CHECK(info.at("interrupted") == true);
  CHECK(info.at("complete") == false);
  CHECK(info.at("swarms")[0].at("frames") == info.at("frames"));
  CHECK(info.at("swarms")[0].at("agents") == 2000);
}

TEST_CASE("CLI D7: --seed takes 0 to 2^64-1 exactly and refuses more", "[cli]") {
  TempDir dir;
  const std::string base = "run " + shellQuote(kTiny) + " --frames 2 --quiet ";
  for (const char* big : {"18446744073709551616", "99999999999999999999999", "-1", "1e3", "12abc"}) {
    const auto r = runCli(base + "-o a.h5 --seed " + shellQuote(big), dir);
    INFO("seed " << big << ": " << r.err);
    CHECK(r.exitCode == 2);
    CHECK_THAT(r.err, Contains("--seed"));
  }
  CHECK_FALSE(fs::exists(dir.file("a.h5")));
  // 2^63 and 2^64 - 1 are different seeds, stored exactly (they used to collide at 2^63 - 1)
  REQUIRE(runCli(base + "-o b.h5 --seed 9223372036854775808", dir).exitCode == 0);
  REQUIRE(runCli(base + "-o c.h5 --seed 18446744073709551615", dir).exitCode == 0);
  CHECK(infoJson("b.h5", dir).at("seed").get<unsigned long long>() == 9223372036854775808ULL);
  CHECK(infoJson("c.h5", dir).at("seed").get<unsigned long long>() == 18446744073709551615ULL);
}

TEST_CASE("CLI D11: command-line errors are one line with the swarmsim prefix, exit 2", "[cli]") {
  TempDir dir;
  for (const char* args : {"run", "run --bogus x.json", "bench --repeat 0", "run x.json --threads 0"}) {
    const auto r = runCli(args, dir);
    INFO(args << ": " << r.err);
    CHECK(r.exitCode == 2);
    CHECK(r.err.rfind("swarmsim: error: ", 0) == 0);
    CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
  }
}
