#pragma once
// Helpers shared by the swarmsim tests: a unique temporary folder per test,
// file helpers and a way to run the built swarmsim binary.
#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <system_error>
#include <vector>

#include "core/error.hpp"
#include "core/parallel.hpp"

namespace swarmsim_test {

namespace fs = std::filesystem;

// A fresh, uniquely named folder under the system temp directory, removed
// (with everything in it) when the object goes out of scope.
class TempDir {
 public:
  TempDir() {
    std::string tmpl = (fs::temp_directory_path() / "swarmsim-test-XXXXXX").string();
    std::vector<char> buf(tmpl.begin(), tmpl.end());
    buf.push_back('\0');
    if (!mkdtemp(buf.data())) throw std::runtime_error("mkdtemp failed for " + tmpl);
    path_ = fs::path(buf.data());
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  const fs::path& path() const { return path_; }
  std::string file(const std::string& name) const { return (path_ / name).string(); }
  // names of the entries in the folder (not recursive), sorted
  std::vector<std::string> entries() const {
    std::vector<std::string> out;
    for (const auto& e : fs::directory_iterator(path_)) out.push_back(e.path().filename().string());
    std::sort(out.begin(), out.end());
    return out;
  }

 private:
  fs::path path_;
};

// the message of the InputError that f throws, or "(no InputError)"
inline std::string inputErrorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const swarmsim::InputError& e) {
    return e.what();
  }
  return "(no InputError)";
}

inline void writeText(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  if (!out) throw std::runtime_error("cannot write " + path);
  out << text;
}

inline std::string readText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// single-quote for /bin/sh
inline std::string shellQuote(const std::string& s) {
  std::string out = "'";
  for (char c : s) {
    if (c == '\'') {
      out += "'\\''";
    } else {
      out += c;
    }
  }
  return out + "'";
}

struct CommandResult {
  int exitCode = -1;  // exit status, or -1 if the command did not exit normally
  std::string out, err;
};

// Run a shell command line with stdout and stderr captured into files of `dir`.
inline CommandResult runCommand(const std::string& commandLine, const fs::path& dir) {
  const std::string outFile = (dir / "cmd.stdout").string(), errFile = (dir / "cmd.stderr").string();
  const std::string full = commandLine + " >" + shellQuote(outFile) + " 2>" + shellQuote(errFile) + " </dev/null";
  const int status = std::system(full.c_str());
  CommandResult r;
  if (status != -1 && WIFEXITED(status)) r.exitCode = WEXITSTATUS(status);
  r.out = readText(outFile);
  r.err = readText(errFile);
  std::error_code ec;
  fs::remove(outFile, ec);
  fs::remove(errFile, ec);
  return r;
}

// the built swarmsim binary and the source tree (compile definitions of the test target)
inline const std::string kSwarmsimExe = SWARMSIM_EXE;
inline const std::string kSourceTree = SWARMSIM_SOURCE_DIR;

// run `swarmsim ARGS` (ARGS already shell-quoted where needed) in `dir`
inline CommandResult runSwarmsim(const std::string& args, const fs::path& dir) {
  return runCommand("cd " + shellQuote(dir.string()) + " && " + shellQuote(kSwarmsimExe) + " " + args, dir);
}

// A child process running `args` (args[0] is the program) in `dir`, stdout and
// stderr to files there; for tests that signal a run while it works.
struct Child {
  pid_t pid = -1;
  std::string outLog, errLog;
};

inline Child spawnChild(const std::vector<std::string>& args, const fs::path& dir, const std::string& tag = "child") {
  Child c;
  c.outLog = (dir / (tag + ".stdout")).string();
  c.errLog = (dir / (tag + ".stderr")).string();
  c.pid = fork();
  if (c.pid < 0) throw std::runtime_error("fork failed");
  if (c.pid == 0) {
    const int o = open(c.outLog.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int e = open(c.errLog.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int in = open("/dev/null", O_RDONLY);
    if (o < 0 || e < 0 || in < 0 || dup2(o, 1) < 0 || dup2(e, 2) < 0 || dup2(in, 0) < 0 || chdir(dir.c_str()) != 0) {
      _exit(127);
    }
    std::vector<char*> argv;
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    execv(argv[0], argv.data());
    _exit(127);
  }
  return c;
}

// wait at most `ms` milliseconds for the child; its wait status, or -1 if it
// is still running (then it is killed and reaped when `killLate`)
inline int waitChild(pid_t pid, long ms, bool killLate = true) {
  for (long waited = 0;; waited += 5) {
    int status = 0;
    if (waitpid(pid, &status, WNOHANG) == pid) return status;
    if (waited >= ms) break;
    usleep(5000);
  }
  if (killLate) {
    kill(pid, SIGKILL);
    int status = 0;
    waitpid(pid, &status, 0);
  }
  return -1;
}

// wait until `path` exists (at most `ms`), false if the child ended first or time ran out
inline bool waitForFile(const std::string& path, pid_t pid, long ms) {
  for (long waited = 0; waited < ms; waited += 5) {
    if (fs::exists(path)) return true;
    siginfo_t info{};
    if (waitid(P_PID, static_cast<id_t>(pid), &info, WEXITED | WNOHANG | WNOWAIT) == 0 && info.si_pid == pid) {
      return false;  // ended (still to be reaped by waitChild)
    }
    usleep(5000);
  }
  return false;
}

// an environment variable set to `value` (or unset, for nullptr) for the guard's lifetime, then restored
struct EnvGuard {
  std::string name;
  bool was;
  std::string saved;
  EnvGuard(const char* variable, const char* value)
      : name(variable), was(std::getenv(variable) != nullptr), saved(was ? std::getenv(variable) : "") {
    value ? setenv(variable, value, 1) : unsetenv(variable);
  }
  ~EnvGuard() { was ? setenv(name.c_str(), saved.c_str(), 1) : unsetenv(name.c_str()); }
  EnvGuard(const EnvGuard&) = delete;
  EnvGuard& operator=(const EnvGuard&) = delete;
};

// restores the thread count on scope exit
struct ThreadCountGuard {
  int saved = swarmsim::threadCount();
  ~ThreadCountGuard() { swarmsim::setThreadCount(saved); }
};

}  // namespace swarmsim_test
