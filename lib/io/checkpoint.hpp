#pragma once
// Checkpoint files: everything a resumed run needs to continue bit-identically
// (docs/output.md#checkpoints-and-resume). Written atomically (a new file,
// fsync, rename, fsync of the folder), checked on reading (magic, version,
// length, checksum), so a torn or foreign file is refused, never misread.
#include <cstdint>
#include <string>
#include <vector>

#include "core/swarm_state.hpp"

namespace swarmsim {

struct Checkpoint {
  std::string scenario;         // the resolved scenario JSON the run was started with
  std::uint64_t step = 0;       // steps taken
  std::int64_t frames = 0;      // frames written to the output before this checkpoint
  std::uint64_t dataHash = 0;   // TrajectoryWriter::dataHash() after those frames
  std::vector<SwarmState> swarms;        // every swarm's state (slot order included)
  std::vector<std::string> modelStates;  // Model::saveState of each swarm's model
};

// write `c` to `path` atomically; throws OutputError
void writeCheckpoint(const std::string& path, const Checkpoint& c);
// read and check `path`; throws InputError naming the file and the defect
Checkpoint readCheckpoint(const std::string& path);

// a 64-bit hash of bytes, chained from `h` (word-wise, fast; not cryptographic)
std::uint64_t hashBytes(const void* data, std::size_t size, std::uint64_t h);

}  // namespace swarmsim
