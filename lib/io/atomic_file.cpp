#include "io/atomic_file.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>

#include "core/error.hpp"
#include "io/output_target.hpp"

namespace swarmsim {

namespace fs = std::filesystem;

std::string refusalToWrite(const std::string& path, bool force, const std::function<bool(const std::string&)>& isOwn) {
  if (std::string why = refuseNonRegular(path); !why.empty()) return why;
  struct stat st {};
  if (lstat(path.c_str(), &st) != 0) return "";  // nothing there (or a dangling link: its target is created)
  if (!S_ISREG(st.st_mode)) {
    return path + ": is " + fileKind(st) + "; swarmsim writes only regular files and never replaces anything else";
  }
  if (!force) return path + ": file exists (use --force to overwrite)";
  if (st.st_size > 0 && !isOwn(path)) return path + ": was not written by swarmsim; not replaced, even with --force";
  return "";
}

AtomicFile::AtomicFile(const std::string& path, bool force, const std::function<bool(const std::string&)>& isOwn)
    : requested_(path), force_(force), isOwn_(isOwn) {
  if (path.empty()) throw OutputError("output path is empty (expected a file path)");
  if (std::string why = refuseNonRegular(path); !why.empty()) throw OutputError(why);
  path_ = followOutputLinks(path);
  if (std::string why = refusalToWrite(path_, force, isOwn); !why.empty()) throw OutputError(why);
  const fs::path p(path_);
  const fs::path dir = p.has_parent_path() ? p.parent_path() : fs::path(".");
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw OutputError(path + ": cannot create folder " + dir.string() + ": " + ec.message());
  part_ = (dir / ("." + p.filename().string() + ".part")).string();
  struct stat st {};
  if (lstat(part_.c_str(), &st) == 0 && !S_ISREG(st.st_mode)) {
    throw OutputError(path + ": " + part_ + " is " + fileKind(st) + "; swarmsim keeps its partial files there (remove it)");
  }
  file_ = std::fopen(part_.c_str(), "wb");
  if (!file_) throw OutputError(part_ + ": cannot create file: " + std::strerror(errno));
}

AtomicFile::~AtomicFile() {
  if (file_) std::fclose(file_);
  if (!committed_ && !part_.empty()) ::unlink(part_.c_str());
}

void AtomicFile::write(const void* data, std::size_t n) {
  if (n > 0 && std::fwrite(data, 1, n, file_) != n) {
    throw OutputError(part_ + ": cannot write: " + std::strerror(errno) + " (disk full?)");
  }
}

void AtomicFile::commit() {
  const bool ok = std::fflush(file_) == 0 && fsync(fileno(file_)) == 0;
  const int err = errno;
  const bool closed = std::fclose(file_) == 0;
  file_ = nullptr;
  if (!ok || !closed) throw OutputError(part_ + ": cannot write: " + std::strerror(err) + " (disk full?)");
  // the path again: something may have appeared there meanwhile
  if (std::string why = refusalToWrite(path_, force_, isOwn_); !why.empty()) throw OutputError(why);
  if (std::rename(part_.c_str(), path_.c_str()) != 0) {
    throw OutputError(path_ + ": cannot rename " + part_ + " to it: " + std::strerror(errno));
  }
  committed_ = true;
}

}  // namespace swarmsim
