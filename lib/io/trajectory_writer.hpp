#pragma once
// Streams per-frame swarm state into an HDF5 trajectory file (docs/output.md).
//
// The file is written under a temporary name in the output's folder and
// renamed to the requested path by finish(); if the writer is destroyed
// without finish() (an error), the temporary file is removed. Frames go
// straight to disk through extendible, chunked datasets, so memory stays
// bounded by one frame.
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
  // creates the temporary file; throws OutputError if it exists and !force,
  // or if it cannot be created
  // statNames[i]: the per-frame statistics of swarm i (Model::statNames)
  TrajectoryWriter(const std::string& path, const Scenario& scenario, const std::vector<SwarmState>& swarms,
                   const std::vector<std::vector<std::string>>& statNames, bool force);
  TrajectoryWriter(const TrajectoryWriter&) = delete;
  TrajectoryWriter& operator=(const TrajectoryWriter&) = delete;
  ~TrajectoryWriter();

  // append one frame at simulated time `time` (seconds); stats[i] in statNames[i] order
  void writeFrame(double time, const std::vector<SwarmState>& swarms, const std::vector<std::vector<double>>& stats);
  // write closing attributes, close and rename to the requested path
  void finish(bool interrupted);

  std::int64_t framesWritten() const { return frames_; }
  const std::string& path() const { return path_; }

 private:
  struct SwarmDatasets {
    H5Handle group, position, velocity;
    std::vector<H5Handle> stats;  // /swarms/<name>/stats/<stat>, (frames) float64
  };
  void appendVec3(hid_t dataset, const SwarmState& s, bool velocity);
  void appendScalar(hid_t dataset, double value, const char* what);

  std::string path_, tmpPath_;
  H5Handle file_, time_;
  std::vector<SwarmDatasets> swarms_;
  std::vector<float> frameBuffer_;  // one swarm-frame, interleaved xyz
  std::int64_t frames_ = 0;
  bool finished_ = false;
};

}  // namespace swarmsim
