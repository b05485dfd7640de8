#pragma once
// FASTSWARM's reference data (Xiang et al., sections 3-4): the samples d_v = [v, a] of real insect tracks,
// forward-differenced, filtered, sorted by speed and cut into speed groups for the reduced search of
// section 5.2.1; stored in HDF5 with where they came from (docs/models/fastswarm.md#the-reference).
//
// From each track source (the CSV and HDF5 inputs of `swarmsim evaluate`, eval/tracks.hpp: same column
// detection, same time grid), forward differences between consecutive samples of one individual on the
// time grid (never across a missing sample):
//   recorded velocities (the source has vx, vy, vz; the default then): samples k, k+1:
//     v = v[k],   a = (v[k+1] - v[k]) / dt
//   positions (no velocity columns, or --velocity positions): samples k, k+1, k+2:
//     v = (p[k+1] - p[k]) / dt,   a = (p[k+2] - 2 p[k+1] + p[k]) / dt^2   (= (v[k+1] - v[k]) / dt)
// Outliers: a sample is dropped when |v| or |a| is above the Tukey fence Q3 + fence * IQR of all samples
// (quartiles: the sorted values at floor(q (n - 1)); fence 0: no fence), or above an explicit bound.
// The kept samples are sorted by |v| (stably: ties stay in source order) and cut into groups of
// group_size consecutive samples (the last group takes the remainder, at most 2 group_size - 1).
#include <cstdint>
#include <iosfwd>
#include <string>
#include <vector>

#include "eval/tracks.hpp"

namespace swarmsim::fastswarm {

struct ReferenceSource {
  std::string name;    // the file's name (without its folder)
  std::string path;    // as given on the command line
  std::string sha256;  // of the file's bytes, lowercase hex
  std::string kind;    // "csv" or "hdf5"
  std::string velocity;  // "recorded" or "positions": where v came from
  double dt = 0.0;     // s
  std::int64_t individuals = 0;
  std::int64_t shortTracks = 0;  // individuals without two (three) consecutive samples anywhere
  std::int64_t samples = 0;      // differenced samples, before the filter
  std::int64_t dropped = 0;      // of them, removed by the filter
};

struct Reference {
  static constexpr const char* kFormatName = "swarmsim-reference";
  static constexpr std::int64_t kFormatVersion = 2;  // 2: /samples/next (version 1 files are read without it)

  std::int64_t formatVersion = kFormatVersion;  // of the file it was read from
  double dt = 0.0;                 // s, the sources' common time step
  std::vector<double> v, a;        // 3 per sample (m/s, m/s^2), samples ascending in |v|
  std::vector<double> speed;       // |v| per sample
  // per sample, the sample that followed it in its track (the same individual one time step later, if that
  // gave a sample and the filter kept it), else -1: the real motion, step by step (fastswarm's `successors`)
  std::vector<std::int64_t> next;
  std::int64_t groupSize = 0;      // samples per speed group (the last may hold more)
  std::vector<std::int64_t> groupStart;  // group g is samples [groupStart[g], groupStart[g + 1])
  std::vector<double> groupFloor;        // speed of each group's first sample (indexGroups; not stored in files)
  // indexGroups' look-up of groupOfSpeed: kGroupBins equal bins of speed from the first group's floor to the last's
  static constexpr std::size_t kGroupBins = 1024;
  std::vector<std::uint32_t> groupBin;  // per bin, the group of its lower edge
  double binScale = 0.0;                // bins per m/s
  // the filter as applied
  double fence = 0.0;              // Tukey fence factor (0: none)
  double maxSpeed = 0.0;           // explicit bounds (0: none), m/s and m/s^2
  double maxAccel = 0.0;
  double speedLimit = 0.0;         // the bounds in force: min of fence and explicit bound (inf: none)
  double accelLimit = 0.0;
  std::vector<ReferenceSource> sources;
  std::string swarmsimVersion;     // of the build that wrote it

  std::size_t size() const { return speed.size(); }
  std::size_t groups() const { return groupStart.empty() ? 0 : groupStart.size() - 1; }
  // the group whose speed range holds s (the nearest one outside the data's range)
  std::size_t groupOfSpeed(double s) const;
  // fills groupFloor and groupBin from speed and groupStart (buildReference and readReference do; without them,
  // groupOfSpeed searches the same speeds through groupStart)
  void indexGroups();
};

enum class VelocitySource { Auto, Recorded, Positions };

struct ReferenceBuildOptions {
  std::vector<std::string> tracks;  // track files (CSV or swarmsim HDF5)
  eval::SourceOptions source;       // --swarm, --frames, --delimiter, --columns as for evaluate
  double fence = 3.0;
  double maxSpeed = 0.0;
  double maxAccel = 0.0;
  std::int64_t groupSize = 100;
  VelocitySource velocity = VelocitySource::Auto;  // Auto: recorded when the source has velocities
};

// throws InputError (exit 2): unreadable or malformed files (as evaluate), sources with different time
// steps, a source in which no individual has three consecutive samples, nothing left after the filter
Reference buildReference(const ReferenceBuildOptions& options);

// writes atomically (io/output_target.hpp: a partial file renamed into place; with force, replaces only a
// swarmsim file); throws OutputError (exit 3)
void writeReference(const Reference& ref, const std::string& path, bool force);

// throws InputError (exit 2) unless `path` is a readable swarmsim reference
Reference readReference(const std::string& path);

// true when `path` is an HDF5 file with the reference's format attribute
bool isReferenceFile(const std::string& path);

// `swarmsim reference info`: a text summary, or one JSON object
void printReferenceInfo(const Reference& ref, const std::string& path, bool json, std::ostream& out);

// sha256 of a file's bytes, lowercase hex; throws InputError when it cannot be read
std::string sha256File(const std::string& path);

}  // namespace swarmsim::fastswarm
