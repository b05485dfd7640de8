#pragma once
// Where a run's output goes, and the rules for getting it there safely
// (docs/output.md#output-path-rules):
//   - the final path is only ever created, or replaced with --force when it is a
//     regular file that swarmsim wrote (or an empty file); anything else (a
//     directory, a device, a FIFO, a socket, a foreign file) is refused;
//   - a symbolic link is followed: the file it points to is the one written;
//   - one run at a time per output: a lock file beside it, held for the run;
//   - the output appears atomically: the run writes a partial file beside it
//     and renames it into place when done, and without --force that rename
//     never replaces a file that appeared meanwhile.
// Files beside the output NAME (all in the same folder, names fixed so that
// nothing accumulates): .NAME.part (the HDF5 file being written),
// .NAME.ckpt (the checkpoint a resume starts from), .NAME.lock.
#include <sys/stat.h>

#include <string>

namespace swarmsim {

class OutputTarget {
 public:
  // Resolve `path` (following symbolic links), check it against the rules above
  // and take the lock. Throws OutputError (exit 3) when the path is empty, not
  // a regular file, exists without `force` (unless `resume`), or another run
  // holds the lock.
  OutputTarget(const std::string& path, bool force, bool resume);
  OutputTarget(const OutputTarget&) = delete;
  OutputTarget& operator=(const OutputTarget&) = delete;
  ~OutputTarget();  // releases the lock (and removes the lock file)

  const std::string& requested() const { return requested_; }  // as given
  const std::string& path() const { return path_; }            // resolved final path
  const std::string& partPath() const { return part_; }
  const std::string& checkpointPath() const { return ckpt_; }
  bool finalExists() const;
  bool partExists() const;
  bool checkpointExists() const;

  // Rename the partial file to the final path. Without `force` this never
  // replaces a file that is there now (atomic: RENAME_NOREPLACE, or a hard
  // link); with `force` it replaces only a regular file. Throws OutputError.
  void place(bool force) const;
  // remove the checkpoint (the output is complete) / the partial file; quiet
  void removeCheckpoint() const;
  void removePart() const;

 private:
  void checkFinal(bool force, bool resume) const;
  std::string requested_, path_, dir_, part_, ckpt_, lock_;
  int lockFd_ = -1;
};

// the path a run writes for `requested`: symbolic links of the last component followed (a dangling
// link's target); throws OutputError for a loop of links
std::string followOutputLinks(const std::string& requested);
// "a directory", "a character device", "a FIFO", ... for messages
std::string fileKind(const struct stat& st);
// a message when `requested` exists and leads (links followed by the kernel) to something that is not a
// regular file, else ""
std::string refuseNonRegular(const std::string& requested);

// true when `path` is a regular file that is a swarmsim trajectory (HDF5 with
// the format attribute), a swarmsim reference (`swarmsim reference build`), or
// is empty
bool isOwnOutputFile(const std::string& path);

}  // namespace swarmsim
