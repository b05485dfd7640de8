#pragma once
// Streams per-frame swarm state into an HDF5 trajectory file (docs/output.md).
//
// The datasets grow in blocks of frames. Each block is allocated when the
// first of its frames is written, and the file is then closed and opened
// again, so its metadata is on disk and never changes while the block's
// frames are written (without compression, writing a frame writes raw data
// only). Hence a file cut off by a killed process is intact up to the block's
// start and every frame written since, a reopened file continues exactly as
// the same process would have (the same allocations from the same on-disk
// state), and a resumed run ends in a file byte-identical to one that never
// stopped. The block boundaries depend only on the frame count and the frame
// size. A frame's position and velocity rows go to the file (and are read back)
// in pieces of at most kMaxBlockRows rows, so the writer's memory is bounded
// whatever the number of agents.
//
// The writer writes the file it is given (OutputTarget decides names and
// places the finished file); it never removes anything.
#include <cstdint>
#include <string>
#include <vector>

#include "core/swarm_state.hpp"
#include "io/hdf5_handle.hpp"
#include "io/scenario.hpp"

namespace swarmsim {

inline constexpr const char* kFormatName = "swarmsim-trajectory";
inline constexpr int kFormatVersion = 1;

class TrajectoryWriter {
 public:
  enum class Mode {
    kCreate,  // a new file (it must not exist)
    kReopen,  // a partial file made by kCreate for the same scenario: frames [0, framesKept) are kept
  };
  // statNames[i]: the per-frame statistics of swarm i (Model::statNames);
  // facts[i]: its model's facts (Model::facts, JSON text; empty: none).
  // Throws OutputError when the file cannot be created or written, InputError
  // when a file to reopen is not the partial output of this scenario.
  TrajectoryWriter(const std::string& file, const Scenario& scenario, const std::vector<SwarmState>& swarms,
                   const std::vector<std::vector<std::string>>& statNames, Mode mode, std::int64_t framesKept = 0,
                   const std::vector<std::string>& facts = {});
  TrajectoryWriter(const TrajectoryWriter&) = delete;
  TrajectoryWriter& operator=(const TrajectoryWriter&) = delete;
  ~TrajectoryWriter();  // closes the file if close() was not called (no exception)

  // the most rows of a position or velocity dataset transferred at once (12 MiB)
  static constexpr std::size_t kMaxBlockRows = std::size_t{1} << 20;
  // Transfer at most `rows` rows at once (the file's bytes and the data hash do
  // not depend on it). Rounded down to whole chunks when a chunk is smaller,
  // so that each compressed chunk is written once, complete; fewer rows than a
  // chunk only for tests. The constructor sets kMaxBlockRows.
  void setMaxBlockRows(std::size_t rows);

  // whether a killed run's partial file can be reopened in place (kReopen): not
  // with compression, where writing a frame allocates space in the file
  static bool canReopen(const Scenario& scenario) { return scenario.output.compression == 0; }

  // append one frame at simulated time `time` (seconds); stats[i] in statNames[i] order
  void writeFrame(double time, const std::vector<SwarmState>& swarms, const std::vector<std::vector<double>>& stats);
  // append frames [0, frames) of another trajectory file of the same scenario (a resume from an interrupted output)
  void copyFramesFrom(const std::string& source, std::int64_t frames);
  // the data hash of this file's frames [0, frames), read back from disk (to check a reopened file)
  std::uint64_t hashStoredFrames(std::int64_t frames);
  // everything written so far is on disk (HDF5 flush, then fdatasync)
  void flush();
  // rename the file being written (it stays open); throws OutputError
  void moveTo(const std::string& path);
  // a hash of every frame's data written so far (chained frame by frame)
  std::uint64_t dataHash() const { return hash_; }
  // after a reopen checked with hashStoredFrames: continue the chain from there
  void setDataHash(std::uint64_t h) { hash_ = h; }
  // closing attributes, then close. An incomplete file's datasets are cut to
  // the frames written (it stays a valid file for every reader).
  void close(bool complete);

  std::int64_t framesWritten() const { return frames_; }
  const std::string& file() const { return file_; }

 private:
  // one dataset's share of a frame: rows x 3 floats, or one double (rows == 0, a 1-D dataset)
  struct Slot {
    hid_t dataset = H5I_INVALID_HID;
    std::size_t rows = 0;
    bool vec = false;
    std::size_t swarm = 0;                                // a vec slot: its swarm
    bool velocity = false;                                // a vec slot: velocity (else position)
    std::size_t blockRows = 1;                            // rows per transfer (setMaxBlockRows)
    std::size_t units() const { return vec ? rows : 1; }  // rows, or the one value
    std::size_t unitBytes() const { return vec ? 3 * sizeof(float) : sizeof(double); }
    std::size_t bytes() const { return units() * unitBytes(); }
  };
  void create(const Scenario& scenario, const std::vector<SwarmState>& swarms,
              const std::vector<std::vector<std::string>>& statNames, const std::vector<std::string>& facts);
  void open(bool checkScenario);  // opens the file and every slot's dataset; sets extent_
  void closeFile();               // closes every handle (no exception)
  void grow();                    // the next block of frames, then close and open again
  std::int64_t nextBoundary(std::int64_t b) const;
  // rows [r0, r1) of a slot's frame (a 1-D dataset: its value, r0 = 0, r1 = 1)
  void transfer(std::size_t slot, hid_t dataset, std::int64_t frame, std::size_t r0, std::size_t r1, void* data,
                bool write, const std::string& file);
  // slot k's frame block by block: visit(r0, r1, data) for each block of rows [r0, r1), `data` the buffer the
  // block goes through; returns `h` chained over the bytes the buffer then holds (the slot's frame)
  template <typename Visit>
  std::uint64_t forEachBlock(std::size_t k, std::uint64_t h, const Visit& visit);
  // frame frames_ of every slot, fill(k, r0, r1, data) giving each block of slot k; hash, ++frames_
  template <typename Fill>
  void appendFrame(const Fill& fill);

  std::string file_;
  std::string scenarioJson_;
  std::int64_t capacity_ = 0;  // the scenario's frames
  std::int64_t extent_ = 0;    // frames the datasets have now
  H5Handle fileId_;
  std::vector<H5Handle> datasets_;               // one per slot
  std::vector<Slot> slots_;                      // in hashing order: per swarm position, velocity, stats; then time
  std::vector<std::string> slotNames_;           // dataset paths
  std::vector<float> block_;                     // one block of rows of a position or velocity slot
  std::vector<double> values_;                   // per slot: a 1-D dataset's value in this frame
  std::vector<std::size_t> swarmFirstSlot_;      // per swarm: its first slot
  std::vector<int> swarmHasPos_, swarmHasVel_;
  std::int64_t frames_ = 0;
  std::uint64_t hash_ = 0;
  bool closed_ = false;
};

}  // namespace swarmsim
