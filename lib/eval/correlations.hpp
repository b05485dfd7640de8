#pragma once
// Correlation functions for `swarmsim evaluate` (issue 13), accumulated per block of samples so that the
// evaluator can bootstrap them over time (score.hpp). Both work on velocity fluctuations: in each sample,
// dv_i = v_i - <v> with <v> the mean velocity of the individuals of that sample that have one (recorded or
// derived, metrics.hpp), so a common drift of the whole swarm does not count as correlation.
//
//   autocorrelation  C(tau) = sum dv_i(t) . dv_i(t + tau) / sum |dv_i(t)|^2, over the individuals i present
//                    with a velocity at both t and t + tau (never across a gap or the range's ends), for
//                    lags tau = 0 .. L samples (C(0) = 1). L = min(ceil(kAutoSeconds / dt), kMaxLags).
//                    The correlation time tau_c is the first lag where C drops below 1/e, linearly
//                    interpolated, in seconds (NaN when C stays above 1/e up to L).
//                    A pair (t, t + tau) is counted in the block of t.
//   velocity correlation over distance
//                    C(r) = mean over pairs i != j of one sample at distance r of u_i . u_j, u = dv / |dv|,
//                    with r in units of the sample's length per individual l = R_g n^(-1/3) (metrics.hpp's
//                    d_rel uses the same l), so swarms of different density are compared at equal density;
//                    kDistanceBins bins of width kMaxDistance / kDistanceBins over [0, kMaxDistance) l.
//                    1 for a rigidly moving group, 0 for independent directions.
// Cost bound: at most kMaxRows individuals of a sample take part (every s-th row, s = ceil(n / kMaxRows)),
// which leaves both averages unbiased.
#include <cstdint>
#include <vector>

#include "eval/metrics.hpp"

namespace swarmsim::eval {

inline constexpr double kAutoSeconds = 2.0;
inline constexpr int kMaxLags = 200;
inline constexpr int kDistanceBins = 16;
inline constexpr double kMaxDistance = 4.0;
inline constexpr std::size_t kMaxRows = 400;

// sums of one block
struct CorrelationSums {
  std::vector<double> autoNum, autoDen;     // per lag 0..L
  std::vector<double> pairSum, pairCount;   // per distance bin
  void resize(int lags, int bins);
  void add(const CorrelationSums& o);
};

// the block (0 .. blocks-1) of `sample` when samples [first, last) are split into `blocks` consecutive blocks
// of nearly equal length; the one rule for every per-block sum of the bootstrap (score.cpp)
int blockOfSample(std::int64_t sample, std::int64_t first, std::int64_t last, int blocks);

class CorrelationAccumulator {
 public:
  // samples [first, last) split into `blocks` consecutive blocks of (nearly) equal length
  CorrelationAccumulator(double dt, std::int64_t first, std::int64_t last, int blocks);
  // samples in increasing order (as computeMetrics gives them)
  void add(const SampleView& s);
  int lags() const { return lags_; }
  int blockOf(std::int64_t sample) const;
  const std::vector<CorrelationSums>& blocks() const { return blocks_; }

 private:
  struct Past {
    std::int64_t sample = -1;
    std::vector<std::int64_t> id;  // the rows taken, ascending
    std::vector<double> dv;        // 3 per taken row (NaN: no velocity)
  };
  std::int64_t first_, last_;
  int lags_;
  std::vector<Past> ring_;
  std::vector<CorrelationSums> blocks_;
};

// C(tau) (or C(r)) from sums: num / den per entry, NaN where den is 0
std::vector<double> ratio(const std::vector<double>& num, const std::vector<double>& den);
// the first lag (in seconds) where c drops below 1/e, linearly interpolated; NaN if it never does
double correlationTime(const std::vector<double>& c, double dt);

}  // namespace swarmsim::eval
