#include "io/output_target.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <system_error>

#include "core/error.hpp"
#include "io/hdf5_util.hpp"
#include "io/trajectory_reader.hpp"

namespace swarmsim {

namespace fs = std::filesystem;

std::string fileKind(const struct stat& st) {
  if (S_ISDIR(st.st_mode)) return "a directory";
  if (S_ISCHR(st.st_mode)) return "a character device";
  if (S_ISBLK(st.st_mode)) return "a block device";
  if (S_ISFIFO(st.st_mode)) return "a FIFO";
  if (S_ISSOCK(st.st_mode)) return "a socket";
  if (S_ISLNK(st.st_mode)) return "a symbolic link";
  return "not a regular file";
}

std::string followOutputLinks(const std::string& requested) {
  fs::path p(requested);
  for (int hops = 0; hops < 40; ++hops) {
    struct stat st {};
    if (lstat(p.c_str(), &st) != 0 || !S_ISLNK(st.st_mode)) return p.string();
    std::error_code ec;
    const fs::path target = fs::read_symlink(p, ec);
    if (ec) throw OutputError(requested + ": cannot read symbolic link " + p.string() + ": " + ec.message());
    p = target.is_absolute() ? target : p.parent_path() / target;
    p = p.lexically_normal();
  }
  throw OutputError(requested + ": too many levels of symbolic links");
}

std::string refuseNonRegular(const std::string& requested) {
  struct stat st {};
  if (stat(requested.c_str(), &st) != 0 || S_ISREG(st.st_mode)) return "";
  if (S_ISDIR(st.st_mode)) return requested + ": is a directory (expected an output file path)";
  return requested + ": is " + fileKind(st) + "; swarmsim writes only regular files and never replaces anything else";
}

namespace {

std::string errnoText() { return std::strerror(errno); }

}  // namespace

bool isOwnOutputFile(const std::string& path) {
  struct stat st {};
  if (stat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) return false;
  if (st.st_size == 0) return true;
  try {
    readTrajectoryInfo(path);  // throws unless it is a readable swarmsim trajectory
    return true;
  } catch (const std::exception&) {
  }
  // or another file swarmsim writes: a reference (fastswarm/reference.hpp)
  return h5::fileFormat(path) == "swarmsim-reference";
}

OutputTarget::OutputTarget(const std::string& path, bool force, bool resume) : requested_(path) {
  if (path.empty()) throw OutputError("output path is empty (expected a file path, e.g. -o out/run.h5)");
  // what the path leads to, links followed by the kernel (also /dev/stdout -> /proc/self/fd/1 -> a pipe)
  if (const std::string why = refuseNonRegular(path); !why.empty()) throw OutputError(why);
  const fs::path resolved(followOutputLinks(path));
  if (resolved.filename().empty() || resolved.filename() == "." || resolved.filename() == "..") {
    throw OutputError(path + ": expected an output file path, not a folder");
  }
  path_ = resolved.string();
  const fs::path dir = resolved.has_parent_path() ? resolved.parent_path() : fs::path(".");
  dir_ = dir.string();
  const std::string name = resolved.filename().string();
  part_ = (dir / ("." + name + ".part")).string();
  ckpt_ = (dir / ("." + name + ".ckpt")).string();
  lock_ = (dir / ("." + name + ".lock")).string();

  checkFinal(force, resume);
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw OutputError(path + ": cannot create folder " + dir.string() + ": " + ec.message());

  // the lock: one run per output. A lock file that was removed and re-created
  // by another run between our open and our flock is retried.
  for (int attempt = 0; attempt < 100; ++attempt) {
    const int fd = ::open(lock_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC | O_NOFOLLOW, 0644);
    if (fd < 0) throw OutputError(path + ": cannot create lock file " + lock_ + ": " + errnoText());
    struct stat fst {};
    if (fstat(fd, &fst) != 0 || !S_ISREG(fst.st_mode)) {
      ::close(fd);
      throw OutputError(path + ": lock file " + lock_ + " is not a regular file");
    }
    if (flock(fd, LOCK_EX | LOCK_NB) != 0) {
      const int err = errno;
      char buf[32] = {0};
      const ssize_t got = pread(fd, buf, sizeof buf - 1, 0);
      ::close(fd);
      if (err == EWOULDBLOCK) {
        std::string pid = got > 0 ? std::string(buf, static_cast<std::size_t>(got)) : "?";
        while (!pid.empty() && (pid.back() == '\n' || pid.back() == ' ')) pid.pop_back();
        throw OutputError(path + ": another swarmsim run (pid " + pid + ") is writing this output (lock " + lock_ + ")");
      }
      throw OutputError(path + ": cannot lock " + lock_ + ": " + std::strerror(err));
    }
    struct stat pst {};
    if (stat(lock_.c_str(), &pst) == 0 && pst.st_ino == fst.st_ino && pst.st_dev == fst.st_dev) {
      lockFd_ = fd;
      const std::string pid = std::to_string(getpid()) + "\n";
      if (ftruncate(fd, 0) == 0) {
        [[maybe_unused]] const ssize_t w = pwrite(fd, pid.data(), pid.size(), 0);
      }
      break;
    }
    ::close(fd);  // the file we locked was unlinked meanwhile: try again
  }
  if (lockFd_ < 0) throw OutputError(path + ": cannot take the lock " + lock_);
  // the checks again, now that no other run can change the files
  checkFinal(force, resume);
  for (const std::string* p : {&part_, &ckpt_}) {
    struct stat st {};
    if (lstat(p->c_str(), &st) == 0 && !S_ISREG(st.st_mode)) {
      throw OutputError(path + ": " + *p + " is " + fileKind(st) + "; swarmsim keeps its own partial files there (remove it)");
    }
  }
}

OutputTarget::~OutputTarget() {
  if (lockFd_ >= 0) {
    ::unlink(lock_.c_str());  // while still holding it: a waiting run re-checks the inode
    ::close(lockFd_);
  }
}

void OutputTarget::checkFinal(bool force, bool resume) const {
  struct stat st {};
  if (lstat(path_.c_str(), &st) != 0) {
    if (errno == ENOENT) return;
    throw OutputError(requested_ + ": cannot check the output path: " + errnoText());
  }
  const std::string shown = path_ == requested_ ? requested_ : requested_ + " (-> " + path_ + ")";
  if (S_ISDIR(st.st_mode)) throw OutputError(shown + ": is a directory (expected an output file path)");
  if (!S_ISREG(st.st_mode)) {
    throw OutputError(shown + ": is " + fileKind(st) + "; swarmsim writes only regular files and never replaces anything else");
  }
  if (resume) return;  // the resume logic decides what an existing file means
  if (!force) throw OutputError(shown + ": output file exists (use --force to overwrite)");
  if (!isOwnOutputFile(path_)) {
    throw OutputError(shown + ": is not a swarmsim output file; not replaced, even with --force");
  }
}

bool OutputTarget::finalExists() const {
  struct stat st {};
  return lstat(path_.c_str(), &st) == 0;
}
bool OutputTarget::partExists() const {
  struct stat st {};
  return lstat(part_.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}
bool OutputTarget::checkpointExists() const {
  struct stat st {};
  return lstat(ckpt_.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

void OutputTarget::place(bool force) const {
  const auto appeared = [&] {
    return OutputError(path_ + ": a file appeared there while this run was writing; not replaced (use --force). "
                       "This run's output is kept as " + part_ + ": place it with --resume --force");
  };
  if (!force) {
    if (renameat2(AT_FDCWD, part_.c_str(), AT_FDCWD, path_.c_str(), RENAME_NOREPLACE) == 0) return;
    if (errno == EEXIST) throw appeared();
    if (errno != EINVAL && errno != ENOSYS && errno != ENOTSUP) {
      throw OutputError(path_ + ": cannot rename " + part_ + " to the output path: " + errnoText());
    }
    // the file system has no RENAME_NOREPLACE: a hard link is just as atomic
    if (::link(part_.c_str(), path_.c_str()) == 0) {
      ::unlink(part_.c_str());
      return;
    }
    if (errno == EEXIST) throw appeared();
    // no hard links either (some network and FUSE file systems): check, then rename
    struct stat st {};
    if (lstat(path_.c_str(), &st) == 0) throw appeared();
  } else {
    checkFinal(true, false);
  }
  if (std::rename(part_.c_str(), path_.c_str()) != 0) {
    throw OutputError(path_ + ": cannot rename " + part_ + " to the output path: " + errnoText());
  }
}

void OutputTarget::removeCheckpoint() const { ::unlink(ckpt_.c_str()); }
void OutputTarget::removePart() const { ::unlink(part_.c_str()); }

}  // namespace swarmsim
