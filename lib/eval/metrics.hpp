#pragma once
// The seven motion metrics of wang2015 (section 5) for `swarmsim evaluate`,
// computed per individual i and sample k of the time grid (tracks.hpp), with
// dt the sampling interval in seconds.
//
// Neighbours in time: sample k-1 (k+1) of individual i exists only when i is
// present at sample index k-1 (k+1) itself (and inside the --frames range).
// Differences are taken only between such samples: never across a gap in a
// track, never across the ends of a track or of the range. A metric value that
// needs a missing sample is simply not produced (it is not zero).
// Vectors are in the source's units times --sim-scale for the simulation
// (positions and velocities multiplied by F).
//
//   velocity  v_k = the recorded velocity (HDF5 velocity dataset, CSV vx, vy, vz)
//             when the source has one; otherwise the central difference
//             v_k = (x_{k+1} - x_{k-1}) / (2 dt), which needs both neighbours.
//   v      speed, m/s:                  |v_k|
//   a      acceleration, m/s^2:         |v_{k+1} - v_{k-1}| / (2 dt)
//   omega  angular velocity, rad/s:     angle(v_{k-1}, v_{k+1}) / (2 dt), the angle in
//                                       [0, pi] computed as atan2(|v_{k-1} x v_{k+1}|,
//                                       v_{k-1} . v_{k+1}); not produced when either
//                                       speed is 0
//   alpha  angular acceleration, rad/s^2: |omega_{k+1} - omega_{k-1}| / (2 dt)
//   jerk   Cartesian jerk, m/s^3:       |v_{k+1} - 2 v_k + v_{k-1}| / dt^2
//   d      nearest-neighbour distance, m: min over the other individuals j present
//                                       at sample k of |x_j - x_i| (same swarm / same
//                                       file); not produced when i is alone at k
//   eta    velocity difference to the nearest neighbour, 1/s:
//                                       |v_nn - v_i| / d with nn the nearest neighbour
//                                       (ties: the lower id); needs v_i and v_nn at
//                                       sample k; not produced when d = 0
//
// Collective metrics (issue 13; not part of wang2015's E), per sample k over the individuals present at k,
// with c the centroid of their positions and R_g = sqrt(mean |x_i - c|^2) (the radius of gyration):
//   pol    polarisation, 1:     |sum_i v_i / |v_i|| / n over the individuals with a velocity and |v_i| > 0;
//                               one value per sample, needs n >= 3 such individuals
//   mill   milling, 1:          |sum_i (x_i - c) x v_i| / sum_i |x_i - c| |v_i| (normalised angular
//                               momentum about the centroid); one value per sample, n >= 3 as for pol
//   r_c    distance to the centre, m:  |x_i - c| per individual; needs n >= 2 present
//   d_rel  nearest-neighbour distance at the swarm's density, 1:  d_i / l with l = R_g n^(-1/3) the
//                               length per individual of the sample; per individual, needs n >= 3
// pol is 1 for a group translating rigidly, mill is 1 for a group turning rigidly about its centroid, both
// are about n^(-1/2) for independent directions. d_rel compares spacing at equal density: a swarm scaled
// in size, or with more individuals at the same spacing, keeps its d_rel distribution.
//
// Hence with recorded velocities v, a, omega, jerk need samples k-1..k+1 and
// alpha k-2..k+2; without them v needs k-1..k+1, a, omega and jerk k-2..k+2 and
// alpha k-3..k+3. On a circle of radius R flown at speed s, sampled at dt
// (theta = s dt / R), derived velocities give |v| = s sin(theta)/theta,
// omega = s/R exactly, alpha = 0, a = s^2/R (1 + O(theta^2)) and
// jerk = s^3/R^2 (1 + O(theta^2)).
//
// Everything is computed in double precision (HDF5 float32 values are widened).
// Frames are processed in sample order with a window of 5 frames, so memory does
// not depend on the number of frames; within a frame the individuals are
// processed in parallel and the values returned in row (id) order, so results
// do not depend on the number of threads.
#include <array>
#include <functional>
#include <string>
#include <vector>

#include "eval/tracks.hpp"

namespace swarmsim::eval {

enum Metric : int {
  kSpeed = 0, kAccel, kOmega, kAlpha, kJerk, kNnDistance, kEta,  // wang2015's seven
  kPolarisation, kMilling, kCentreDistance, kRelNnDistance,      // collective
  kMetricCount
};
inline constexpr int kPaperMetricCount = 7;  // the first seven: wang2015's E uses these only

const char* metricName(int m);  // "v", "a", "omega", "alpha", "jerk", "d", "eta", "pol", "mill", "r_c", "d_rel"
const char* metricUnit(int m);  // "m/s", "m/s^2", "rad/s", "rad/s^2", "m/s^3", "m", "1/s", "1", "1", "m", "1"

// the values of one sample k: for each metric, the values of the individuals
// present at k for which it is defined, in id order (pol and mill: at most one)
using FrameValues = std::array<std::vector<double>, kMetricCount>;

// the centroid c of a frame's positions and its length per individual l = R_g n^(-1/3) (R_g the radius of
// gyration about c); l = 0 for an empty frame
void centroidAndSpacing(const Frame& f, double c[3], double& spacing);

// sample k itself, for what needs more than the values (correlations.hpp): the individuals present and
// their velocities (3 per row, recorded or derived; NaN where not available), already scaled
struct SampleView {
  std::int64_t sample = 0;
  const Frame* frame = nullptr;
  const std::vector<double>* velocity = nullptr;
};

// one pass over the source's samples [first, last), calling `sink` once per
// sample in increasing order; positions and velocities are multiplied by `scale`
void computeMetrics(TrackSource& source, double scale,
                    const std::function<void(const FrameValues&, const SampleView&)>& sink);

}  // namespace swarmsim::eval
