#include "eval/score.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <memory>

#include "core/error.hpp"

namespace swarmsim::eval {

namespace {

// count, mean, M2 (sum of squared deviations), min, max; merged in a fixed order
struct Moments {
  std::int64_t n = 0;
  double mean = 0, m2 = 0;
  double lo = std::numeric_limits<double>::infinity(), hi = -std::numeric_limits<double>::infinity();

  void addAll(const std::vector<double>& xs) {
    if (xs.empty()) return;
    double s = 0;
    for (double x : xs) s += x;
    const double mb = s / static_cast<double>(xs.size());
    double q = 0, l = lo, h = hi;
    for (double x : xs) {
      q += (x - mb) * (x - mb);
      l = std::min(l, x);
      h = std::max(h, x);
    }
    const auto nb = static_cast<std::int64_t>(xs.size());
    const std::int64_t nt = n + nb;
    const double delta = mb - mean;
    mean += delta * static_cast<double>(nb) / static_cast<double>(nt);
    m2 += q + delta * delta * static_cast<double>(n) * static_cast<double>(nb) / static_cast<double>(nt);
    n = nt;
    lo = l;
    hi = h;
  }
  double stddev() const { return n > 0 ? std::sqrt(std::max(0.0, m2 / static_cast<double>(n))) : 0.0; }
};

struct Side {
  std::unique_ptr<TrackSource> source;
  double scale = 1.0;
  std::array<Moments, kMetricCount> mom;
  std::array<std::vector<std::int64_t>, kMetricCount> raw, z;
};

std::size_t binOf(double x, double lo, double hi, std::size_t bins) {
  if (!(hi > lo)) return 0;
  const double t = (x - lo) / (hi - lo) * static_cast<double>(bins);
  if (!(t > 0.0)) return 0;
  return std::min(bins - 1, static_cast<std::size_t>(t));
}

// median of a histogram with uniform mass inside each bin
double histMedian(const std::vector<std::int64_t>& h, double lo, double hi, std::int64_t n) {
  if (n == 0) return std::numeric_limits<double>::quiet_NaN();
  if (!(hi > lo)) return lo;
  const double w = (hi - lo) / static_cast<double>(h.size());
  const double half = 0.5 * static_cast<double>(n);
  double cum = 0;
  for (std::size_t b = 0; b < h.size(); ++b) {
    const double c = static_cast<double>(h[b]);
    if (c > 0 && cum + c >= half) return lo + w * (static_cast<double>(b) + (half - cum) / c);
    cum += c;
  }
  return hi;
}

// integral of |F_a - F_b| for piecewise linear CDFs on common bins
double histW1(const std::vector<std::int64_t>& a, std::int64_t na, const std::vector<std::int64_t>& b, std::int64_t nb,
              double lo, double hi) {
  if (!(hi > lo) || na == 0 || nb == 0) return 0.0;
  const double w = (hi - lo) / static_cast<double>(a.size());
  std::int64_t ca = 0, cb = 0;
  double total = 0, d0 = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    ca += a[i];
    cb += b[i];
    const double d1 =
        static_cast<double>(ca) / static_cast<double>(na) - static_cast<double>(cb) / static_cast<double>(nb);
    if ((d0 >= 0) == (d1 >= 0) || d0 == 0 || d1 == 0) {
      total += 0.5 * w * (std::abs(d0) + std::abs(d1));
    } else {  // the difference changes sign inside the bin
      total += 0.5 * w * (d0 * d0 + d1 * d1) / (std::abs(d0) + std::abs(d1));
    }
    d0 = d1;
  }
  return total;
}

void pass(Side& s, const std::function<void(const FrameValues&)>& f) { computeMetrics(*s.source, s.scale, f); }

}  // namespace

EvaluationResult evaluate(const EvaluateOptions& options) {
  if (options.bins < 2) throw InputError("--bins: expected at least 2, got " + std::to_string(options.bins));
  if (!(options.simScale > 0.0) || !std::isfinite(options.simScale)) {
    throw InputError("--sim-scale: expected a positive number, got " + std::to_string(options.simScale));
  }
  Side sides[2];
  sides[0].source = openTracks(options.sim, options.source);
  sides[0].scale = options.simScale;
  sides[1].source = openTracks(options.reference, options.source);
  const auto nbins = static_cast<std::size_t>(options.bins);

  // pass 1: moments
  for (auto& s : sides) {
    pass(s, [&s](const FrameValues& v) {
      for (std::size_t m = 0; m < kMetricCount; ++m) s.mom[m].addAll(v[m]);
    });
  }
  for (const auto& s : sides) {
    std::int64_t any = 0;
    for (const auto& m : s.mom) any += m.n;
    if (any == 0) {
      throw InputError(s.source->info().file +
                       ": no metric samples at all (tracks too short or too gappy for any difference, and at most "
                       "one individual per sample)");
    }
  }
  // ranges
  std::array<double, kMetricCount> rawLo{}, rawHi{}, zLo{}, zHi{}, mean[2]{}, sd[2]{};
  for (std::size_t m = 0; m < kMetricCount; ++m) {
    rawLo[m] = std::min(sides[0].mom[m].lo, sides[1].mom[m].lo);
    rawHi[m] = std::max(sides[0].mom[m].hi, sides[1].mom[m].hi);
    double zl = std::numeric_limits<double>::infinity(), zh = -zl;
    for (int k = 0; k < 2; ++k) {
      const Moments& mo = sides[k].mom[m];
      mean[k][m] = mo.mean;
      sd[k][m] = mo.stddev();
      if (mo.n == 0) continue;
      const double a = sd[k][m] > 0 ? (mo.lo - mo.mean) / sd[k][m] : 0.0;
      const double b = sd[k][m] > 0 ? (mo.hi - mo.mean) / sd[k][m] : 0.0;
      zl = std::min(zl, a);
      zh = std::max(zh, b);
    }
    zl = std::clamp(zl, -5.0, 5.0);
    zh = std::clamp(zh, -5.0, 5.0);
    if (!(zh > zl)) {
      zl -= 0.5;
      zh += 0.5;
    }
    zLo[m] = zl;
    zHi[m] = zh;
  }
  // pass 2: histograms
  for (int k = 0; k < 2; ++k) {
    Side& s = sides[k];
    for (std::size_t m = 0; m < kMetricCount; ++m) {
      s.raw[m].assign(kRawBins, 0);
      s.z[m].assign(nbins, 0);
    }
    pass(s, [&](const FrameValues& v) {
      for (std::size_t m = 0; m < kMetricCount; ++m) {
        auto& raw = s.raw[m];
        auto& zh = s.z[m];
        const double mu = mean[k][m], sg = sd[k][m];
        for (double x : v[m]) {
          ++raw[binOf(x, rawLo[m], rawHi[m], kRawBins)];
          ++zh[binOf(sg > 0 ? (x - mu) / sg : 0.0, zLo[m], zHi[m], nbins)];
        }
      }
    });
  }

  EvaluationResult r;
  r.sim = sides[0].source->info();
  r.reference = sides[1].source->info();
  r.bins = options.bins;
  std::vector<double> entropy1;  // 1 - e_j of scored metrics
  for (std::size_t m = 0; m < kMetricCount; ++m) {
    MetricResult mr;
    mr.name = metricName(static_cast<int>(m));
    mr.unit = metricUnit(static_cast<int>(m));
    mr.samplesSim = sides[0].mom[m].n;
    mr.samplesRef = sides[1].mom[m].n;
    mr.meanSim = mean[0][m];
    mr.meanRef = mean[1][m];
    mr.stdSim = sd[0][m];
    mr.stdRef = sd[1][m];
    mr.medianSim = histMedian(sides[0].raw[m], rawLo[m], rawHi[m], mr.samplesSim);
    mr.medianRef = histMedian(sides[1].raw[m], rawLo[m], rawHi[m], mr.samplesRef);
    mr.scored = mr.samplesSim > 0 && mr.samplesRef > 0;
    mr.w1 = mr.scored ? histW1(sides[0].raw[m], mr.samplesSim, sides[1].raw[m], mr.samplesRef, rawLo[m], rawHi[m])
                      : std::numeric_limits<double>::quiet_NaN();
    mr.edges.resize(nbins + 1);
    for (std::size_t i = 0; i <= nbins; ++i) {
      mr.edges[i] = zLo[m] + (zHi[m] - zLo[m]) * static_cast<double>(i) / static_cast<double>(nbins);
    }
    mr.pdfSim.assign(nbins, 0.0);
    mr.pdfRef.assign(nbins, 0.0);
    for (std::size_t i = 0; i < nbins; ++i) {
      if (mr.samplesSim > 0) mr.pdfSim[i] = static_cast<double>(sides[0].z[m][i]) / static_cast<double>(mr.samplesSim);
      if (mr.samplesRef > 0) mr.pdfRef[i] = static_cast<double>(sides[1].z[m][i]) / static_cast<double>(mr.samplesRef);
    }
    if (mr.scored) {
      double l1 = 0;
      for (std::size_t i = 0; i < nbins; ++i) l1 += std::abs(mr.pdfRef[i] - mr.pdfSim[i]);
      mr.energy = 1.0 - 0.5 * l1;
      double e = 1.0;
      if (l1 > 0) {
        double h = 0;
        for (std::size_t i = 0; i < nbins; ++i) {
          const double p = std::abs(mr.pdfRef[i] - mr.pdfSim[i]) / l1;
          if (p > 0) h -= p * std::log(p);
        }
        e = h / std::log(static_cast<double>(nbins));
      }
      entropy1.push_back(1.0 - e);
    } else {
      mr.energy = std::numeric_limits<double>::quiet_NaN();
    }
    r.metrics.push_back(std::move(mr));
  }
  double denom = 0;
  for (double x : entropy1) denom += x;
  std::size_t j = 0;
  const double scoredCount = static_cast<double>(entropy1.size());
  r.total = 0;
  for (auto& mr : r.metrics) {
    if (!mr.scored) continue;
    mr.weight = denom > 0 ? entropy1[j] / denom : 1.0 / scoredCount;
    r.total += mr.weight * mr.energy;
    ++j;
  }
  return r;
}

nlohmann::json EvaluationResult::toJson() const {
  const auto side = [](const TrackInfo& t) {
    return nlohmann::json{{"file", t.file},
                          {"swarm", t.swarm.empty() ? nlohmann::json(nullptr) : nlohmann::json(t.swarm)},
                          {"dt", t.dt},
                          {"individuals", t.individuals}};
  };
  const auto num = [](double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); };
  nlohmann::json j;
  j["sim"] = side(sim);
  j["reference"] = side(reference);
  j["bins"] = bins;
  j["metrics"] = nlohmann::json::array();
  for (const auto& m : metrics) {
    j["metrics"].push_back({{"name", m.name},
                            {"unit", m.unit},
                            {"samples_sim", m.samplesSim},
                            {"samples_ref", m.samplesRef},
                            {"median_sim", num(m.medianSim)},
                            {"median_ref", num(m.medianRef)},
                            {"w1", num(m.w1)},
                            {"energy", num(m.energy)},
                            {"weight", m.weight},
                            {"edges", m.edges},
                            {"pdf_sim", m.pdfSim},
                            {"pdf_ref", m.pdfRef}});
  }
  j["total"] = total;
  return j;
}

void EvaluationResult::printTable(std::ostream& out) const {
  char buf[512];
  const auto sideLine = [&](const char* label, const TrackInfo& t) {
    std::snprintf(buf, sizeof buf, "%-10s %s%s%s (%s, dt %g s, %lld individuals, samples %lld..%lld)\n", label,
                  t.file.c_str(), t.swarm.empty() ? "" : " swarm ", t.swarm.c_str(), t.kind.c_str(), t.dt,
                  static_cast<long long>(t.individuals), static_cast<long long>(t.first),
                  static_cast<long long>(t.last - 1));
    out << buf;
  };
  sideLine("sim:", sim);
  sideLine("reference:", reference);
  std::snprintf(buf, sizeof buf, "%-6s %-8s %12s %12s %12s %12s %12s %8s %8s\n", "metric", "unit", "samples_sim",
                "samples_ref", "median_sim", "median_ref", "W1", "E_phi", "weight");
  out << buf;
  for (const auto& m : metrics) {
    std::snprintf(buf, sizeof buf, "%-6s %-8s %12lld %12lld %12.5g %12.5g %12.5g %8.5f %8.5f\n", m.name.c_str(),
                  m.unit.c_str(), static_cast<long long>(m.samplesSim), static_cast<long long>(m.samplesRef),
                  m.medianSim, m.medianRef, m.w1, m.energy, m.weight);
    out << buf;
  }
  std::snprintf(buf, sizeof buf, "total E = %.6f  (%d z-score bins; 1 = identical distributions)\n", total, bins);
  out << buf;
}

void runEvaluate(const EvaluateOptions& options, std::ostream& out) {
  const EvaluationResult r = evaluate(options);
  if (options.json) {
    out << r.toJson().dump(2) << "\n";
  } else {
    r.printTable(out);
  }
}

}  // namespace swarmsim::eval
