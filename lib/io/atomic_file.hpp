#pragma once
// A file that appears atomically (docs/tools.md#export): written as .NAME.part
// beside its path and renamed into place by commit(); removed if never
// committed. The output-path rules of docs/output.md#output-path-rules apply:
// a symbolic link is followed; an existing path that is not a regular file (a
// directory, device, FIFO, socket) is never replaced; an existing regular file
// only with `force`, and only if `isOwn` says swarmsim wrote it (or it is empty).
#include <cstdio>
#include <functional>
#include <string>

namespace swarmsim {

class AtomicFile {
 public:
  // throws OutputError (exit 3) when the path may not be written
  AtomicFile(const std::string& path, bool force, const std::function<bool(const std::string&)>& isOwn);
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;
  ~AtomicFile();  // an uncommitted file is removed

  std::FILE* stream() const { return file_; }
  const std::string& path() const { return path_; }  // the final path (links followed)
  // write `n` bytes; throws OutputError (disk full, ...)
  void write(const void* data, std::size_t n);
  // flush, close and rename into place; throws OutputError
  void commit();

 private:
  std::string requested_, path_, part_;
  bool force_ = false;
  std::FILE* file_ = nullptr;
  bool committed_ = false;
  std::function<bool(const std::string&)> isOwn_;
};

// Why `path` (links followed) may not be written, or "" when it may: it does not exist, or it is a regular
// file and `force` is set and isOwn(path) or it is empty
std::string refusalToWrite(const std::string& path, bool force, const std::function<bool(const std::string&)>& isOwn);

}  // namespace swarmsim
