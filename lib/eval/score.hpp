#pragma once
// `swarmsim evaluate`: the entropy-based similarity of wang2015 (section 5,
// eq. 5-7) between a simulation (SIM) and a reference (REF), plus medians and
// Wasserstein-1 distances on the raw metric values (metrics.hpp).
//
// Two passes over each file (metrics are recomputed, never stored):
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
//       raw values; the values are taken as uniformly spread within each bin
//       (piecewise linear CDF). The median of each side and
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
// A metric without samples on one side (e.g. d when a file has a single
// individual per sample) gets no energy (JSON null), weight 0, and is left out
// of the weights and the total (M = the number of metrics left). No metric
// samples at all, on either side, is an error.
#include <cstdint>
#include <nlohmann/json.hpp>
#include <ostream>
#include <string>
#include <vector>

#include "eval/metrics.hpp"
#include "eval/tracks.hpp"

namespace swarmsim::eval {

inline constexpr int kRawBins = 8192;

struct EvaluateOptions {
  std::string sim, reference;
  SourceOptions source;  // --swarm, --frames, --delimiter, --columns: applied to both files
  int bins = 50;
  double simScale = 1.0;
  bool json = false;
};

struct MetricResult {
  std::string name, unit;
  std::int64_t samplesSim = 0, samplesRef = 0;
  double meanSim = 0, meanRef = 0, stdSim = 0, stdRef = 0;
  double medianSim = 0, medianRef = 0;
  double w1 = 0;
  bool scored = false;  // samples on both sides
  double energy = 0, weight = 0;
  std::vector<double> edges, pdfSim, pdfRef;  // z-score bins
};

struct EvaluationResult {
  TrackInfo sim, reference;
  int bins = 0;
  std::vector<MetricResult> metrics;
  double total = 0;

  nlohmann::json toJson() const;
  void printTable(std::ostream& out) const;
};

EvaluationResult evaluate(const EvaluateOptions& options);

// what the subcommand runs: evaluate and print (table or JSON) to out
void runEvaluate(const EvaluateOptions& options, std::ostream& out);

}  // namespace swarmsim::eval
