#include "eval/score.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <memory>

#include "core/error.hpp"
#include "core/rng.hpp"
#include "eval/baseline.hpp"
#include "eval/correlations.hpp"

namespace swarmsim::eval {

// median of a histogram with uniform mass inside each bin
double histogramMedian(const std::int64_t* h, std::size_t bins, double lo, double hi, std::int64_t n) {
  if (n == 0) return std::numeric_limits<double>::quiet_NaN();
  if (!(hi > lo)) return lo;
  const double w = (hi - lo) / static_cast<double>(bins);
  const double half = 0.5 * static_cast<double>(n);
  double cum = 0;
  for (std::size_t b = 0; b < bins; ++b) {
    const double c = static_cast<double>(h[b]);
    if (c > 0 && cum + c >= half) return lo + w * (static_cast<double>(b) + (half - cum) / c);
    cum += c;
  }
  return hi;
}

// mean absolute deviation about `med` of a histogram with uniform mass inside each bin
double histogramSpread(const std::int64_t* h, std::size_t bins, double lo, double hi, std::int64_t n, double med) {
  if (n == 0 || !(hi > lo)) return 0.0;
  const double w = (hi - lo) / static_cast<double>(bins);
  double total = 0;
  for (std::size_t b = 0; b < bins; ++b) {
    if (h[b] == 0) continue;
    const double a = lo + w * static_cast<double>(b), e = a + w;
    double mean;
    if (med <= a) {
      mean = 0.5 * (a + e) - med;
    } else if (med >= e) {
      mean = med - 0.5 * (a + e);
    } else {
      mean = ((med - a) * (med - a) + (e - med) * (e - med)) / (2.0 * w);
    }
    total += static_cast<double>(h[b]) * mean;
  }
  return total / static_cast<double>(n);
}

// integral of |F_a - F_b| for piecewise linear CDFs on common bins
double histogramW1(const std::int64_t* a, std::int64_t na, const std::int64_t* b, std::int64_t nb, std::size_t bins,
              double lo, double hi) {
  if (!(hi > lo) || na == 0 || nb == 0) return 0.0;
  const double w = (hi - lo) / static_cast<double>(bins);
  std::int64_t ca = 0, cb = 0;
  double total = 0, d0 = 0;
  for (std::size_t i = 0; i < bins; ++i) {
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

double physicalScore(double w1, double spread) {
  if (spread > 0) return std::exp(-w1 / spread);
  return w1 == 0 ? 1.0 : 0.0;
}

// 1 - mean |a - b| / 2 over entries defined on both (from index `from`); NaN when none is
double curveScore(const std::vector<double>& a, const std::vector<double>& b, std::size_t from) {
  double sum = 0;
  std::size_t n = 0;
  for (std::size_t i = from; i < a.size(); ++i) {
    if (std::isnan(a[i]) || std::isnan(b[i])) continue;
    sum += std::abs(a[i] - b[i]);
    ++n;
  }
  return n > 0 ? 1.0 - 0.5 * sum / static_cast<double>(n) : std::numeric_limits<double>::quiet_NaN();
}


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
  int blocks = 1;
  std::array<Moments, kMetricCount> mom;
  // raw histograms per time block (blocks x kRawBins) and the z-score histogram of the paper metrics, also
  // per block (blocks x bins)
  std::array<std::vector<std::int64_t>, kMetricCount> raw, z;
  std::array<std::vector<std::int64_t>, kMetricCount> blockCount;  // values per block
  std::unique_ptr<CorrelationAccumulator> corr;
  // pass 1 extras for the baseline: individuals per sample, centroid sum
  std::vector<std::int64_t> perSample;
  double centroid[3] = {0, 0, 0};
  std::int64_t centroidSamples = 0;

  int blockOf(std::int64_t sample) const {
    return blockOfSample(sample, source->info().first, source->info().last, blocks);
  }
};

std::size_t binOf(double x, double lo, double hi, std::size_t bins) {
  if (!(hi > lo)) return 0;
  const double t = (x - lo) / (hi - lo) * static_cast<double>(bins);
  if (!(t > 0.0)) return 0;
  return std::min(bins - 1, static_cast<std::size_t>(t));
}

// the E of eq. 5-7 from the paper metrics' z histograms (count per side); scored[m] says which count
struct Wang {
  std::array<double, kPaperMetricCount> energy{}, weight{};
  double total = 0;
};
Wang wangScore(const std::array<const std::int64_t*, kPaperMetricCount>& zs,
               const std::array<const std::int64_t*, kPaperMetricCount>& zr,
               const std::array<std::int64_t, kPaperMetricCount>& ns, const std::array<std::int64_t, kPaperMetricCount>& nr,
               const std::array<bool, kPaperMetricCount>& scored, std::size_t nbins) {
  Wang w;
  std::array<double, kPaperMetricCount> entropy1{};
  double denom = 0;
  int count = 0;
  for (std::size_t m = 0; m < kPaperMetricCount; ++m) {
    if (!scored[m] || ns[m] == 0 || nr[m] == 0) {
      w.energy[m] = std::numeric_limits<double>::quiet_NaN();
      continue;
    }
    double l1 = 0;
    for (std::size_t i = 0; i < nbins; ++i) {
      l1 += std::abs(static_cast<double>(zr[m][i]) / static_cast<double>(nr[m]) -
                     static_cast<double>(zs[m][i]) / static_cast<double>(ns[m]));
    }
    w.energy[m] = 1.0 - 0.5 * l1;
    double e = 1.0;
    if (l1 > 0) {
      double h = 0;
      for (std::size_t i = 0; i < nbins; ++i) {
        const double p = std::abs(static_cast<double>(zr[m][i]) / static_cast<double>(nr[m]) -
                                  static_cast<double>(zs[m][i]) / static_cast<double>(ns[m])) /
                         l1;
        if (p > 0) h -= p * std::log(p);
      }
      e = h / std::log(static_cast<double>(nbins));
    }
    entropy1[m] = 1.0 - e;
    denom += entropy1[m];
    ++count;
  }
  for (std::size_t m = 0; m < kPaperMetricCount; ++m) {
    if (std::isnan(w.energy[m])) continue;
    w.weight[m] = denom > 0 ? entropy1[m] / denom : 1.0 / count;
    w.total += w.weight[m] * w.energy[m];
  }
  return w;
}

void pass(Side& s, const std::function<void(const FrameValues&, const SampleView&)>& f) {
  computeMetrics(*s.source, s.scale, f);
}

// serves every k-th sample of another source (a coarser time grid): sample j = the inner's first + j k
class StrideSource : public TrackSource {
 public:
  StrideSource(std::unique_ptr<TrackSource> inner, std::int64_t k) : inner_(std::move(inner)), k_(k) {
    info_ = inner_->info();
    info_.dt *= static_cast<double>(k);
    info_.first = 0;
    info_.last = (inner_->info().last - inner_->info().first + k - 1) / k;
  }
  void read(std::int64_t j, Frame& out) override {
    inner_->read(inner_->info().first + j * k_, out);
    out.sample = j;
  }

 private:
  std::unique_ptr<TrackSource> inner_;
  std::int64_t k_;
};

// both sides on one time grid: the finer one subsampled by the integer ratio, or an error
void commonGrid(std::unique_ptr<TrackSource>& sim, std::unique_ptr<TrackSource>& ref, std::vector<std::string>& warnings) {
  const double a = sim->info().dt, b = ref->info().dt;
  if (std::abs(a - b) <= 1e-9 * std::max(a, b)) return;
  auto& fine = a < b ? sim : ref;
  const double ratio = std::max(a, b) / std::min(a, b);
  const double k = std::round(ratio);
  if (std::abs(ratio - k) > 1e-6 * ratio || k < 2) {
    char buf[512];
    std::snprintf(buf, sizeof buf,
                  "the time steps differ and are not integer multiples: %s has dt %.9g s, %s has dt %.9g s "
                  "(metrics such as acceleration depend on the step; write the simulation at the reference's "
                  "interval, e.g. with the scenario's dt and steps_per_frame, or resample one of them)",
                  sim->info().file.c_str(), a, ref->info().file.c_str(), b);
    throw InputError(buf);
  }
  char buf[512];
  std::snprintf(buf, sizeof buf, "%s: dt %.9g s subsampled every %d samples to the other side's dt %.9g s",
                fine->info().file.c_str(), std::min(a, b), static_cast<int>(k), std::max(a, b));
  warnings.emplace_back(buf);
  fine = std::make_unique<StrideSource>(std::move(fine), static_cast<std::int64_t>(k));
  if (fine->info().last - fine->info().first < 2) {
    throw InputError(fine->info().file + ": fewer than 2 samples left after subsampling to the other side's dt");
  }
}

struct RefStats {
  double medianSpeed = 0, tau = 0, extent = 0;
  double centre[3] = {0, 0, 0};
  std::int64_t count = 0, samples = 0;
  double dt = 0;
};

EvaluationResult evaluateSources(std::unique_ptr<TrackSource> simSource, double simScale,
                                 std::unique_ptr<TrackSource> refSource, const EvaluateOptions& options,
                                 RefStats* refStats) {
  if (options.bins < 2) throw InputError("--bins: expected at least 2, got " + std::to_string(options.bins));
  if (options.blocks < 1) throw InputError("--blocks: expected at least 1, got " + std::to_string(options.blocks));
  if (options.bootstrap < 0) throw InputError("--bootstrap: expected 0 or more replicates");
  EvaluationResult r;
  Side sides[2];
  commonGrid(simSource, refSource, r.warnings);
  sides[0].source = std::move(simSource);
  sides[0].scale = simScale;
  sides[1].source = std::move(refSource);
  const auto nbins = static_cast<std::size_t>(options.bins);
  for (auto& s : sides) {
    const TrackInfo& t = s.source->info();
    s.blocks = static_cast<int>(std::min<std::int64_t>(options.blocks, std::max<std::int64_t>(1, t.last - t.first)));
  }

  // pass 1: moments (and the reference's count, centroid for a baseline)
  for (auto& s : sides) {
    pass(s, [&s](const FrameValues& v, const SampleView& view) {
      for (std::size_t m = 0; m < kMetricCount; ++m) s.mom[m].addAll(v[m]);
      const Frame& f = *view.frame;
      s.perSample.push_back(static_cast<std::int64_t>(f.size()));
      if (f.size() > 0) {
        double c[3], spacing = 0;
        centroidAndSpacing(f, c, spacing);
        for (std::size_t d = 0; d < 3; ++d) s.centroid[d] += c[d];
        ++s.centroidSamples;
      }
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
  // pass 2: histograms per block, correlation sums per block
  for (int k = 0; k < 2; ++k) {
    Side& s = sides[k];
    const auto B = static_cast<std::size_t>(s.blocks);
    for (std::size_t m = 0; m < kMetricCount; ++m) {
      s.raw[m].assign(B * kRawBins, 0);
      s.z[m].assign(m < kPaperMetricCount ? B * nbins : 0, 0);
      s.blockCount[m].assign(B, 0);
    }
    const TrackInfo& t = s.source->info();
    s.corr = std::make_unique<CorrelationAccumulator>(t.dt, t.first, t.last, s.blocks);
    pass(s, [&](const FrameValues& v, const SampleView& view) {
      const auto b = static_cast<std::size_t>(s.blockOf(view.sample));
      for (std::size_t m = 0; m < kMetricCount; ++m) {
        std::int64_t* raw = s.raw[m].data() + b * kRawBins;
        const double mu = mean[k][m], sg = sd[k][m];
        for (double x : v[m]) ++raw[binOf(x, rawLo[m], rawHi[m], kRawBins)];
        if (m < kPaperMetricCount) {
          std::int64_t* zh = s.z[m].data() + b * nbins;
          for (double x : v[m]) ++zh[binOf(sg > 0 ? (x - mu) / sg : 0.0, zLo[m], zHi[m], nbins)];
        }
        s.blockCount[m][b] += static_cast<std::int64_t>(v[m].size());
      }
      s.corr->add(view);
    });
  }

  r.sim = sides[0].source->info();
  r.reference = sides[1].source->info();
  r.bins = options.bins;
  r.replicates = options.bootstrap;
  r.blocksSim = sides[0].blocks;
  r.blocksRef = sides[1].blocks;
  r.seed = options.seed;

  // the whole data as a "replicate" that draws every block once
  struct Draw {
    std::vector<int> blocks[2];
  };
  const auto identity = [&]() {
    Draw d;
    for (int k = 0; k < 2; ++k) {
      for (int b = 0; b < sides[k].blocks; ++b) d.blocks[k].push_back(b);
    }
    return d;
  };
  // scores of one draw: per metric s_j, per curve s, S, E
  struct Scores {
    std::array<double, kMetricCount> metric{};
    std::array<double, 2> curve{};
    double physical = 0, wang = 0;
  };
  std::array<bool, kMetricCount> scoredMetric{};
  std::array<bool, 2> scoredCurve{};
  std::vector<std::int64_t> bufS(kRawBins), bufR(kRawBins);
  std::array<std::vector<std::int64_t>, kPaperMetricCount> zsAll, zrAll;
  const auto scoresOf = [&](const Draw& d, bool full, EvaluationResult* out) {
    Scores sc;
    std::array<const std::int64_t*, kPaperMetricCount> zsp{}, zrp{};
    std::array<std::int64_t, kPaperMetricCount> ns{}, nr{};
    std::array<bool, kPaperMetricCount> scoredPaper{};
    double sum = 0;
    int used = 0;
    for (std::size_t m = 0; m < kMetricCount; ++m) {
      std::int64_t n[2] = {0, 0};
      for (int k = 0; k < 2; ++k) {
        std::vector<std::int64_t>& buf = k == 0 ? bufS : bufR;
        std::fill(buf.begin(), buf.end(), 0);
        for (int b : d.blocks[k]) {
          const std::int64_t* h = sides[k].raw[m].data() + static_cast<std::size_t>(b) * kRawBins;
          for (std::size_t i = 0; i < kRawBins; ++i) buf[i] += h[i];
          n[k] += sides[k].blockCount[m][static_cast<std::size_t>(b)];
        }
        if (m < kPaperMetricCount) {
          auto& zall = k == 0 ? zsAll[m] : zrAll[m];
          zall.assign(nbins, 0);
          for (int b : d.blocks[k]) {
            const std::int64_t* h = sides[k].z[m].data() + static_cast<std::size_t>(b) * nbins;
            for (std::size_t i = 0; i < nbins; ++i) zall[i] += h[i];
          }
        }
      }
      const double medRef = histogramMedian(bufR.data(), kRawBins, rawLo[m], rawHi[m], n[1]);
      const double spread = histogramSpread(bufR.data(), kRawBins, rawLo[m], rawHi[m], n[1], medRef);
      const double w1 = histogramW1(bufS.data(), n[0], bufR.data(), n[1], kRawBins, rawLo[m], rawHi[m]);
      sc.metric[m] = physicalScore(w1, spread);
      if (full) {
        scoredMetric[m] = n[0] >= kMinSamples && n[1] >= kMinSamples;
        MetricResult& mr = out->metrics[m];
        mr.samplesSim = n[0];
        mr.samplesRef = n[1];
        mr.medianSim = histogramMedian(bufS.data(), kRawBins, rawLo[m], rawHi[m], n[0]);
        mr.medianRef = medRef;
        mr.spreadRef = spread;
        mr.scored = scoredMetric[m];
        mr.w1 = (n[0] > 0 && n[1] > 0) ? w1 : std::numeric_limits<double>::quiet_NaN();
        mr.score = mr.scored ? sc.metric[m] : std::numeric_limits<double>::quiet_NaN();
      }
      if (scoredMetric[m]) {
        sum += sc.metric[m];
        ++used;
      }
      if (m < kPaperMetricCount) {
        zsp[m] = zsAll[m].data();
        zrp[m] = zrAll[m].data();
        ns[m] = n[0];
        nr[m] = n[1];
        scoredPaper[m] = scoredMetric[m];
      }
    }
    // correlation functions
    CorrelationSums cs[2];
    for (int k = 0; k < 2; ++k) {
      cs[k].resize(sides[k].corr->lags(), kDistanceBins);
      for (int b : d.blocks[k]) cs[k].add(sides[k].corr->blocks()[static_cast<std::size_t>(b)]);
    }
    const std::vector<double> autoS = ratio(cs[0].autoNum, cs[0].autoDen), autoR = ratio(cs[1].autoNum, cs[1].autoDen);
    std::vector<double> pairS = ratio(cs[0].pairSum, cs[0].pairCount), pairR = ratio(cs[1].pairSum, cs[1].pairCount);
    const double sAuto = curveScore(autoS, autoR, 1), sPair = curveScore(pairS, pairR, 0);
    sc.curve = {sAuto, sPair};
    if (full) {
      scoredCurve = {!std::isnan(sAuto), !std::isnan(sPair)};
      const double dt = r.reference.dt;
      CurveResult a;
      a.name = "autocorrelation";
      a.axis = "lag";
      a.axisUnit = "s";
      for (std::size_t i = 0; i < autoR.size(); ++i) a.x.push_back(static_cast<double>(i) * dt);
      a.sim = autoS;
      a.ref = autoR;
      a.tauSim = correlationTime(autoS, dt);
      a.tauRef = correlationTime(autoR, dt);
      a.scored = scoredCurve[0];
      a.score = sAuto;
      CurveResult p;
      p.name = "velocity_correlation";
      p.axis = "distance";
      p.axisUnit = "l";
      for (int i = 0; i < kDistanceBins; ++i) p.x.push_back((i + 0.5) * kMaxDistance / kDistanceBins);
      p.sim = pairS;
      p.ref = pairR;
      p.scored = scoredCurve[1];
      p.score = sPair;
      out->curves = {a, p};
    }
    for (int c = 0; c < 2; ++c) {
      if (scoredCurve[static_cast<std::size_t>(c)]) {
        sum += sc.curve[static_cast<std::size_t>(c)];
        ++used;
      }
    }
    sc.physical = used > 0 ? sum / used : std::numeric_limits<double>::quiet_NaN();
    const Wang w = wangScore(zsp, zrp, ns, nr, scoredPaper, nbins);
    sc.wang = w.total;
    if (full) {
      out->summary.used = used;
      for (std::size_t m = 0; m < kPaperMetricCount; ++m) {
        out->metrics[m].energy = w.energy[m];
        out->metrics[m].weight = w.weight[m];
      }
    }
    return sc;
  };

  r.metrics.resize(kMetricCount);
  for (std::size_t m = 0; m < kMetricCount; ++m) {
    MetricResult& mr = r.metrics[m];
    mr.name = metricName(static_cast<int>(m));
    mr.unit = metricUnit(static_cast<int>(m));
    mr.paper = m < kPaperMetricCount;
    mr.meanSim = mean[0][m];
    mr.meanRef = mean[1][m];
    mr.stdSim = sd[0][m];
    mr.stdRef = sd[1][m];
    if (mr.paper) {
      mr.edges.resize(nbins + 1);
      for (std::size_t i = 0; i <= nbins; ++i) {
        mr.edges[i] = zLo[m] + (zHi[m] - zLo[m]) * static_cast<double>(i) / static_cast<double>(nbins);
      }
    }
  }
  const Scores est = scoresOf(identity(), true, &r);
  for (std::size_t m = 0; m < kPaperMetricCount; ++m) {
    MetricResult& mr = r.metrics[m];
    mr.pdfSim.assign(nbins, 0.0);
    mr.pdfRef.assign(nbins, 0.0);
    for (std::size_t i = 0; i < nbins; ++i) {
      if (mr.samplesSim > 0) mr.pdfSim[i] = static_cast<double>(zsAll[m][i]) / static_cast<double>(mr.samplesSim);
      if (mr.samplesRef > 0) mr.pdfRef[i] = static_cast<double>(zrAll[m][i]) / static_cast<double>(mr.samplesRef);
    }
  }
  r.summary.physical = est.physical;
  r.summary.wang2015 = est.wang;
  r.total = est.wang;
  for (std::size_t m = 0; m < kMetricCount; ++m) {
    const MetricResult& mr = r.metrics[m];
    if (!mr.scored && (mr.samplesSim > 0 || mr.samplesRef > 0)) {
      r.warnings.push_back("metric " + mr.name + ": too few values to score (" + std::to_string(mr.samplesSim) +
                           " sim, " + std::to_string(mr.samplesRef) + " reference; at least " +
                           std::to_string(kMinSamples) + " each): left out of the scores");
    }
  }
  for (const CurveResult& c : r.curves) {
    if (!c.scored) r.warnings.push_back(c.name + ": no entry defined on both sides: left out of the physical score");
  }

  // block bootstrap
  if (options.bootstrap > 0) {
    const auto R = static_cast<std::size_t>(options.bootstrap);
    std::vector<std::array<double, kMetricCount>> metricReps(R);
    std::vector<std::array<double, 2>> curveReps(R);
    std::vector<double> physReps(R), wangReps(R);
    for (std::size_t rep = 0; rep < R; ++rep) {
      Draw d;
      for (int k = 0; k < 2; ++k) {
        const int B = sides[k].blocks;
        for (int q = 0; q < B; ++q) {
          const auto w = philox4x32({static_cast<std::uint32_t>(rep), static_cast<std::uint32_t>(k),
                                     static_cast<std::uint32_t>(q), 0xB005u},
                                    options.seed);
          d.blocks[k].push_back(static_cast<int>((static_cast<std::uint64_t>(w[0]) * static_cast<std::uint64_t>(B)) >> 32));
        }
      }
      const Scores sc = scoresOf(d, false, nullptr);
      metricReps[rep] = sc.metric;
      curveReps[rep] = sc.curve;
      physReps[rep] = sc.physical;
      wangReps[rep] = sc.wang;
    }
    const auto basic = [&](double x, std::vector<double> reps) {
      Interval iv;
      reps.erase(std::remove_if(reps.begin(), reps.end(), [](double v) { return std::isnan(v); }), reps.end());
      if (reps.empty() || std::isnan(x)) return iv;
      std::sort(reps.begin(), reps.end());
      const auto q = [&](double p) {
        const double pos = p * static_cast<double>(reps.size() - 1);
        const auto i = static_cast<std::size_t>(pos);
        const double f = pos - static_cast<double>(i);
        return i + 1 < reps.size() ? reps[i] * (1 - f) + reps[i + 1] * f : reps[i];
      };
      iv.lo = std::clamp(2 * x - q(0.975), 0.0, 1.0);
      iv.hi = std::clamp(2 * x - q(0.025), 0.0, 1.0);
      iv.valid = true;
      return iv;
    };
    std::vector<double> tmp(R);
    for (std::size_t m = 0; m < kMetricCount; ++m) {
      if (!r.metrics[m].scored) continue;
      for (std::size_t i = 0; i < R; ++i) tmp[i] = metricReps[i][m];
      r.metrics[m].scoreCi = basic(r.metrics[m].score, tmp);
    }
    for (std::size_t c = 0; c < r.curves.size(); ++c) {
      if (!r.curves[c].scored) continue;
      for (std::size_t i = 0; i < R; ++i) tmp[i] = curveReps[i][c];
      r.curves[c].scoreCi = basic(r.curves[c].score, tmp);
    }
    r.summary.physicalCi = basic(r.summary.physical, physReps);
    r.summary.wang2015Ci = basic(r.summary.wang2015, wangReps);
  }

  if (refStats) {
    const Side& ref = sides[1];
    refStats->medianSpeed = r.metrics[kSpeed].medianRef;
    refStats->tau = r.curves.empty() ? std::numeric_limits<double>::quiet_NaN() : r.curves[0].tauRef;
    const double mu = r.metrics[kCentreDistance].meanRef, sg = r.metrics[kCentreDistance].stdRef;
    refStats->extent = std::sqrt(mu * mu + sg * sg);
    for (std::size_t d = 0; d < 3; ++d) {
      refStats->centre[d] = ref.centroidSamples > 0 ? ref.centroid[d] / static_cast<double>(ref.centroidSamples) : 0.0;
    }
    std::vector<std::int64_t> counts = ref.perSample;
    if (!counts.empty()) {
      std::nth_element(counts.begin(), counts.begin() + static_cast<std::ptrdiff_t>(counts.size() / 2), counts.end());
      refStats->count = counts[counts.size() / 2];
    }
    refStats->samples = r.reference.last - r.reference.first;
    refStats->dt = r.reference.dt;
  }
  return r;
}

SourceOptions sideOptions(const SourceOptions& common, const std::optional<FrameRange>& frames) {
  SourceOptions o = common;
  if (frames) o.frames = *frames;
  return o;
}

}  // namespace

EvaluationResult evaluate(const EvaluateOptions& options) {
  if (!(options.simScale > 0.0) || !std::isfinite(options.simScale)) {
    throw InputError("--sim-scale: expected a positive number, got " + std::to_string(options.simScale));
  }
  RefStats stats;
  EvaluationResult r = evaluateSources(openTracks(options.sim, sideOptions(options.source, options.simFrames)),
                                       options.simScale,
                                       openTracks(options.reference, sideOptions(options.source, options.refFrames)),
                                       options, &stats);
  if (options.baseline) {
    BaselineSpec spec;
    spec.count = std::max<std::int64_t>(stats.count, 2);
    spec.samples = stats.samples;
    spec.dt = stats.dt;
    spec.medianSpeed = stats.medianSpeed;
    spec.correlationTime = stats.tau;
    if (!(spec.correlationTime > 0)) {
      spec.correlationTime = kAutoSeconds;
      r.warnings.push_back("baseline: the reference's velocity correlation time is not resolved within " +
                           std::to_string(kAutoSeconds) + " s; the baseline uses that");
    }
    for (std::size_t d = 0; d < 3; ++d) spec.centre[d] = stats.centre[d];
    spec.extent = stats.extent;
    spec.seed = options.seed;
    if (!(spec.extent > 0) || !(spec.medianSpeed > 0)) {
      throw InputError(options.reference + ": --baseline needs a reference with at least two moving individuals per "
                       "sample (its spread about the centre and its median speed match the walkers to it)");
    }
    char buf[512];
    std::snprintf(buf, sizeof buf,
                  "Ornstein-Uhlenbeck walkers: %lld individuals, %lld samples at dt %g s, median speed %.4g m/s, "
                  "correlation time %.4g s, rms distance to the centre %.4g m, seed %llu",
                  static_cast<long long>(spec.count), static_cast<long long>(spec.samples), spec.dt, spec.medianSpeed,
                  spec.correlationTime, spec.extent, static_cast<unsigned long long>(spec.seed));
    r.baselineDescription = buf;
    const EvaluationResult b = evaluateSources(
        makeOuBaseline(spec), 1.0, openTracks(options.reference, sideOptions(options.source, options.refFrames)),
        options, nullptr);
    r.baseline = b.summary;
    for (const MetricResult& m : b.metrics) r.baselineScores[m.name] = {m.scored, m.score, m.scoreCi};
    for (const CurveResult& c : b.curves) r.baselineScores[c.name] = {c.scored, c.score, c.scoreCi};
  }
  return r;
}

namespace {
nlohmann::json num(double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); }
nlohmann::json ci(const Interval& iv) {
  return iv.valid ? nlohmann::json::array({iv.lo, iv.hi}) : nlohmann::json(nullptr);
}
nlohmann::json nums(const std::vector<double>& xs) {
  nlohmann::json a = nlohmann::json::array();
  for (double x : xs) a.push_back(num(x));
  return a;
}
nlohmann::json summaryJson(const ScoreSummary& s) {
  return {{"physical", num(s.physical)},
          {"physical_ci", ci(s.physicalCi)},
          {"physical_terms", s.used},
          {"wang2015", num(s.wang2015)},
          {"wang2015_ci", ci(s.wang2015Ci)}};
}
std::string ciText(const Interval& iv) {
  if (!iv.valid) return "";
  char buf[64];
  std::snprintf(buf, sizeof buf, "[%.3f, %.3f]", iv.lo, iv.hi);
  return buf;
}
}  // namespace

nlohmann::json EvaluationResult::toJson() const {
  const auto side = [](const TrackInfo& t) {
    return nlohmann::json{{"file", t.file},
                          {"swarm", t.swarm.empty() ? nlohmann::json(nullptr) : nlohmann::json(t.swarm)},
                          {"dt", t.dt},
                          {"individuals", t.individuals},
                          {"samples", {t.first, t.last}}};
  };
  nlohmann::json j;
  j["sim"] = side(sim);
  j["reference"] = side(reference);
  j["bins"] = bins;
  j["bootstrap"] = {{"replicates", replicates},
                    {"blocks_sim", blocksSim},
                    {"blocks_ref", blocksRef},
                    {"seed", seed},
                    {"interval", replicates > 0 ? "basic bootstrap, 95 %" : "none"}};
  j["metrics"] = nlohmann::json::array();
  for (const auto& m : metrics) {
    nlohmann::json e = {{"name", m.name},
                        {"unit", m.unit},
                        {"paper", m.paper},
                        {"samples_sim", m.samplesSim},
                        {"samples_ref", m.samplesRef},
                        {"median_sim", num(m.medianSim)},
                        {"median_ref", num(m.medianRef)},
                        {"w1", num(m.w1)},
                        {"spread_ref", num(m.spreadRef)},
                        {"scored", m.scored},
                        {"score", m.scored ? num(m.score) : nlohmann::json(nullptr)},
                        {"score_ci", ci(m.scoreCi)}};
    if (m.paper) {
      e["energy"] = num(m.energy);
      e["weight"] = m.weight;
      e["edges"] = m.edges;
      e["pdf_sim"] = m.pdfSim;
      e["pdf_ref"] = m.pdfRef;
    }
    j["metrics"].push_back(e);
  }
  j["curves"] = nlohmann::json::array();
  for (const auto& c : curves) {
    nlohmann::json e = {{"name", c.name},  {"axis", c.axis},      {"axis_unit", c.axisUnit}, {"x", c.x},
                        {"sim", nums(c.sim)}, {"ref", nums(c.ref)}, {"scored", c.scored},
                        {"score", c.scored ? num(c.score) : nlohmann::json(nullptr)}, {"score_ci", ci(c.scoreCi)}};
    if (c.name == "autocorrelation") {
      e["tau_sim"] = num(c.tauSim);
      e["tau_ref"] = num(c.tauRef);
    }
    j["curves"].push_back(e);
  }
  j["scores"] = summaryJson(summary);
  j["total"] = total;
  if (baseline) {
    j["baseline"] = summaryJson(*baseline);
    j["baseline"]["model"] = baselineDescription;
    nlohmann::json scores = nlohmann::json::object();
    for (const auto& [name, v] : baselineScores) {
      scores[name] = {{"score", v.scored ? num(v.score) : nlohmann::json(nullptr)}, {"score_ci", ci(v.ci)}};
    }
    j["baseline"]["scores"] = scores;
  }
  j["warnings"] = warnings;
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
  std::snprintf(buf, sizeof buf, "%-7s %-8s %10s %10s %11s %11s %11s %11s %7s %-16s %7s %7s\n", "metric", "unit",
                "n_sim", "n_ref", "median_sim", "median_ref", "W1", "spread_ref", "score", "95% interval", "E_phi",
                "weight");
  out << buf;
  for (const auto& m : metrics) {
    std::snprintf(buf, sizeof buf, "%-7s %-8s %10lld %10lld %11.5g %11.5g %11.5g %11.5g ", m.name.c_str(),
                  m.unit.c_str(), static_cast<long long>(m.samplesSim), static_cast<long long>(m.samplesRef),
                  m.medianSim, m.medianRef, m.w1, m.spreadRef);
    out << buf;
    if (m.scored) {
      std::snprintf(buf, sizeof buf, "%7.3f %-16s ", m.score, ciText(m.scoreCi).c_str());
    } else {
      std::snprintf(buf, sizeof buf, "%7s %-16s ", "-", "(too few)");
    }
    out << buf;
    if (m.paper) {
      std::snprintf(buf, sizeof buf, "%7.4f %7.4f\n", m.energy, m.weight);
    } else {
      std::snprintf(buf, sizeof buf, "%7s %7s\n", "", "");
    }
    out << buf;
  }
  for (const auto& c : curves) {
    std::snprintf(buf, sizeof buf, "%-26s over %-8s ", c.name.c_str(), c.axis.c_str());
    out << buf;
    if (c.scored) {
      std::snprintf(buf, sizeof buf, "score %.3f %s", c.score, ciText(c.scoreCi).c_str());
    } else {
      std::snprintf(buf, sizeof buf, "score -");
    }
    out << buf;
    if (c.name == "autocorrelation") {
      std::snprintf(buf, sizeof buf, "   tau_c sim %.3g s, reference %.3g s", c.tauSim, c.tauRef);
      out << buf;
    }
    out << "\n";
  }
  const auto summaryLine = [&](const char* label, const ScoreSummary& s) {
    std::snprintf(buf, sizeof buf, "%s physical score S = %.4f %s (%d terms); wang2015 E = %.4f %s\n", label,
                  s.physical, ciText(s.physicalCi).c_str(), s.used, s.wang2015, ciText(s.wang2015Ci).c_str());
    out << buf;
  };
  summaryLine("sim:     ", summary);
  if (baseline) {
    summaryLine("baseline:", *baseline);
    out << "baseline: " << baselineDescription << "\n";
  }
  if (replicates > 0) {
    std::snprintf(buf, sizeof buf,
                  "(95%% basic bootstrap intervals: %d replicates of %d and %d time blocks, seed %llu; S: 1 = the "
                  "same distributions in physical units; E: %d z-score bins)\n",
                  replicates, blocksSim, blocksRef, static_cast<unsigned long long>(seed), bins);
  } else {
    std::snprintf(buf, sizeof buf, "(no intervals: --bootstrap 0; E: %d z-score bins)\n", bins);
  }
  out << buf;
}

void runEvaluate(const EvaluateOptions& options, std::ostream& out, std::ostream& err) {
  const EvaluationResult r = evaluate(options);
  for (const auto& w : r.warnings) err << "swarmsim: warning: " << w << "\n";
  if (options.json) {
    out << r.toJson().dump(2) << "\n";
  } else {
    r.printTable(out);
  }
}

}  // namespace swarmsim::eval
