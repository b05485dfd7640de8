// Output-path safety (issue 9, D1, D2, D9, D10): the final path is only ever
// created, or replaced with --force when it is a regular swarmsim output or an
// empty file; devices, FIFOs, directories and foreign files are refused with
// exit 3; symbolic links are written through; a full disk or a file-size limit
// is exit 3 without a crash, keeping what a resume needs; two runs never write
// one output at once, and a file that appears during a run is not replaced.
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "io/trajectory_reader.hpp"
#include "test_util.hpp"

using swarmsim_test::shellQuote;
using swarmsim_test::TempDir;
using Catch::Matchers::Contains;

namespace fs = std::filesystem;

namespace {

const std::string& kExe = swarmsim_test::kSwarmsimExe;
const std::string kTiny = swarmsim_test::kSourceTree + "/tests/data/tiny.json";

swarmsim_test::CommandResult runCli(const std::string& args, const TempDir& dir) {
  return swarmsim_test::runSwarmsim(args, dir.path());
}

std::string tinyRun(const std::string& out, const std::string& extra = "") {
  return "run " + shellQuote(kTiny) + " --frames 3 -o " + shellQuote(out) + " " + extra;
}

bool isCharDevice(const std::string& p) {
  struct stat st {};
  return lstat(p.c_str(), &st) == 0 && S_ISCHR(st.st_mode);
}

}  // namespace

TEST_CASE("D1: --force onto a device node refuses and leaves it alone", "[safety]") {
  TempDir dir;
  const std::string dev = dir.file("nulldev");
  if (mknod(dev.c_str(), S_IFCHR | 0666, makedev(1, 3)) != 0) {
    WARN("skipped: mknod needs root (CI runs as root)");
    return;
  }
  REQUIRE(isCharDevice(dev));
  const auto r = runCli(tinyRun(dev, "--force"), dir);
  INFO("stderr: " << r.err);
  CHECK(r.exitCode == 3);
  CHECK_THAT(r.err, Contains("character device"));
  CHECK(isCharDevice(dev));  // still the device, not a regular file
  // the same through a symbolic link to it, and for the system's /dev/null
  fs::create_symlink(dev, dir.file("link.h5"));
  CHECK(runCli(tinyRun("link.h5", "--force"), dir).exitCode == 3);
  CHECK(isCharDevice(dev));
  CHECK(runCli(tinyRun("/dev/null", "--force"), dir).exitCode == 3);
  CHECK(isCharDevice("/dev/null"));
  // nothing of ours left behind
  for (const auto& name : dir.entries()) {
    CHECK(name.find(".part") == std::string::npos);
    CHECK(name.find(".lock") == std::string::npos);
  }
}

TEST_CASE("D1: FIFOs, directories and foreign files are never replaced", "[safety]") {
  TempDir dir;
  REQUIRE(mkfifo(dir.file("fifo").c_str(), 0644) == 0);
  auto r = runCli(tinyRun("fifo", "--force"), dir);
  CHECK(r.exitCode == 3);
  CHECK_THAT(r.err, Contains("FIFO"));
  fs::create_directory(dir.file("folder.h5"));
  r = runCli(tinyRun("folder.h5", "--force"), dir);
  CHECK(r.exitCode == 3);
  CHECK_THAT(r.err, Contains("directory"));
  // a regular file that is not a swarmsim output: not even with --force
  swarmsim_test::writeText(dir.file("notes.txt"), "precious\n");
  r = runCli(tinyRun("notes.txt", "--force"), dir);
  CHECK(r.exitCode == 3);
  CHECK_THAT(r.err, Contains("not a swarmsim output"));
  CHECK(swarmsim_test::readText(dir.file("notes.txt")) == "precious\n");
  // an empty file (e.g. from mktemp) and our own output are replaced with --force
  swarmsim_test::writeText(dir.file("empty.h5"), "");
  CHECK(runCli(tinyRun("empty.h5", "--force"), dir).exitCode == 0);
  CHECK(swarmsim::readTrajectoryInfo(dir.file("empty.h5")).complete);
  CHECK(runCli(tinyRun("empty.h5", "--force"), dir).exitCode == 0);
  // the empty path is refused, not replaced by the scenario's own output path
  r = runCli("run " + shellQuote(kTiny) + " --frames 2 -o ''", dir);
  CHECK(r.exitCode == 2);
  CHECK_THAT(r.err, Contains("empty"));
  CHECK_FALSE(fs::exists(dir.file("tiny.h5")));
}

TEST_CASE("D1: a symbolic link is written through", "[safety]") {
  TempDir dir;
  fs::create_directory(dir.file("store"));
  REQUIRE(runCli(tinyRun("store/real.h5"), dir).exitCode == 0);
  fs::create_symlink("store/real.h5", dir.file("current.h5"));
  const auto r = runCli(tinyRun("current.h5", "--force --set seed=9"), dir);
  INFO("stderr: " << r.err);
  REQUIRE(r.exitCode == 0);
  CHECK(fs::is_symlink(dir.file("current.h5")));  // the link stays a link
  CHECK(swarmsim::readTrajectoryInfo(dir.file("store/real.h5")).seed == 9u);
  // a dangling link: its target is created
  fs::create_symlink("store/new.h5", dir.file("next.h5"));
  REQUIRE(runCli(tinyRun("next.h5"), dir).exitCode == 0);
  CHECK(fs::is_symlink(dir.file("next.h5")));
  CHECK(swarmsim::readTrajectoryInfo(dir.file("store/new.h5")).complete);
}

TEST_CASE("D2: a file-size limit is exit 3, no crash, nothing half-written", "[safety]") {
  TempDir dir;
  const std::string args = "run " + shellQuote(kTiny) + " --frames 40 --set 'swarms[0].count=2000' -o out.h5";
  const auto r = swarmsim_test::runCommand(
      "cd " + shellQuote(dir.path().string()) + " && ulimit -f 400 && " + shellQuote(kExe) + " " + args, dir.path());
  INFO("stderr: " << r.err);
  CHECK(r.exitCode == 3);  // not 139 (a crash in HDF5's exit handler), not 1, not SIGXFSZ
  CHECK_THAT(r.err, Contains("cannot write"));
  CHECK(dir.entries() == std::vector<std::string>{});  // no output, no partial file, no lock
}

TEST_CASE("D2: a full disk is exit 3 without a crash, and the run resumes once there is space", "[safety]") {
  TempDir dir;
  const std::string mnt = dir.file("small");
  fs::create_directory(mnt);
  const auto m = swarmsim_test::runCommand("mount -t tmpfs -o size=1m tmpfs " + shellQuote(mnt), dir.path());
  if (m.exitCode != 0) {
    WARN("skipped: cannot mount a tmpfs here: " << m.err);
    return;
  }
  struct Unmount {
    std::string path;
    ~Unmount() { swarmsim_test::runCommand("umount " + shellQuote(path), fs::temp_directory_path()); }
  } unmount{mnt};
  // ~120 KB a frame: the 1 MB file system fills after a few frames
  const std::string args = "run " + shellQuote(kTiny) + " --frames 30 --set 'swarms[0].count=5000' --checkpoint-every 0";
  // the reference, written where there is space but recorded under the same path
  swarmsim_test::runCommand("mount -o remount,size=64m " + shellQuote(mnt), dir.path());
  REQUIRE(runCli(args + " -o " + shellQuote(mnt + "/out.h5"), dir).exitCode == 0);
  fs::copy_file(mnt + "/out.h5", dir.file("ref.h5"));
  fs::remove(mnt + "/out.h5");
  swarmsim_test::runCommand("mount -o remount,size=1m " + shellQuote(mnt), dir.path());

  const auto r = runCli(args + " -o " + shellQuote(mnt + "/out.h5"), dir);
  INFO("stderr: " << r.err);
  CHECK(r.exitCode == 3);
  CHECK_THAT(r.err, Contains("cannot write"));  // the frame or the checkpoint, whichever met the full disk
  CHECK_THAT(r.err, Contains("--resume"));
  CHECK_FALSE(fs::exists(mnt + "/out.h5"));
  CHECK(fs::exists(mnt + "/.out.h5.part"));
  CHECK(fs::exists(mnt + "/.out.h5.ckpt"));
  // space again: the resumed run equals one that never stopped
  swarmsim_test::runCommand("mount -o remount,size=64m " + shellQuote(mnt), dir.path());
  const auto r2 = runCli(args + " -o " + shellQuote(mnt + "/out.h5") + " --resume", dir);
  INFO("resume stderr: " << r2.err);
  REQUIRE(r2.exitCode == 0);
  const bool identical = swarmsim_test::readText(mnt + "/out.h5") == swarmsim_test::readText(dir.file("ref.h5"));
  CHECK(identical);
}

TEST_CASE("D9: two runs never write one output at once", "[safety]") {
  TempDir dir;
  // a long first run
  const swarmsim_test::Child a = swarmsim_test::spawnChild(
      {kExe, "run", kTiny, "--frames", "400", "--set", "swarms[0].count=1000", "-o", "out.h5"}, dir.path(), "a");
  REQUIRE(swarmsim_test::waitForFile(dir.file(".out.h5.part"), a.pid, 30000));
  // the second, without --force and with it: refused while the first holds the output
  auto r = runCli(tinyRun("out.h5"), dir);
  CHECK(r.exitCode == 3);
  CHECK_THAT(r.err, Contains("another swarmsim run"));
  r = runCli(tinyRun("out.h5", "--force"), dir);
  CHECK(r.exitCode == 3);
  CHECK_THAT(r.err, Contains("another swarmsim run"));
  // a file that appears while the first run works is not replaced at its end
  swarmsim_test::writeText(dir.file("out.h5"), "someone else's\n");
  kill(a.pid, SIGTERM);
  const int status = swarmsim_test::waitChild(a.pid, 30000);
  REQUIRE(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) == 3);
  CHECK_THAT(swarmsim_test::readText(a.errLog), Contains("appeared"));
  CHECK(swarmsim_test::readText(dir.file("out.h5")) == "someone else's\n");
  CHECK(fs::exists(dir.file(".out.h5.part")));  // the run's work is kept
  // a foreign file is never replaced, even by --resume --force
  const std::string again = "run " + shellQuote(kTiny) + " --frames 400 --set 'swarms[0].count=1000' -o out.h5 --quiet";
  r = runCli(again + " --resume --force", dir);
  CHECK(r.exitCode == 3);
  CHECK(swarmsim_test::readText(dir.file("out.h5")) == "someone else's\n");
  // once its owner moves it away, the kept run finishes and is put in place as the message says
  // (the kept file was closed: its frames are copied)
  fs::remove(dir.file("out.h5"));
  const auto placed = runCli(again + " --resume", dir);
  INFO("resume stderr: " << placed.err);
  CHECK(placed.exitCode == 0);
  CHECK(swarmsim::readTrajectoryInfo(dir.file("out.h5")).complete);
  CHECK_FALSE(fs::exists(dir.file(".out.h5.part")));
  CHECK_FALSE(fs::exists(dir.file(".out.h5.ckpt")));
}

TEST_CASE("D10: SIGHUP stops like SIGTERM; killed runs leave nothing unreported", "[safety]") {
  TempDir dir;
  const swarmsim_test::Child a = swarmsim_test::spawnChild(
      {kExe, "run", kTiny, "--frames", "100000", "--set", "swarms[0].count=2000", "-o", "out.h5"}, dir.path(), "a");
  REQUIRE(swarmsim_test::waitForFile(dir.file(".out.h5.ckpt"), a.pid, 30000));
  usleep(200000);
  kill(a.pid, SIGHUP);
  const int status = swarmsim_test::waitChild(a.pid, 30000);
  REQUIRE(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) == 4);
  CHECK(swarmsim::readTrajectoryInfo(dir.file("out.h5")).interrupted);
  CHECK_FALSE(fs::exists(dir.file(".out.h5.part")));

  // a temporary file of an older swarmsim whose process is gone is removed, and said so
  swarmsim_test::writeText(dir.file(".old.h5.tmp-999999999"), "junk");
  const auto r = runCli(tinyRun("old.h5"), dir);
  CHECK(r.exitCode == 0);
  CHECK_THAT(r.err, Contains(".old.h5.tmp-999999999"));
  CHECK_FALSE(fs::exists(dir.file(".old.h5.tmp-999999999")));
}
