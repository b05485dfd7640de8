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

// what a checkpoint holds besides the swarms' states
struct CheckpointInfo {
  std::string scenario;         // the resolved scenario JSON the run was started with
  std::uint64_t step = 0;       // steps taken
  std::int64_t frames = 0;      // frames written to the output before this checkpoint
  std::uint64_t dataHash = 0;   // TrajectoryWriter::dataHash() after those frames
  std::vector<std::string> modelStates;  // Model::saveState of each swarm's model
};

// a checkpoint as read: every swarm's state (slot order included)
struct Checkpoint : CheckpointInfo {
  std::vector<SwarmState> swarms;
};

// a checkpoint to write: the swarms are referenced, not held. The file is streamed from the live states, so a
// checkpoint needs no copy of them (they are most of a large run's memory).
struct CheckpointView : CheckpointInfo {
  std::vector<const SwarmState*> swarms;
};

// write `c` to `path` atomically, through a buffer of a few MiB; throws OutputError
void writeCheckpoint(const std::string& path, const CheckpointView& c);
// read and check `path`; throws InputError naming the file and the defect
Checkpoint readCheckpoint(const std::string& path);

// a 64-bit hash of bytes, chained from `h` (word-wise, fast; not cryptographic)
std::uint64_t hashBytes(const void* data, std::size_t size, std::uint64_t h);

// hashBytes over bytes that come in pieces: update() with the `size` bytes
// split in any way, then finish() is hashBytes(all of them, size, h). The
// length enters the starting state, so it is given first.
class ByteHasher {
 public:
  ByteHasher(std::uint64_t h, std::size_t size);
  void update(const void* data, std::size_t n);
  // throws std::logic_error when the pieces did not add up to `size`
  std::uint64_t finish() const;

 private:
  std::uint64_t a_, b_;
  std::size_t size_, seen_ = 0;
  unsigned char part_[16] = {};  // a word begun by one piece and not yet completed
  std::size_t partSize_ = 0;
};

}  // namespace swarmsim
