// The Ornstein-Uhlenbeck baseline swarm of swarmsim evaluate (eval/baseline.hpp):
// its statistics match the spec, its frames are a pure function of the spec, bad
// specs are refused naming the field.
#include "eval/baseline.hpp"

#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "core/parallel.hpp"
#include "eval/tracks.hpp"
#include "test_util.hpp"

using namespace swarmsim::eval;
using swarmsim_test::inputErrorOf;

namespace {

BaselineSpec referenceLikeSpec() {
  BaselineSpec s;
  s.count = 200;
  s.samples = 3000;
  s.dt = 0.02;
  s.medianSpeed = 0.47;
  s.correlationTime = 0.25;
  s.centre = {1.0, -2.0, 0.5};
  s.extent = 0.3;
  s.seed = 20240611;
  return s;
}

BaselineSpec smallSpec(std::uint64_t seed = 7) {
  BaselineSpec s = referenceLikeSpec();
  s.count = 30;
  s.samples = 200;
  s.seed = seed;
  return s;
}


// every frame of one pass over [first, last)
std::vector<Frame> readAll(TrackSource& src, std::int64_t first, std::int64_t last) {
  std::vector<Frame> frames(static_cast<std::size_t>(last - first));
  for (std::int64_t k = first; k < last; ++k) src.read(k, frames[static_cast<std::size_t>(k - first)]);
  return frames;
}

bool sameFrame(const Frame& a, const Frame& b) {
  return a.sample == b.sample && a.dense == b.dense && a.id == b.id && a.pos == b.pos && a.vel == b.vel;
}

// first lag (s) where the normalised autocorrelation drops below 1/e, linearly interpolated
double oneOverETime(const std::vector<double>& c, double dt) {
  const double target = std::exp(-1.0);
  for (std::size_t lag = 1; lag < c.size(); ++lag) {
    if (c[lag] < target) {
      const double c0 = c[lag - 1], c1 = c[lag];
      return dt * (static_cast<double>(lag - 1) + (c0 - target) / (c0 - c1));
    }
  }
  return std::numeric_limits<double>::infinity();
}

}  // namespace

TEST_CASE("baseline: the Maxwell median factor solves the chi-3 median", "[baseline]") {
  const double m = maxwellMedianFactor();
  CHECK(m == Approx(1.5381722544550522).epsilon(1e-13));
  const double cdf =
      std::erf(m / std::sqrt(2.0)) - std::sqrt(2.0 / 3.14159265358979323846) * m * std::exp(-0.5 * m * m);
  CHECK(cdf == Approx(0.5).margin(1e-14));
}

TEST_CASE("baseline: info and frame layout", "[baseline]") {
  const BaselineSpec spec = smallSpec();
  auto src = makeOuBaseline(spec);
  const TrackInfo& info = src->info();
  CHECK(info.file == "baseline (Ornstein-Uhlenbeck)");
  CHECK(info.kind == "baseline");
  CHECK(info.dt == spec.dt);
  CHECK(info.individuals == spec.count);
  CHECK(info.hasVelocity);
  CHECK(info.first == 0);
  CHECK(info.last == spec.samples);
  Frame f;
  for (std::int64_t k : {std::int64_t{0}, std::int64_t{1}, spec.samples - 1}) {
    src->read(k, f);
    CHECK(f.sample == k);
    CHECK(f.dense);
    REQUIRE(f.size() == static_cast<std::size_t>(spec.count));
    REQUIRE(f.pos.size() == 3 * f.size());
    REQUIRE(f.vel.size() == 3 * f.size());
    for (std::size_t i = 0; i < f.size(); ++i) CHECK(f.id[i] == static_cast<std::int64_t>(i));
    CHECK(f.find(spec.count - 1) == static_cast<std::ptrdiff_t>(spec.count - 1));
    CHECK(std::all_of(f.pos.begin(), f.pos.end(), [](double v) { return std::isfinite(v); }));
    CHECK(std::all_of(f.vel.begin(), f.vel.end(), [](double v) { return std::isfinite(v); }));
  }
}

TEST_CASE("baseline: median speed, extent and correlation time match the spec", "[baseline]") {
  const BaselineSpec spec = referenceLikeSpec();
  auto src = makeOuBaseline(spec);
  const auto n = static_cast<std::size_t>(spec.count);
  const auto samples = static_cast<std::size_t>(spec.samples);
  std::vector<double> speeds;
  speeds.reserve(n * samples);
  std::vector<double> vel(samples * n * 3);  // [sample][individual][axis]
  double sumR2 = 0.0;
  Frame f;
  for (std::size_t k = 0; k < samples; ++k) {
    src->read(static_cast<std::int64_t>(k), f);
    REQUIRE(f.size() == n);
    for (std::size_t i = 0; i < n; ++i) {
      double v2 = 0.0;
      for (std::size_t c = 0; c < 3; ++c) {
        const double d = f.pos[3 * i + c] - spec.centre[c];
        sumR2 += d * d;
        v2 += f.vel[3 * i + c] * f.vel[3 * i + c];
      }
      speeds.push_back(std::sqrt(v2));
    }
    std::copy(f.vel.begin(), f.vel.end(), vel.begin() + static_cast<std::ptrdiff_t>(k * n * 3));
  }

  // median speed (the lower middle of an even count; 600,000 speeds)
  auto mid = speeds.begin() + static_cast<std::ptrdiff_t>(speeds.size() / 2);
  std::nth_element(speeds.begin(), mid, speeds.end());
  const double medianSpeed = *mid;
  CHECK(medianSpeed == Approx(spec.medianSpeed).epsilon(0.03));

  // root-mean-square distance to the centre
  const double rms = std::sqrt(sumR2 / static_cast<double>(n * samples));
  CHECK(rms == Approx(spec.extent).epsilon(0.10));

  // C(lag) = sum v(t).v(t+lag) / sum v(t).v(t), over the same t, all individuals
  const std::size_t maxLag = 75;  // 1.5 s = 6 tau
  std::vector<double> c(maxLag + 1);
  for (std::size_t lag = 0; lag <= maxLag; ++lag) {
    double num = 0.0, den = 0.0;
    for (std::size_t t = 0; t + lag < samples; ++t) {
      const double* a = &vel[t * n * 3];
      const double* b = &vel[(t + lag) * n * 3];
      for (std::size_t j = 0; j < n * 3; ++j) {
        num += a[j] * b[j];
        den += a[j] * a[j];
      }
    }
    c[lag] = num / den;
  }
  const double tauMeasured = oneOverETime(c, spec.dt);
  CHECK(tauMeasured == Approx(spec.correlationTime).epsilon(0.15));

  // the spring bends C away from exp(-t/tau) (baseline.hpp): the 1/e time of the
  // continuous process's exact C(t) = exp(-t/2tau) [cosh wt - sinh(wt)/(2 w tau)]
  const double s = spec.medianSpeed / maxwellMedianFactor();
  const double kappa = s * s / (spec.extent * spec.extent / 3.0);
  const double tau = spec.correlationTime;
  REQUIRE(kappa * tau * tau < 0.25);  // overdamped for this spec
  const double w = std::sqrt(1.0 / (4.0 * tau * tau) - kappa);
  const auto exact = [&](double t) {
    return std::exp(-t / (2.0 * tau)) * (std::cosh(w * t) - std::sinh(w * t) / (2.0 * w * tau));
  };
  double lo = 0.0, hi = tau;  // exact(0) = 1, exact(tau) < exp(-1)
  for (int it = 0; it < 100; ++it) (exact(0.5 * (lo + hi)) > std::exp(-1.0) ? lo : hi) = 0.5 * (lo + hi);
  const double tauPredicted = 0.5 * (lo + hi);
  CHECK(tauPredicted == Approx(0.2224).epsilon(0.002));  // the -11 % of baseline.hpp
  CHECK(tauMeasured == Approx(tauPredicted).epsilon(0.03));
  // past the 1/e time the spring pulls C below zero (bounded positions)
  CHECK(*std::min_element(c.begin(), c.end()) < 0.0);
}

TEST_CASE("baseline: frames are a pure function of the spec", "[baseline]") {
  const BaselineSpec spec = smallSpec();
  auto a = makeOuBaseline(spec);
  auto b = makeOuBaseline(spec);
  const auto passA = readAll(*a, 0, spec.samples);
  const auto passB = readAll(*b, 0, spec.samples);
  for (std::size_t k = 0; k < passA.size(); ++k) REQUIRE(sameFrame(passA[k], passB[k]));

  SECTION("a second pass restarts from sample 0 with the same frames") {
    const auto again = readAll(*a, 0, 101);  // a is at the last sample: goes back
    for (std::size_t k = 0; k < again.size(); ++k) REQUIRE(sameFrame(again[k], passA[k]));
    const auto part = readAll(*b, 40, 60);  // back from the end to the middle
    for (std::size_t k = 0; k < part.size(); ++k) REQUIRE(sameFrame(part[k], passA[k + 40]));
    Frame f;
    b->read(100, f);
    b->read(0, f);  // sample 0 again after sample 100
    CHECK(sameFrame(f, passA[0]));
  }
  SECTION("skipping samples gives the same frames as reading every one") {
    auto c = makeOuBaseline(spec);
    Frame f;
    for (std::int64_t k : {3, 50, 51, 199}) {
      c->read(k, f);
      CHECK(sameFrame(f, passA[static_cast<std::size_t>(k)]));
    }
  }
  SECTION("another seed gives other positions") {
    auto other = makeOuBaseline(smallSpec(8));
    const auto passO = readAll(*other, 0, spec.samples);
    std::size_t equal = 0;  // coordinates equal in both
    for (std::size_t k = 0; k < passA.size(); ++k) {
      for (std::size_t j = 0; j < passA[k].pos.size(); ++j) equal += passO[k].pos[j] == passA[k].pos[j] ? 1 : 0;
    }
    CHECK(equal == 0);
  }
}

TEST_CASE("baseline: frames do not depend on the thread count", "[baseline]") {
  struct ThreadGuard {
    int saved = swarmsim::threadCount();
    ~ThreadGuard() { swarmsim::setThreadCount(saved); }
  } guard;
  BaselineSpec spec = smallSpec();
  spec.count = 3000;  // above kSerialBelow: parallelFor uses the team
  spec.samples = 12;
  std::vector<std::vector<Frame>> runs;
  for (int t : {1, 2}) {
    swarmsim::setThreadCount(t);
    auto src = makeOuBaseline(spec);
    runs.push_back(readAll(*src, 0, spec.samples));
  }
  for (std::size_t k = 0; k < runs[0].size(); ++k) REQUIRE(sameFrame(runs[0][k], runs[1][k]));
}

TEST_CASE("baseline: bad specs are refused naming the field", "[baseline]") {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  const auto refused = [](BaselineSpec spec, const std::string& field) {
    const std::string msg = inputErrorOf([&] { makeOuBaseline(spec); });
    INFO(msg);
    CHECK(msg.find("baseline spec: " + field) != std::string::npos);
  };
  BaselineSpec s = smallSpec();
  REQUIRE_NOTHROW(makeOuBaseline(s));

  s = smallSpec(), s.count = 0, refused(s, "count");
  s = smallSpec(), s.count = -3, refused(s, "count");
  s = smallSpec(), s.samples = 0, refused(s, "samples");
  s = smallSpec(), s.dt = 0.0, refused(s, "dt");
  s = smallSpec(), s.dt = -0.02, refused(s, "dt");
  s = smallSpec(), s.dt = nan, refused(s, "dt");
  s = smallSpec(), s.medianSpeed = -0.47, refused(s, "medianSpeed");
  s = smallSpec(), s.medianSpeed = 0.0, refused(s, "medianSpeed");
  s = smallSpec(), s.correlationTime = 0.0, refused(s, "correlationTime");
  s = smallSpec(), s.correlationTime = inf, refused(s, "correlationTime");
  s = smallSpec(), s.extent = nan, refused(s, "extent");
  s = smallSpec(), s.extent = -1.0, refused(s, "extent");
  s = smallSpec(), s.centre[1] = inf, refused(s, "centre[1]");
  // a walker crossing the whole swarm in one sample: the spring step would diverge
  s = smallSpec(), s.dt = 2.0, refused(s, "dt");
}
