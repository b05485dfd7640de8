// Checkpoint and resume: a run stopped by SIGKILL, SIGTERM or SIGHUP at random
// points of a multi-model scenario (boids, field with a moving goal, bswarm
// with a moving predator), then continued with --resume, ends in a file
// byte-identical to an uninterrupted run; also across thread counts and with
// compressed output. Drives the built binary (SWARMSIM_EXE).
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "core/state_buffer.hpp"
#include "io/checkpoint.hpp"
#include "io/trajectory_reader.hpp"
#include "test_util.hpp"

using swarmsim_test::Child;
using swarmsim_test::TempDir;
using Catch::Matchers::Contains;

namespace fs = std::filesystem;

namespace {

const std::string& kExe = swarmsim_test::kSwarmsimExe;
const std::string kMulti = swarmsim_test::kSourceTree + "/tests/data/multi_model.json";

std::vector<std::string> runArgs(const std::vector<std::string>& extra) {
  // 150 frames: a run of a few seconds, so that most stops land inside it
  std::vector<std::string> a = {kExe, "run", kMulti, "-o", "out.h5", "--quiet", "--frames", "150"};
  a.insert(a.end(), extra.begin(), extra.end());
  return a;
}

// run to the end; returns the exit code (or -1)
int runToEnd(const TempDir& dir, const std::vector<std::string>& extra, std::string* err = nullptr) {
  const Child c = swarmsim_test::spawnChild(runArgs(extra), dir.path(), "end");
  const int status = swarmsim_test::waitChild(c.pid, 120000);
  if (err) *err = swarmsim_test::readText(c.errLog);
  return status >= 0 && WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string fileBytes(const std::string& path) { return swarmsim_test::readText(path); }

// Stop the run with `sig` at `kills` random moments (each run after the first
// resumes), then finish it with --resume; the output must equal the reference.
// afterCheckpoint: each stop comes after the run's first checkpoint is written (else a stop may come before
// it, and a loaded machine can make every stop do so)
void killAndResume(int sig, int kills, const std::vector<std::string>& options, const std::vector<std::string>& refOptions,
                   unsigned seed, bool afterCheckpoint = false) {
  TempDir dir;
  // the reference run, timed from the appearance of its partial file (the stops are timed from there too)
  std::chrono::milliseconds refMs(0);
  {
    const Child c = swarmsim_test::spawnChild(runArgs(refOptions), dir.path(), "end");
    swarmsim_test::waitForFile(dir.file(".out.h5.part"), c.pid, 30000);
    const auto start = std::chrono::steady_clock::now();
    const int status = swarmsim_test::waitChild(c.pid, 120000);
    refMs = std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::steady_clock::now() - start);
    INFO("reference run stderr: " << swarmsim_test::readText(c.errLog));
    REQUIRE((status >= 0 && WIFEXITED(status) && WEXITSTATUS(status) == 0));
  }
  fs::rename(dir.file("out.h5"), dir.file("ref.h5"));
  const std::string ref = fileBytes(dir.file("ref.h5"));
  REQUIRE(ref.size() > 1000);

  std::mt19937 rng(seed);
  // ms after the partial file appears: within the first 60 % of an uninterrupted run's time from there,
  // whatever the machine's speed (a fixed bound let every stop come after the end of a 0.5 s run)
  std::uniform_int_distribution<int> delay(0, std::max(20, static_cast<int>(refMs.count() * 6 / 10)));
  int stoppedMidway = 0;
  for (int k = 0; k < kills; ++k) {
    std::vector<std::string> extra = options;
    if (k > 0) extra.push_back("--resume");
    const Child c = swarmsim_test::spawnChild(runArgs(extra), dir.path(), "kill");
    // wait for the run to write (or to end, if it was nearly done)
    swarmsim_test::waitForFile(dir.file(".out.h5.part"), c.pid, 30000);
    if (afterCheckpoint) swarmsim_test::waitForFile(dir.file(".out.h5.ckpt"), c.pid, 30000);
    const int ms = delay(rng);
    usleep(static_cast<useconds_t>(ms) * 1000);
    kill(c.pid, sig);
    const int status = swarmsim_test::waitChild(c.pid, 60000);
    INFO("kill " << k << " after " << ms << " ms, stderr: " << swarmsim_test::readText(c.errLog));
    REQUIRE(status != -1);
    if (sig == SIGKILL) {
      CHECK((WIFSIGNALED(status) || (WIFEXITED(status) && WEXITSTATUS(status) == 0)));
    } else {
      // a stop signal: exit 4 with a valid output and its checkpoint, or 0 if it came too late
      REQUIRE(WIFEXITED(status));
      const int code = WEXITSTATUS(status);
      CHECK((code == 4 || code == 0));
      if (code == 4) {
        const auto info = swarmsim::readTrajectoryInfo(dir.file("out.h5"));
        CHECK(info.interrupted);
        CHECK(fs::exists(dir.file(".out.h5.ckpt")));
        CHECK_FALSE(fs::exists(dir.file(".out.h5.part")));
      }
    }
    if (fs::exists(dir.file(".out.h5.ckpt"))) ++stoppedMidway;
  }
  std::string err, listing;
  for (const auto& name : dir.entries()) listing += name + " ";
  INFO("before the final resume: " << listing);
  std::vector<std::string> last = options;
  last.push_back("--resume");
  const int code = runToEnd(dir, last, &err);
  INFO("final resume stderr: " << err);
  REQUIRE(code == 0);
  CHECK(stoppedMidway > 0);  // at least one stop left something to resume
  const std::string out = fileBytes(dir.file("out.h5"));
  CHECK(out.size() == ref.size());
  const bool identical = out == ref;  // byte for byte
  CHECK(identical);
  // nothing left beside the output
  std::vector<std::string> left;
  for (const auto& name : dir.entries()) {
    if (name != "out.h5" && name != "ref.h5" && name.find(".stdout") == std::string::npos &&
        name.find(".stderr") == std::string::npos) {
      left.push_back(name);
    }
  }
  CHECK(left.empty());
}

}  // namespace

TEST_CASE("Resume after SIGKILL at random points is byte-identical", "[resume]") {
  killAndResume(SIGKILL, 3, {"--checkpoint-every", "0"}, {}, 11);
}

TEST_CASE("Resume after SIGKILL with the default checkpoint interval", "[resume]") {
  // only the frame-0 checkpoint exists: the resume starts again from there. The stop waits for it: under
  // ctest -j2 a stop a few ms after the partial file appeared once came before it (nothing to resume)
  killAndResume(SIGKILL, 1, {}, {}, 12, true);
}

TEST_CASE("Resume after SIGTERM at random points is byte-identical", "[resume]") {
  killAndResume(SIGTERM, 3, {}, {}, 13);
}

TEST_CASE("Resume after SIGHUP at random points is byte-identical", "[resume]") {
  killAndResume(SIGHUP, 3, {}, {}, 14);
}

TEST_CASE("Resume with other thread counts is byte-identical", "[resume]") {
  killAndResume(SIGKILL, 2, {"--checkpoint-every", "0", "--threads", "2"}, {"--threads", "1"}, 15);
}

TEST_CASE("Resume of compressed output after SIGKILL is byte-identical", "[resume]") {
  const std::vector<std::string> z = {"--set", "output.compression=4"};
  std::vector<std::string> opts = z;
  opts.insert(opts.end(), {"--checkpoint-every", "0"});
  killAndResume(SIGKILL, 2, opts, z, 16);
}

TEST_CASE("Resume refuses another scenario and explains leftovers", "[resume]") {
  TempDir dir;
  const Child c = swarmsim_test::spawnChild(runArgs({"--checkpoint-every", "0"}), dir.path(), "a");
  // sanitized and on a busy machine, start-up can take long
  REQUIRE(swarmsim_test::waitForFile(dir.file(".out.h5.ckpt"), c.pid, 120000));
  usleep(300000);
  kill(c.pid, SIGKILL);
  swarmsim_test::waitChild(c.pid, 30000);
  REQUIRE(fs::exists(dir.file(".out.h5.part")));

  // a plain run does not silently replace the partial output
  std::string err;
  CHECK(runToEnd(dir, {}, &err) == 3);
  CHECK_THAT(err, Contains("--resume"));
  CHECK_THAT(err, Contains(".out.h5.part"));
  CHECK(fs::exists(dir.file(".out.h5.part")));
  // other options: another run, refused
  CHECK(runToEnd(dir, {"--resume", "--seed", "5"}, &err) == 2);
  CHECK_THAT(err, Contains("another scenario"));
  CHECK(fs::exists(dir.file(".out.h5.part")));
  // a damaged checkpoint is refused, not misread
  {
    std::string ck = swarmsim_test::readText(dir.file(".out.h5.ckpt"));
    const std::string saved = ck;
    ck[ck.size() / 2] ^= 0x5a;
    swarmsim_test::writeText(dir.file(".out.h5.ckpt"), ck);
    CHECK(runToEnd(dir, {"--resume"}, &err) == 2);
    CHECK_THAT(err, Contains("checksum"));
    swarmsim_test::writeText(dir.file(".out.h5.ckpt"), saved);
  }
  // --force starts again
  CHECK(runToEnd(dir, {"--force"}, &err) == 0);
  CHECK_FALSE(fs::exists(dir.file(".out.h5.part")));
  CHECK_FALSE(fs::exists(dir.file(".out.h5.ckpt")));
  // --resume of a complete output does nothing
  const std::string before = swarmsim_test::readText(dir.file("out.h5"));
  const Child d = swarmsim_test::spawnChild({kExe, "run", kMulti, "-o", "out.h5", "--frames", "150", "--resume"}, dir.path(), "d");
  const int st = swarmsim_test::waitChild(d.pid, 60000);
  REQUIRE(WIFEXITED(st));
  CHECK(WEXITSTATUS(st) == 0);
  CHECK_THAT(swarmsim_test::readText(d.outLog), Contains("already complete"));
  CHECK(swarmsim_test::readText(dir.file("out.h5")) == before);
}

TEST_CASE("SIGTERM is answered within a second even when a frame takes longer", "[resume]") {
  TempDir dir;
  // 2,000 steps per frame: a frame takes several seconds
  const Child c = swarmsim_test::spawnChild(
      {kExe, "run", kMulti, "-o", "out.h5", "--set", "steps_per_frame=2000", "--frames", "3"}, dir.path(), "t");
  REQUIRE(swarmsim_test::waitForFile(dir.file(".out.h5.ckpt"), c.pid, 120000));  // frame 0 written
  usleep(500000);
  const auto t0 = std::chrono::steady_clock::now();
  kill(c.pid, SIGTERM);
  const int status = swarmsim_test::waitChild(c.pid, 10000);
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  INFO("stderr: " << swarmsim_test::readText(c.errLog));
  REQUIRE(status != -1);
  CHECK(s < 1.0);
  REQUIRE(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) == 4);
  const auto info = swarmsim::readTrajectoryInfo(dir.file("out.h5"));
  CHECK(info.frames == 1);
  CHECK(info.interrupted);
  // the checkpoint is mid-frame: the step reached, not the frame boundary
  const swarmsim::Checkpoint ck = swarmsim::readCheckpoint(dir.file(".out.h5.ckpt"));
  CHECK(ck.frames == 1);
  CHECK(ck.step > 0);
  CHECK(ck.step < 2000);
}

TEST_CASE("SIGUSR1 writes a checkpoint and the run goes on", "[resume]") {
  TempDir dir;
  const Child c = swarmsim_test::spawnChild(
      {kExe, "run", kMulti, "-o", "out.h5", "--set", "steps_per_frame=400", "--frames", "3"}, dir.path(), "u");
  REQUIRE(swarmsim_test::waitForFile(dir.file(".out.h5.ckpt"), c.pid, 120000));
  const swarmsim::Checkpoint first = swarmsim::readCheckpoint(dir.file(".out.h5.ckpt"));
  CHECK(first.step == 0);
  usleep(300000);
  kill(c.pid, SIGUSR1);
  // a newer checkpoint appears while the run goes on
  bool newer = false;
  for (int i = 0; i < 400 && !newer; ++i) {
    usleep(10000);
    try {
      newer = swarmsim::readCheckpoint(dir.file(".out.h5.ckpt")).step > 0;
    } catch (const std::exception&) {
    }
  }
  CHECK(newer);
  const int status = swarmsim_test::waitChild(c.pid, 120000);
  INFO("stderr: " << swarmsim_test::readText(c.errLog));
  REQUIRE(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) == 0);
  CHECK(swarmsim::readTrajectoryInfo(dir.file("out.h5")).complete);
}

TEST_CASE("Checkpoint state buffers refuse short data", "[resume]") {
  swarmsim::StateOut out;
  out.put<std::uint64_t>(7);
  out.putVector(std::vector<float>{1.0f, 2.0f});
  swarmsim::StateIn in(out.bytes());
  CHECK(in.get<std::uint64_t>() == 7u);
  CHECK(in.getVector<float>() == std::vector<float>{1.0f, 2.0f});
  CHECK(in.atEnd());
  CHECK_THROWS(in.get<float>());
  const std::string cut = out.bytes().substr(0, 12);
  swarmsim::StateIn in2(cut);
  in2.get<std::uint64_t>();
  CHECK_THROWS(in2.getVector<float>());
}
