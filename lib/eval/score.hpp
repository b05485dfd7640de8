#pragma once
// `swarmsim evaluate`: how closely a simulation (SIM) moves like a reference (REF). Two scores
// (docs/evaluation.md says why there are two):
//
// 1. The wang2015 score E (BSwarm, section 5, eq. 5-7), kept as the paper defines it, over the paper's
//    seven metrics (metrics.hpp) only. Each side's values are z-scored by their own mean and standard
//    deviation, so E compares shapes of distributions and never magnitudes.
//   pass 1, per metric and side: count, mean, population standard deviation
//     (divide by the count), min, max (double; frames combined in order, so
//     the result does not depend on the number of threads).
//   pass 2, per metric and side: two histograms.
//     z-score histogram: each value is z-scored by its own side's mean and
//       standard deviation, z = (x - mean) / std (z = 0 for every value when
//       std = 0). The N bins (--bins, default 50) are common to both sides and
//       span [zlo, zhi] = the union of both sides' z ranges, clipped to
//       [-5, 5] (values beyond fall into the first or last bin); when that range
//       is empty it is widened to [zlo - 0.5, zhi + 0.5]. Q = counts / count, so
//       each PDF sums to 1.
//     raw histogram: 8192 equal bins between the joint min and max of both sides'
//       raw values, one per time block (below); the values are taken as uniformly
//       spread within each bin (piecewise linear CDF). The median of each side and
//       W1 = integral |F_sim(x) - F_ref(x)| dx (the metric's unit) are computed
//       from these, exactly for that piecewise linear CDF; the resolution is
//       (max - min) / 8192, so each is within one bin width of the exact value.
//   energy (eq. 6-7 with p1 = 0, p2 = 2): E_j = 1 - sum_i |Q_ref,i - Q_sim,i| / 2,
//     1 for identical PDFs, 0 for disjoint ones.
//   weights (entropy weight method, Zou et al. 2006; bins i = 1..N are the
//     objects, metrics j the indicators): x_ij = |Q_ref,i - Q_sim,i|,
//     p_ij = x_ij / sum_i x_ij, e_j = -(1 / ln N) sum_i p_ij ln p_ij (0 ln 0 = 0;
//     e_j = 1 when every x_ij of metric j is 0), w_j = (1 - e_j) / sum_k (1 - e_k);
//     when that denominator is 0 (e.g. identical data) every weight is 1/M.
//   total (eq. 5): E = sum_j w_j E_j; 1 for identical data.
//
// 2. The physical score S, in physical units, over all eleven distribution metrics (the paper's seven and
//    the collective pol, mill, r_c, d_rel) and two correlation functions (correlations.hpp):
//     distribution metric j: s_j = exp(-W1_j / D_j), with W1_j as above (the metric's unit) and D_j the
//       reference's own spread, its mean absolute deviation about its median (same unit; from the same
//       histogram). s_j = 1 for identical distributions; a shift of the whole distribution by D_j gives
//       exp(-1) = 0.37. When D_j = 0: s_j = 1 if W1_j = 0, else 0.
//     correlation function (autocorrelation C(tau) over lags 1..L; velocity correlation C(r) over the
//       distance bins): s = 1 - mean |C_sim - C_ref| / 2 over the entries defined on both sides (C in
//       [-1, 1], so s in [0, 1]).
//     S = the mean of the s of every scored metric and function, each counted once.
//   A metric or function is scored only when both sides have at least kMinSamples values (pair sums for the
//   functions: at least one defined entry); one that is not is reported with a warning and left out of S
//   and E (E's weights are over the scored paper metrics).
//
// Uncertainty: a block bootstrap over time. Each side's samples [first, last) are split into B consecutive
// blocks (--blocks, default 20, fewer when a side has fewer samples); a replicate draws B blocks with
// replacement on each side independently (counter-based random numbers keyed on (--seed, replicate, side,
// draw): the result depends on nothing else) and recomputes every s_j, S and E from the drawn blocks'
// histograms and sums (the moments and z-ranges of the full data are kept). With R replicates (--bootstrap,
// default 200; 0: no intervals) the 95 % interval is the basic bootstrap interval
// [2 x - q_97.5, 2 x - q_2.5] of the estimate x and the replicates' percentiles, clipped to [0, 1]: W1
// between finite samples is biased upward, replicates (resampled again) more so, and the basic interval
// corrects for that bias once; a data set scored against itself gets [1, 1].
//
// Time steps: both sides are compared on one time grid. When the two sampling intervals differ, the
// finer side is subsampled by the integer ratio when there is one (within 1e-6), else it is an error.
//
// --baseline also scores a swarm of independent Ornstein-Uhlenbeck walkers matched to the reference
// (baseline.hpp: count = the median individuals per sample, median speed, velocity correlation time,
// centroid and rms distance to it, same dt and number of samples; seeded by --seed) against the reference,
// so every report shows where plain noise lands.
#include <cstdint>
#include <nlohmann/json.hpp>
#include <map>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "eval/metrics.hpp"
#include "eval/tracks.hpp"

namespace swarmsim::eval {

inline constexpr int kRawBins = 8192;
inline constexpr std::int64_t kMinSamples = 30;

struct EvaluateOptions {
  std::string sim, reference;
  SourceOptions source;                      // --swarm, --frames, --delimiter, --columns: both files
  std::optional<FrameRange> simFrames, refFrames;  // --sim-frames, --ref-frames: one side (over --frames)
  int bins = 50;
  double simScale = 1.0;
  bool json = false;
  int bootstrap = 200;  // replicates; 0: no intervals
  int blocks = 20;
  std::uint64_t seed = 1;
  bool baseline = false;
};

struct Interval {
  double lo = 0, hi = 0;
  bool valid = false;
};

struct MetricResult {
  std::string name, unit;
  bool paper = true;  // one of wang2015's seven (in E)
  std::int64_t samplesSim = 0, samplesRef = 0;
  double meanSim = 0, meanRef = 0, stdSim = 0, stdRef = 0;
  double medianSim = 0, medianRef = 0;
  double w1 = 0;
  double spreadRef = 0;  // D: the reference's mean absolute deviation about its median
  bool scored = false;   // at least kMinSamples values on both sides
  double score = 0;      // s = exp(-W1 / D)
  Interval scoreCi;
  double energy = 0, weight = 0;  // wang2015 (paper metrics only)
  std::vector<double> edges, pdfSim, pdfRef;  // z-score bins (paper metrics only)
};

struct CurveResult {
  std::string name, axis, axisUnit;  // e.g. "autocorrelation", "lag", "s"
  std::vector<double> x, sim, ref;
  double tauSim = 0, tauRef = 0;  // autocorrelation only: correlation times (s; NaN when unresolved)
  bool scored = false;
  double score = 0;
  Interval scoreCi;
};

struct ScoreSummary {
  double physical = 0;  // S
  Interval physicalCi;
  int used = 0;         // metrics and functions in S
  double wang2015 = 0;  // E
  Interval wang2015Ci;
};

struct EvaluationResult {
  TrackInfo sim, reference;
  int bins = 0;
  int replicates = 0, blocksSim = 0, blocksRef = 0;
  std::uint64_t seed = 0;
  std::vector<MetricResult> metrics;  // every distribution metric, metrics.hpp's order
  std::vector<CurveResult> curves;    // autocorrelation, velocity correlation over distance
  ScoreSummary summary;
  double total = 0;  // = summary.wang2015 (kept for existing readers)
  std::vector<std::string> warnings;
  std::optional<ScoreSummary> baseline;  // --baseline
  std::string baselineDescription;
  struct TermScore {
    bool scored = false;
    double score = 0;
    Interval ci;
  };
  std::map<std::string, TermScore> baselineScores;  // --baseline: each metric's and function's score

  nlohmann::json toJson() const;
  void printTable(std::ostream& out) const;
};

EvaluationResult evaluate(const EvaluateOptions& options);

// the pieces of the scores, on histograms of `bins` equal bins over [lo, hi] whose mass is taken as uniform
// inside each bin (n: the histogram's total count)
double histogramMedian(const std::int64_t* h, std::size_t bins, double lo, double hi, std::int64_t n);
// mean absolute deviation about `med`
double histogramSpread(const std::int64_t* h, std::size_t bins, double lo, double hi, std::int64_t n, double med);
// integral of |F_a - F_b| (Wasserstein-1) on common bins
double histogramW1(const std::int64_t* a, std::int64_t na, const std::int64_t* b, std::int64_t nb, std::size_t bins,
                   double lo, double hi);
// s = exp(-W1 / spread) (1 or 0 when spread is 0)
double physicalScore(double w1, double spread);
// 1 - mean |a - b| / 2 over the entries from `from` on defined (not NaN) in both; NaN when none is
double curveScore(const std::vector<double>& a, const std::vector<double>& b, std::size_t from);

// what the subcommand runs: evaluate and print (table or JSON) to out; warnings go to `err`
void runEvaluate(const EvaluateOptions& options, std::ostream& out, std::ostream& err);

}  // namespace swarmsim::eval
