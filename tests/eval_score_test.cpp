// The physical score of `swarmsim evaluate` (issue 13): distances against hand-worked values, collective
// metrics and correlation functions on constructed swarms, the bootstrap, the baseline, and the real data.
#include <array>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "eval/correlations.hpp"
#include "eval/metrics.hpp"
#include "eval/score.hpp"
#include "eval/tracks.hpp"
#include "test_util.hpp"

using namespace swarmsim::eval;
using swarmsim_test::TempDir;
using swarmsim_test::writeText;

namespace {

// a CSV with recorded velocities: rows (id, k, x, y, z, vx, vy, vz) at dt
struct Row {
  int id;
  int k;
  double p[3], v[3];
};
std::string csvOf(const std::vector<Row>& rows, double dt) {
  std::string s = "id,time,x,y,z,vx,vy,vz\n";
  char buf[320];
  for (const Row& r : rows) {
    std::snprintf(buf, sizeof buf, "%d,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g\n", r.id, dt * r.k, r.p[0], r.p[1],
                  r.p[2], r.v[0], r.v[1], r.v[2]);
    s += buf;
  }
  return s;
}

FrameValues collectFile(const std::string& path) {
  auto src = openTracks(path, {});
  FrameValues all;
  computeMetrics(*src, 1.0, [&](const FrameValues& v, const SampleView&) {
    for (std::size_t m = 0; m < kMetricCount; ++m) all[m].insert(all[m].end(), v[m].begin(), v[m].end());
  });
  return all;
}

EvaluationResult evalPair(const std::string& sim, const std::string& ref, int bootstrap = 0, bool baseline = false) {
  EvaluateOptions o;
  o.sim = sim;
  o.reference = ref;
  o.bootstrap = bootstrap;
  o.baseline = baseline;
  return evaluate(o);
}

}  // namespace

TEST_CASE("physical score: W1, spread and score against hand-worked values", "[eval][physical]") {
  // two bins over [0, 2]; mass uniform inside each bin
  const std::int64_t a[2] = {1, 0};  // uniform on [0, 1]
  const std::int64_t b[2] = {0, 1};  // uniform on [1, 2]
  const std::int64_t c[2] = {1, 1};  // uniform on [0, 2]
  // a shift by 1: W1 = 1
  CHECK(histogramW1(a, 1, b, 1, 2, 0.0, 2.0) == Approx(1.0).epsilon(1e-12));
  // [0,1] against [0,2]: the CDFs differ by x/2 on [0,1] and by 1 - x/2 on [1,2]: W1 = 1/4 + 1/4 = 1/2
  CHECK(histogramW1(a, 1, c, 2, 2, 0.0, 2.0) == Approx(0.5).epsilon(1e-12));
  CHECK(histogramW1(c, 2, c, 2, 2, 0.0, 2.0) == 0.0);
  // medians: 1.5 of [1, 2], 1 of [0, 2]
  CHECK(histogramMedian(b, 2, 0.0, 2.0, 1) == Approx(1.5));
  CHECK(histogramMedian(c, 2, 0.0, 2.0, 2) == Approx(1.0));
  // mean absolute deviation about the median: uniform on [1, 2] about 1.5 is 1/4; [0, 2] about 1 is 1/2
  CHECK(histogramSpread(b, 2, 0.0, 2.0, 1, 1.5) == Approx(0.25).epsilon(1e-12));
  CHECK(histogramSpread(c, 2, 0.0, 2.0, 2, 1.0) == Approx(0.5).epsilon(1e-12));
  // s = exp(-W1 / spread): [0,1] scored against the reference [1,2]: exp(-1 / 0.25)
  CHECK(physicalScore(1.0, 0.25) == Approx(std::exp(-4.0)));
  CHECK(physicalScore(0.0, 0.0) == 1.0);
  CHECK(physicalScore(0.1, 0.0) == 0.0);
  // curves: 1 - mean |a - b| / 2 over entries defined on both, from index 1
  const double nan = std::nan("");
  CHECK(curveScore({1.0, 0.5, 0.2, nan}, {1.0, 0.3, 0.6, 0.1}, 1) == Approx(1.0 - (0.2 + 0.4) / 2 / 2));
  CHECK(std::isnan(curveScore({1.0, nan}, {1.0, 0.3}, 1)));
}

TEST_CASE("collective metrics: translation gives polarisation 1, rotation milling 1, independence about 0",
          "[eval][physical]") {
  TempDir dir;
  std::mt19937 gen(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const int n = 40, frames = 30;
  const double dt = 0.02;
  // a rigid group translating at (0.3, -0.2, 0.1) m/s
  std::vector<Row> trans;
  std::vector<std::array<double, 3>> offset(n);
  for (auto& o : offset) o = {u(gen), u(gen), u(gen)};
  for (int k = 0; k < frames; ++k) {
    for (int i = 0; i < n; ++i) {
      const double t = k * dt;
      trans.push_back({i, k, {offset[i][0] + 0.3 * t, offset[i][1] - 0.2 * t, offset[i][2] + 0.1 * t}, {0.3, -0.2, 0.1}});
    }
  }
  // a rigid disc turning about its centroid (the origin: individual i + n/2 is i's mirror) at 1.5 rad/s: v = w x r
  std::vector<Row> rot;
  for (int k = 0; k < frames; ++k) {
    for (int i = 0; i < n; ++i) {
      const int j = i % (n / 2);
      const double r = 0.2 + 0.8 * (j + 0.5) / n, a = 2.0 * M_PI * j / n * 7.0 + (i < n / 2 ? 0.0 : M_PI) + 1.5 * k * dt;
      rot.push_back({i, k, {r * std::cos(a), r * std::sin(a), 0.0}, {-1.5 * r * std::sin(a), 1.5 * r * std::cos(a), 0.0}});
    }
  }
  // independent walkers: random directions every sample
  std::vector<Row> indep;
  for (int k = 0; k < frames; ++k) {
    for (int i = 0; i < n; ++i) {
      indep.push_back({i, k, {3 * u(gen), 3 * u(gen), 3 * u(gen)}, {u(gen), u(gen), u(gen)}});
    }
  }
  writeText(dir.file("trans.csv"), csvOf(trans, dt));
  writeText(dir.file("rot.csv"), csvOf(rot, dt));
  writeText(dir.file("indep.csv"), csvOf(indep, dt));

  const FrameValues t = collectFile(dir.file("trans.csv"));
  REQUIRE(t[kPolarisation].size() > 20u);
  for (double p : t[kPolarisation]) CHECK(p == Approx(1.0).epsilon(1e-12));
  const FrameValues r = collectFile(dir.file("rot.csv"));
  REQUIRE(r[kMilling].size() > 20u);
  for (double m : r[kMilling]) CHECK(m == Approx(1.0).epsilon(1e-9));
  for (double p : r[kPolarisation]) CHECK(p < 0.2);  // every direction of the circle: little net heading
  const FrameValues w = collectFile(dir.file("indep.csv"));
  REQUIRE(w[kPolarisation].size() > 20u);
  double meanP = 0, meanM = 0;
  for (double p : w[kPolarisation]) meanP += p / static_cast<double>(w[kPolarisation].size());
  for (double m : w[kMilling]) meanM += m / static_cast<double>(w[kMilling].size());
  // about n^-1/2 = 0.16 for independent directions
  CHECK(meanP < 0.3);
  CHECK(meanM < 0.3);
  CHECK(meanP > 0.05);

  // distance to the centre and d_rel: the translating group keeps its shape, so r_c and d_rel repeat every
  // sample; d_rel is scale-free (the same group twice as large gives the same d_rel)
  std::vector<Row> big = trans;
  for (Row& q : big) {
    for (double& c : q.p) c *= 2.0;
  }
  writeText(dir.file("big.csv"), csvOf(big, dt));
  const FrameValues tb = collectFile(dir.file("big.csv"));
  REQUIRE(tb[kRelNnDistance].size() == t[kRelNnDistance].size());
  for (std::size_t i = 0; i < t[kRelNnDistance].size(); ++i) {
    CHECK(tb[kRelNnDistance][i] == Approx(t[kRelNnDistance][i]).epsilon(1e-9));
    CHECK(tb[kCentreDistance][i] == Approx(2.0 * t[kCentreDistance][i]).epsilon(1e-9));
  }
}

TEST_CASE("correlation functions: constant fluctuations correlate at every lag, independent ones do not",
          "[eval][physical]") {
  TempDir dir;
  std::mt19937 gen(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const int n = 30, frames = 200;
  const double dt = 0.02;
  // each individual flies its own constant velocity (the mean over individuals is subtracted per sample)
  std::vector<std::array<double, 3>> vel(n), pos0(n);
  for (int i = 0; i < n; ++i) {
    vel[i] = {u(gen), u(gen), u(gen)};
    pos0[i] = {u(gen), u(gen), u(gen)};
  }
  std::vector<Row> steady, noisy;
  for (int k = 0; k < frames; ++k) {
    for (int i = 0; i < n; ++i) {
      const double t = k * dt;
      steady.push_back({i, k, {pos0[i][0] + vel[i][0] * t, pos0[i][1] + vel[i][1] * t, pos0[i][2] + vel[i][2] * t},
                        {vel[i][0], vel[i][1], vel[i][2]}});
      noisy.push_back({i, k, {u(gen), u(gen), u(gen)}, {u(gen), u(gen), u(gen)}});
    }
  }
  for (auto* rows : {&steady, &noisy}) {
    const std::string f = dir.file(rows == &steady ? "steady.csv" : "noisy.csv");
    writeText(f, csvOf(*rows, dt));
    auto src = openTracks(f, {});
    CorrelationAccumulator acc(dt, src->info().first, src->info().last, 4);
    computeMetrics(*src, 1.0, [&](const FrameValues&, const SampleView& s) { acc.add(s); });
    CorrelationSums sum;
    sum.resize(acc.lags(), kDistanceBins);
    for (const auto& b : acc.blocks()) sum.add(b);
    const std::vector<double> c = ratio(sum.autoNum, sum.autoDen);
    REQUIRE(static_cast<int>(c.size()) == acc.lags() + 1);
    CHECK(acc.lags() == 100);  // 2 s at 0.02 s
    CHECK(c[0] == Approx(1.0));
    if (rows == &steady) {
      for (double x : c) CHECK(x == Approx(1.0).epsilon(1e-9));
      CHECK(std::isnan(correlationTime(c, dt)));  // never drops below 1/e
    } else {
      for (std::size_t lag = 1; lag < c.size(); ++lag) CHECK(std::abs(c[lag]) < 0.15);
      CHECK(correlationTime(c, dt) < dt);  // below 1/e at the first lag
      const std::vector<double> cr = ratio(sum.pairSum, sum.pairCount);
      for (double x : cr) {
        if (!std::isnan(x)) CHECK(std::abs(x) < 0.2);
      }
    }
  }
}

TEST_CASE("bootstrap: a data set against itself scores 1 with an interval that holds 1; a shifted copy less",
          "[eval][physical]") {
  TempDir dir;
  std::mt19937 gen(3);
  std::normal_distribution<double> g(0.0, 1.0);
  const int n = 12, frames = 300;
  const double dt = 0.02;
  std::vector<Row> rows, fast;
  std::vector<std::array<double, 3>> p(n), v(n);
  for (int i = 0; i < n; ++i) {
    p[i] = {g(gen), g(gen), g(gen)};
    v[i] = {0.3 * g(gen), 0.3 * g(gen), 0.3 * g(gen)};
  }
  for (int k = 0; k < frames; ++k) {
    for (int i = 0; i < n; ++i) {
      for (int d = 0; d < 3; ++d) {
        v[i][d] = 0.9 * v[i][d] - 0.05 * p[i][d] + 0.1 * g(gen);
        p[i][d] += v[i][d] * dt;
      }
      rows.push_back({i, k, {p[i][0], p[i][1], p[i][2]}, {v[i][0], v[i][1], v[i][2]}});
      fast.push_back({i, k, {p[i][0], p[i][1], p[i][2]}, {2 * v[i][0], 2 * v[i][1], 2 * v[i][2]}});
    }
  }
  writeText(dir.file("a.csv"), csvOf(rows, dt));
  writeText(dir.file("fast.csv"), csvOf(fast, dt));
  const auto self = evalPair(dir.file("a.csv"), dir.file("a.csv"), 100);
  CHECK(self.summary.physical == 1.0);
  REQUIRE(self.summary.physicalCi.valid);
  CHECK(self.summary.physicalCi.lo <= 1.0);
  CHECK(self.summary.physicalCi.hi == 1.0);
  for (const auto& m : self.metrics) {
    INFO(m.name);
    if (!m.scored) continue;
    CHECK(m.scoreCi.hi == 1.0);
  }
  // velocities doubled: speed's score falls far below 1 and its interval stays below 1
  const auto other = evalPair(dir.file("fast.csv"), dir.file("a.csv"), 100);
  const auto& sp = other.metrics[kSpeed];
  CHECK(sp.score < 0.5);
  REQUIRE(sp.scoreCi.valid);
  CHECK(sp.scoreCi.hi < 0.7);
  CHECK(other.summary.physical < self.summary.physical);
  // the bootstrap is reproducible for a seed
  const auto again = evalPair(dir.file("fast.csv"), dir.file("a.csv"), 100);
  CHECK(again.summary.physicalCi.lo == other.summary.physicalCi.lo);
  CHECK(again.summary.physicalCi.hi == other.summary.physicalCi.hi);
}

TEST_CASE("evaluate: too few values mark a metric unscored with a warning", "[eval][physical]") {
  TempDir dir;
  // 2 individuals, 10 samples: pol and mill need 3 moving individuals, so they have no values
  std::vector<Row> rows;
  for (int k = 0; k < 10; ++k) {
    for (int i = 0; i < 2; ++i) rows.push_back({i, k, {0.1 * k + i, 0.0, 0.0}, {0.1 / 0.02, 0.0, 0.0}});
  }
  writeText(dir.file("small.csv"), csvOf(rows, 0.02));
  const auto r = evalPair(dir.file("small.csv"), dir.file("small.csv"));
  for (const auto& m : r.metrics) {
    INFO(m.name);
    CHECK_FALSE(m.scored);  // at most 20 values each: under 30
  }
  CHECK_FALSE(r.warnings.empty());
  bool named = false;
  for (const auto& w : r.warnings) named = named || w.find("metric v: too few values") != std::string::npos;
  CHECK(named);
}

TEST_CASE("evaluate on the real mosquitoes: one half against the other lands clearly above the OU baseline",
          "[eval][physical][real]") {
  const std::string ref = std::string(SWARMSIM_SOURCE_DIR) + "/../shared/data/real/anopheles_swarm_moustic/tracks.csv";
  if (!std::filesystem::exists(ref)) {
    WARN("skipped: " << ref << " is not there");
    return;
  }
  EvaluateOptions o;
  o.sim = o.reference = ref;
  o.simFrames = FrameRange::parse(":1000");
  o.refFrames = FrameRange::parse("1000:");
  o.bootstrap = 200;
  o.baseline = true;
  const EvaluationResult r = evaluate(o);
  REQUIRE(r.baseline.has_value());
  INFO("real halves S " << r.summary.physical << " [" << r.summary.physicalCi.lo << ", " << r.summary.physicalCi.hi
                        << "], baseline S " << r.baseline->physical << " [" << r.baseline->physicalCi.lo << ", "
                        << r.baseline->physicalCi.hi << "]");
  CHECK(r.summary.used == 13);
  CHECK(r.summary.physicalCi.lo > r.baseline->physicalCi.hi);  // intervals that do not overlap
  CHECK(r.summary.physical > 0.75);
  CHECK(r.baseline->physical < 0.6);
}
