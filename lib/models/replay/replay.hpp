#pragma once
// replay: a swarm whose agents follow recorded tracks (a CSV or HDF5 track file, read as `swarmsim evaluate`
// reads it, eval/tracks.hpp), for mixing real insects with simulated ones (FASTSWARM section 5.2.3). Agent i
// is the file's i-th individual (in id order: the order a CSV first names them, an HDF5 swarm's slots). At
// simulated time t the file is at time start + t after its first sample; an agent (its recorded position
// moved by `translate`) is
//   at its recorded position and velocity when that time falls on one of its samples (within 1e-6 of the
//   sample interval),
//   linearly interpolated between two consecutive samples of its track (positions; velocities too when the
//   file records them, else the forward difference of the two positions),
//   absent (position and velocity NaN) before its track starts, after it ends and within its gaps.
// The model carries no state from step to step: a resumed run places the agents as an uninterrupted one.
// docs/models/replay.md.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "models/model.hpp"

namespace swarmsim {

// the tracks, sample by sample: one row of positions per individual over [first, last] of its own samples
struct ReplayTracks {
  double dt = 0.0;  // seconds between samples of the file
  bool recordedVelocity = false;
  struct Track {
    std::int64_t first = 0;      // sample index (from the file's first served sample) of pos[0]
    std::vector<double> pos;     // 3 per sample from `first` to the track's last sample, m
    std::vector<double> vel;     // 3 per sample (recorded or differenced), m/s
    std::vector<char> present;   // per sample
    std::int64_t samples() const { return static_cast<std::int64_t>(present.size()); }
  };
  std::vector<Track> tracks;
  // agent i's position and velocity at file time u (in samples after the first); false: absent
  bool at(std::size_t i, double u, double p[3], double v[3]) const;
};

struct ReplayParams {
  std::string file;          // resolved against the scenario's folder
  std::string swarm;         // HDF5: which swarm (empty: the only one)
  std::string delimiter, columns;  // CSV: as `swarmsim evaluate --delimiter/--columns`
  double start = 0.0;        // s after the file's first sample at simulated time 0
  Vec3d translate = Vec3d::Zero();  // m, added to every recorded position
  std::shared_ptr<const ReplayTracks> tracks;
};

// reads the file; throws InputError naming it
ReplayTracks readReplayTracks(const std::string& file, const std::string& swarm, const std::string& delimiter,
                              const std::string& columns);
std::shared_ptr<const ModelConfig> parseReplay(JsonReader& params, const ModelContext& context);

}  // namespace swarmsim
