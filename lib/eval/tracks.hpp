#pragma once
// Track sources for `swarmsim evaluate`: a swarmsim HDF5 output or a CSV of
// tracks, both served as a sequence of frames (one per sample of the time
// grid) so that metrics can be computed with bounded memory.
//
// Time grid
//   HDF5: sample k = frame k; dt = the root attribute frame_dt (or
//         /time[1] - /time[0] when frame_dt is missing or not positive).
//   CSV:  dt0 = the median positive time step between consecutive rows of the
//         same track (rows ordered by time within each id; for an even number
//         of steps the lower of the two middle steps); dt = the mean m of the steps
//         within 25 % of dt0 when |m - dt0| > 1e-6 dt0, else dt0 (so times rounded to a few decimals, e.g. 60 fps
//         written with 4 decimals, still give the true interval); t0 = the smallest time;
//         sample index = round((t - t0) / dt). Two rows of one id that round
//         to the same sample are an error naming both lines.
// Frame range (--frames A:B): python-like half-open range of sample indices,
//   either side optional, negative values count from the end (the number of
//   samples is the last sample index + 1). Samples outside the range are
//   treated as absent: no difference reaches across the range's ends.
//
// CSV format: one header line, then one row per individual per sample with
// id, time, x, y, z and optionally vx, vy, vz (metres, seconds, m/s). Empty
// lines are skipped; cells are trimmed of spaces and surrounding double quotes.
//   Delimiter: --delimiter (",", ";", "tab" or a tab character), else the one
//   of ';', ',' and tab occurring most often in the header.
//   Columns (header names compared case-insensitively), unless --columns names them:
//     id:   the first present of "id", "object", "track", "track_id", "individual"
//           (so a file with object and oldobject uses object); any text
//     time: "time", else "t"
//     x, y, z:    exact "x" ("y", "z"), else the first column whose name starts with it
//                 (e.g. "XSplined")
//     vx, vy, vz: exact "vx" (...), else the first column starting with it (e.g.
//                 "VXSplined"); velocities are used only when all three are found,
//                 otherwise they are derived from positions (metrics.hpp).
#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace swarmsim::eval {

// one sample of the time grid: the individuals present, sorted by id
struct Frame {
  std::int64_t sample = 0;
  bool dense = false;            // id[i] == i for every i (HDF5): find is O(1)
  std::vector<std::int64_t> id;  // ascending
  std::vector<double> pos;       // 3 per individual, m
  std::vector<double> vel;       // 3 per individual, m/s; empty when the source has no velocities

  std::size_t size() const { return id.size(); }
  // row of `key`, or -1 when that individual is absent from this frame
  std::ptrdiff_t find(std::int64_t key) const;
};

struct FrameRange {
  std::optional<long long> begin, end;
  // "A:B", "A:", ":B", ":"; throws InputError naming the option
  static FrameRange parse(const std::string& text);
  // python slice semantics on [0, count): negative counts from the end, clamped
  void resolve(std::int64_t count, std::int64_t& first, std::int64_t& last) const;
};

struct CsvOptions {
  std::string delimiter;  // empty: detect
  std::string columns;    // "id=NAME,time=NAME,x=NAME,..."; empty: detect
};

struct SourceOptions {
  std::string swarm;  // HDF5 only; empty: the only swarm
  FrameRange frames;
  CsvOptions csv;
};

struct TrackInfo {
  std::string file;
  std::string kind;   // "hdf5" or "csv"
  std::string swarm;  // HDF5: the swarm's name; CSV: empty
  double dt = 0.0;    // s
  std::int64_t individuals = 0;
  bool hasVelocity = false;
  std::int64_t first = 0, last = 0;  // samples [first, last) are served
};

class TrackSource {
 public:
  virtual ~TrackSource() = default;
  const TrackInfo& info() const { return info_; }
  // frame of sample k (first <= k < last); frames are read in increasing order
  // within a pass and a new pass may start again from `first`
  virtual void read(std::int64_t k, Frame& out) = 0;

 protected:
  TrackInfo info_;
};

// true when the file starts with the HDF5 signature or is named *.h5 / *.hdf5
bool looksLikeHdf5(const std::string& path);

// opens SIM or REF; throws InputError (file, line, column) on bad input
std::unique_ptr<TrackSource> openTracks(const std::string& path, const SourceOptions& options);

}  // namespace swarmsim::eval
