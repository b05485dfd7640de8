#pragma once
// The bytes of the mesh files (OBJ) a scenario reads, by absolute path.
//
// While a scenario is parsed every mesh file goes through one InputFiles: it
// records what was read, so that the writer can store those files in the
// output (docs/output.md#scene-and-inputs), and it hands back copies embedded
// beforehand instead of reading the disk, so that `swarmsim run --from OUT.h5`
// re-runs a stored scenario from the meshes stored with it, wherever it runs.
// Not thread-safe: scenarios are parsed by one thread.
#include <functional>
#include <map>
#include <memory>
#include <string>

namespace swarmsim {

class InputFiles {
 public:
  using Bytes = std::shared_ptr<const std::string>;
  // the bytes of `path`: the embedded copy when there is one, else readFile(); recorded either way
  Bytes read(const std::string& path, const std::function<std::string()>& readFile);
  // make read(path) return these bytes instead of reading the file
  void embed(const std::string& path, std::string bytes);
  bool embedded(const std::string& path) const { return embedded_.count(path) > 0; }
  // every file read so far, by path (sorted)
  const std::map<std::string, Bytes>& used() const { return used_; }

 private:
  std::map<std::string, Bytes> embedded_, used_;
};

}  // namespace swarmsim
