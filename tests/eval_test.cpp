// swarmsim evaluate: track loading, the seven metrics, the scores.
#include <array>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "core/parallel.hpp"
#include "eval/metrics.hpp"
#include "eval/score.hpp"
#include "eval/tracks.hpp"
#include "io/scenario.hpp"
#include "run.hpp"
#include "test_util.hpp"

using namespace swarmsim::eval;
using swarmsim_test::inputErrorOf;
using swarmsim_test::TempDir;
using swarmsim_test::writeText;

namespace {

struct Sample {
  long long k;
  double p[3];
};
using Tracks = std::map<std::string, std::vector<Sample>>;

// four smooth, different tracks of 80 samples with gaps, an entry and an exit
Tracks syntheticTracks() {
  Tracks t;
  for (int i = 0; i < 4; ++i) {
    const double r = 0.3 + 0.1 * i, w = 2.0 + 0.7 * i, c = 0.2 * i;
    auto& s = t["ind" + std::to_string(i)];
    for (long long k = 0; k < 80; ++k) {
      if (i == 1 && k >= 30 && k < 33) continue;    // a gap of 3 samples
      if (i == 2 && k == 50) continue;              // a gap of 1 sample
      if (i == 3 && (k < 10 || k >= 65)) continue;  // enters late, leaves early
      const double tt = 0.02 * static_cast<double>(k);
      s.push_back(
          {k, {c + r * std::cos(w * tt), 0.5 * c + r * std::sin(w * tt), 1.0 + 0.2 * std::sin(0.5 * w * tt + c)}});
    }
  }
  return t;
}

std::string toCsv(const Tracks& t, double dt, const char* delim = ",") {
  std::string s = std::string("id") + delim + "time" + delim + "x" + delim + "y" + delim + "z\n";
  char buf[256];
  for (const auto& [id, samples] : t) {
    for (const auto& q : samples) {
      std::snprintf(buf, sizeof buf, "%s%s%.17g%s%.17g%s%.17g%s%.17g\n", id.c_str(), delim,
                    dt * static_cast<double>(q.k), delim, q.p[0], delim, q.p[1], delim, q.p[2]);
      s += buf;
    }
  }
  return s;
}


EvaluationResult evalFiles(const std::string& sim, const std::string& ref, const std::string& frames = "",
                           double scale = 1.0) {
  EvaluateOptions o;
  o.sim = sim;
  o.reference = ref;
  o.simScale = scale;
  if (!frames.empty()) o.source.frames = FrameRange::parse(frames);
  return evaluate(o);
}

// all values of every metric over one pass
FrameValues collect(const std::string& path, const SourceOptions& so = {}) {
  auto src = openTracks(path, so);
  FrameValues all;
  computeMetrics(*src, 1.0, [&](const FrameValues& v, const SampleView&) {
    for (std::size_t m = 0; m < kMetricCount; ++m) all[m].insert(all[m].end(), v[m].begin(), v[m].end());
  });
  return all;
}

void checkIdentical(const EvaluationResult& r) {
  CHECK(std::abs(r.total - 1.0) < 1e-12);
  for (const auto& m : r.metrics) {
    INFO(m.name);
    CHECK(m.samplesSim == m.samplesRef);
    if (!m.scored) continue;
    if (m.paper) CHECK(m.energy == 1.0);
    CHECK(m.w1 == 0.0);
    CHECK(m.score == 1.0);
    CHECK(m.medianSim == m.medianRef);
  }
  for (const auto& c : r.curves) {
    INFO(c.name);
    if (c.scored) CHECK(c.score == 1.0);
  }
  CHECK(r.summary.physical == 1.0);
}

}  // namespace

TEST_CASE("evaluate: a CSV against itself scores 1", "[eval]") {
  TempDir dir;
  const std::string f = dir.file("tracks.csv");
  writeText(f, toCsv(syntheticTracks(), 0.02));
  const auto r = evalFiles(f, f);
  CHECK(r.sim.dt == Approx(0.02));
  CHECK(r.sim.individuals == 4);
  REQUIRE(r.metrics.size() == 11u);
  for (const auto& m : r.metrics) {
    INFO(m.name);
    CHECK(m.scored);
    CHECK(m.samplesSim >= 60);  // pol and mill: one per sample with 3 or more moving individuals
    if (!m.paper) continue;
    CHECK(m.weight == Approx(1.0 / 7.0));
    double s = 0, t = 0;
    for (double p : m.pdfSim) s += p;
    for (double p : m.pdfRef) t += p;
    CHECK(s == Approx(1.0));
    CHECK(t == Approx(1.0));
    CHECK(m.edges.size() == 51u);
  }
  checkIdentical(r);
  // the JSON has the documented keys
  const auto j = r.toJson();
  CHECK(j.at("bins") == 50);
  CHECK(j.at("sim").at("individuals") == 4);
  CHECK(j.at("metrics").at(0).at("name") == "v");
  CHECK(j.at("metrics").at(0).at("unit") == "m/s");
  for (const char* k : {"samples_sim", "samples_ref", "median_sim", "median_ref", "w1", "energy", "weight", "edges",
                        "pdf_sim", "pdf_ref"}) {
    CHECK(j.at("metrics").at(6).contains(k));
  }
  CHECK(j.at("total").get<double>() == Approx(1.0).margin(1e-12));
}

TEST_CASE("evaluate: halving the time stamps doubles speeds", "[eval]") {
  TempDir dir;
  const Tracks t = syntheticTracks();
  const std::string ref = dir.file("ref.csv"), fast = dir.file("fast.csv");
  writeText(ref, toCsv(t, 0.02));
  writeText(fast, toCsv(t, 0.01, ";"));  // also: another delimiter
  // the mean speed of the original, worked out from the tracks (central differences inside tracks)
  double sum = 0;
  long long n = 0;
  for (const auto& [id, s] : t) {
    for (std::size_t i = 1; i + 1 < s.size(); ++i) {
      if (s[i - 1].k != s[i].k - 1 || s[i + 1].k != s[i].k + 1) continue;
      const double dx = s[i + 1].p[0] - s[i - 1].p[0], dy = s[i + 1].p[1] - s[i - 1].p[1],
                   dz = s[i + 1].p[2] - s[i - 1].p[2];
      sum += std::sqrt(dx * dx + dy * dy + dz * dz) / (2 * 0.02);
      ++n;
    }
  }
  const double meanSpeed = sum / static_cast<double>(n);
  const FrameValues vf = collect(fast), vr = collect(ref);
  REQUIRE(vr[kSpeed].size() == static_cast<std::size_t>(n));
  REQUIRE(vf[kSpeed].size() == vr[kSpeed].size());
  double mean = 0;
  for (std::size_t i = 0; i < vr[kSpeed].size(); ++i) {
    CHECK(vf[kSpeed][i] == Approx(2.0 * vr[kSpeed][i]).epsilon(1e-12));
    mean += vr[kSpeed][i];
  }
  CHECK(mean / static_cast<double>(n) == Approx(meanSpeed).epsilon(1e-12));
  CHECK(vf[kNnDistance] == vr[kNnDistance]);  // positions unchanged

  // evaluated against each other, the finer grid is subsampled to the coarser one (every 2nd sample): the
  // even samples of the fast file are the ref's samples 0, 1, 2, ... at half the time, so speeds double
  const auto r = evalFiles(fast, ref);
  CHECK(r.sim.dt == Approx(0.02));
  REQUIRE(r.warnings.size() >= 1);
  CHECK_THAT(r.warnings[0], Catch::Matchers::Contains("subsampled every 2 samples"));
  const auto& v = r.metrics[kSpeed];
  CHECK(v.samplesRef == n);
  CHECK(v.meanRef == Approx(meanSpeed).epsilon(1e-12));
  CHECK(v.samplesSim < v.samplesRef);
}

TEST_CASE("evaluate: time steps that are not integer multiples are refused, naming both", "[eval]") {
  TempDir dir;
  const Tracks t = syntheticTracks();
  writeText(dir.file("a.csv"), toCsv(t, 0.02));
  writeText(dir.file("b.csv"), toCsv(t, 0.03));
  const std::string msg = inputErrorOf([&] { evalFiles(dir.file("a.csv"), dir.file("b.csv")); });
  CHECK_THAT(msg, Catch::Matchers::Contains("not integer multiples"));
  CHECK_THAT(msg, Catch::Matchers::Contains("dt 0.02 s"));
  CHECK_THAT(msg, Catch::Matchers::Contains("dt 0.03 s"));
}

TEST_CASE("evaluate: 60 fps times rounded to 4 decimals load on their true grid", "[eval]") {
  // 20 s at 60 fps written with 4 decimals: steps of 0.0166 and 0.0167 s; the median alone (0.0167) would
  // put late samples on the wrong index and two of them on one ("duplicate sample")
  TempDir dir;
  std::string csv = "id,time,x,y,z\n";
  char buf[128];
  for (int i = 0; i < 3; ++i) {
    for (int k = 0; k < 1200; ++k) {
      const double tt = k / 60.0;
      std::snprintf(buf, sizeof buf, "%d,%.4f,%.6f,%.6f,%.6f\n", i, tt, 0.3 * std::cos(tt + i), 0.3 * std::sin(tt + i),
                    1.0 + 0.1 * i);
      csv += buf;
    }
  }
  writeText(dir.file("f60.csv"), csv);
  auto src = openTracks(dir.file("f60.csv"), {});
  CHECK(src->info().dt == Approx(1.0 / 60.0).epsilon(1e-5));  // the last time is rounded: 1.7e-6 off
  CHECK(src->info().last - src->info().first == 1200);
  Frame f;
  for (std::int64_t k = src->info().first; k < src->info().last; ++k) {
    src->read(k, f);
    REQUIRE(f.size() == 3u);  // every sample has all three: none lost, none doubled
  }
}

TEST_CASE("evaluate: metrics on a circle", "[eval]") {
  // radius R at speed s sampled at dt: theta = s dt / R = 0.005; derived velocities are chords,
  // so |v| = s sin(theta)/theta, omega = s/R exactly, a and jerk agree with s^2/R and s^3/R^2
  // to O(theta^2) ~ 1e-5 relative: checked to 1e-4
  TempDir dir;
  const double R = 2.0, s = 1.0, dt = 0.01;
  const int N = 200;
  Tracks t;
  for (long long k = 0; k < N; ++k) {
    const double ph = s * dt * static_cast<double>(k) / R;
    t["c"].push_back({k, {R * std::cos(ph), R * std::sin(ph), 0.7}});
  }
  const std::string f = dir.file("circle.csv");
  writeText(f, toCsv(t, dt));
  const auto v = collect(f);
  CHECK(v[kSpeed].size() == static_cast<std::size_t>(N - 2));
  CHECK(v[kAccel].size() == static_cast<std::size_t>(N - 4));
  CHECK(v[kOmega].size() == static_cast<std::size_t>(N - 4));
  CHECK(v[kJerk].size() == static_cast<std::size_t>(N - 4));
  CHECK(v[kAlpha].size() == static_cast<std::size_t>(N - 6));
  CHECK(v[kNnDistance].empty());  // a single individual
  CHECK(v[kEta].empty());
  for (double x : v[kSpeed]) CHECK(x == Approx(s).epsilon(1e-4));
  for (double x : v[kOmega]) CHECK(x == Approx(s / R).epsilon(1e-9));
  for (double x : v[kAccel]) CHECK(x == Approx(s * s / R).epsilon(1e-4));
  for (double x : v[kJerk]) CHECK(x == Approx(s * s * s / (R * R)).epsilon(1e-4));
  for (double x : v[kAlpha]) CHECK(x == Approx(0.0).margin(1e-6));
  // with d missing everywhere the evaluation leaves it (and eta) out
  const auto r = evalFiles(f, f);
  CHECK_FALSE(r.metrics[kNnDistance].scored);
  CHECK(r.metrics[kNnDistance].weight == 0.0);
  CHECK(r.metrics[kSpeed].weight == Approx(0.2));
  CHECK(r.total == Approx(1.0).margin(1e-12));
}

TEST_CASE("evaluate: no differences across a gap", "[eval]") {
  TempDir dir;
  // straight line at 1 m/s along x, samples 0..9 with sample 5 missing
  std::string derived = "id,time,x,y,z\n", given = "track;t;x;y;z;vx;vy;vz\n";
  for (int k = 0; k < 10; ++k) {
    if (k == 5) continue;
    derived += "a," + std::to_string(k) + "," + std::to_string(k) + ",0,0\n";
    given += "a;" + std::to_string(k) + ";" + std::to_string(k) + ";0;0;1;0;0\n";
  }
  writeText(dir.file("d.csv"), derived);
  writeText(dir.file("g.csv"), given);
  const auto d = collect(dir.file("d.csv"));
  CHECK(d[kSpeed].size() == 5u);  // v at k = 1, 2, 3, 7, 8: both neighbours present
  CHECK(d[kAccel].size() == 1u);  // v at k - 1 and k + 1: only k = 2
  CHECK(d[kOmega].size() == 1u);
  CHECK(d[kJerk].size() == 1u);
  CHECK(d[kAlpha].empty());  // omega only at k = 2
  for (double x : d[kSpeed]) CHECK(x == Approx(1.0));
  for (double x : d[kAccel]) CHECK(x == Approx(0.0).margin(1e-12));
  const auto g = collect(dir.file("g.csv"));
  CHECK(g[kSpeed].size() == 9u);  // recorded velocities: every sample
  CHECK(g[kAccel].size() == 5u);  // k = 1, 2, 3, 7, 8
  CHECK(g[kJerk].size() == 5u);
  CHECK(g[kOmega].size() == 5u);
  CHECK(g[kAlpha].size() == 1u);  // omega at k - 1 and k + 1: only k = 2 (1 and 3)
}

TEST_CASE("evaluate: nearest neighbour distance and eta of two parallel tracks", "[eval]") {
  // A at (t, 0, 0) with 1 m/s, B at (2t, 0.3, 0) with 2 m/s, both along x:
  // d(t) = sqrt(t^2 + 0.09), eta = |2 - 1| / d = 1 / d
  TempDir dir;
  std::string csv = "id,time,x,y,z,vx,vy,vz\n";
  const int N = 10;
  const double dt = 0.1;
  char buf[200];
  for (int k = 0; k < N; ++k) {
    const double t = dt * k;
    std::snprintf(buf, sizeof buf, "A,%.17g,%.17g,0,0,1,0,0\nB,%.17g,%.17g,0.3,0,2,0,0\n", t, t, t, 2 * t);
    csv += buf;
  }
  writeText(dir.file("p.csv"), csv);
  auto src = openTracks(dir.file("p.csv"), {});
  int k = 0;
  computeMetrics(*src, 1.0, [&](const FrameValues& v, const SampleView&) {
    const double t = dt * k, d = std::sqrt(t * t + 0.09);
    REQUIRE(v[kNnDistance].size() == 2u);
    REQUIRE(v[kEta].size() == 2u);
    for (int i = 0; i < 2; ++i) {
      CHECK(v[kNnDistance][static_cast<std::size_t>(i)] == Approx(d).epsilon(1e-12));
      CHECK(v[kEta][static_cast<std::size_t>(i)] == Approx(1.0 / d).epsilon(1e-12));
    }
    CHECK(v[kSpeed][0] == 1.0);
    CHECK(v[kSpeed][1] == 2.0);
    ++k;
  });
  CHECK(k == N);
}

TEST_CASE("evaluate: nearest neighbours on the grid match brute force", "[eval]") {
  // 600 random points (above the brute-force threshold of 64), one of them isolated far away
  TempDir dir;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<std::array<double, 3>> p(600);
  for (auto& q : p) q = {u(rng), u(rng), 0.3 * u(rng)};
  p[5] = {25.0, 3.0, -4.0};
  std::string csv = "id,time,x,y,z\n";
  char buf[200];
  for (int k = 0; k < 2; ++k) {
    for (std::size_t i = 0; i < p.size(); ++i) {
      std::snprintf(buf, sizeof buf, "%zu,%d,%.17g,%.17g,%.17g\n", i, k, p[i][0], p[i][1], p[i][2]);
      csv += buf;
    }
  }
  writeText(dir.file("r.csv"), csv);
  const auto v = collect(dir.file("r.csv"));
  REQUIRE(v[kNnDistance].size() == 2 * p.size());
  // ids sort as numbers of first appearance = row order
  for (std::size_t i = 0; i < p.size(); ++i) {
    double best = 1e300;
    for (std::size_t j = 0; j < p.size(); ++j) {
      if (j == i) continue;
      const double dx = p[i][0] - p[j][0], dy = p[i][1] - p[j][1], dz = p[i][2] - p[j][2];
      best = std::min(best, std::sqrt(dx * dx + dy * dy + dz * dz));
    }
    CHECK(v[kNnDistance][i] == best);
  }
}

TEST_CASE("evaluate: bad CSV input", "[eval]") {
  TempDir dir;
  const auto run = [&](const std::string& name, const std::string& text, const std::string& frames = "") {
    writeText(dir.file(name), text);
    return inputErrorOf([&] { evalFiles(dir.file(name), dir.file(name), frames); });
  };
  using Catch::Matchers::Contains;
  CHECK_THAT(run("m.csv", "id,time,x,y\n1,0,0,0\n1,1,0,0\n"),
             Contains("m.csv:1: missing column for z") && Contains("header: id, time, x, y"));
  CHECK_THAT(run("n.csv", "id,time,x,y,z\n1,0,0,0,0\n1,1,abc,0,0\n"),
             Contains("n.csv:3: column x: expected a number, got \"abc\""));
  CHECK_THAT(run("s.csv", "id,time,x,y,z\n1,0,0,0,0\n"), Contains("s.csv: 1 sample(s); need at least 2"));
  CHECK_THAT(run("t.csv", "id,time,x,y,z\n1,0,0,0,0\n2,0,1,0,0\n"),
             Contains("t.csv: cannot determine the sampling interval"));
  CHECK_THAT(run("nan.csv", "id,time,x,y,z\n1,0,0,0,0\n1,1,0,nan,0\n"),
             Contains("nan.csv:3: column y: not a finite number: \"nan\""));
  CHECK_THAT(run("inf.csv", "id;time;x;y;z\n1;0;0;0;0\n1;1;0;0;-inf\n"), Contains("inf.csv:3: column z: not a finite"));
  CHECK_THAT(run("dup.csv", "id,time,x,y,z\n1,0,0,0,0\n1,1,0,0,0\n1,2,0,0,0\n1,2.1,0,0,0\n"),
             Contains("dup.csv:5: duplicate sample: id \"1\"") && Contains("like line 4"));
  CHECK_THAT(run("short.csv", "id,time,x,y,z\n1,0,0,0,0\n1,1,0,0\n"),
             Contains("short.csv:3: expected 5 fields, got 4"));
  // two samples: a speed needs three, so no metric at all
  CHECK_THAT(run("two.csv", "id,time,x,y,z\n1,0,0,0,0\n1,1,0,0,0\n"), Contains("two.csv: no metric samples at all"));
  const std::string ok = "id,time,x,y,z\n1,0,0,0,0\n1,1,1,0,0\n1,2,2,0,0\n1,3,3,0,0\n";
  CHECK_THAT(run("f.csv", ok, "3:"), Contains("f.csv: 1 sample(s) of the time grid"));
  CHECK_THAT(inputErrorOf([] { FrameRange::parse("1-2"); }), Contains("--frames: expected A:B"));
  CHECK_THAT(inputErrorOf([] { FrameRange::parse("a:"); }), Contains("--frames: expected A:B"));
  CHECK_THAT(inputErrorOf([&] { evalFiles(dir.file("nope.csv"), dir.file("f.csv")); }),
             Contains("nope.csv: cannot open"));
  // --columns and the moustic-style header (object preferred to oldobject, prefixes)
  writeText(dir.file("c.csv"), "oldobject;object;time;XS;YS;ZS\n9;1;0;0;0;0\n9;1;1;1;0;0\n9;1;2;2;0;0\n");
  CHECK(collect(dir.file("c.csv"))[kSpeed].size() == 1u);
  SourceOptions so;
  so.csv.columns = "id=oldobject,x=missing";
  CHECK_THAT(inputErrorOf([&] { openTracks(dir.file("c.csv"), so); }),
             Contains("no column \"missing\" (given for x by --columns); header: oldobject, object, time, XS, YS, ZS"));
}

TEST_CASE("evaluate: HDF5 output against itself, --frames, --swarm, threads", "[eval]") {
  TempDir dir;
  const auto sc = swarmsim::parseScenario(nlohmann::json::parse(R"({
    "name": "evaltiny", "seed": 5, "dt": 0.01, "frames": 20, "steps_per_frame": 2,
    "domain": {"min": [-2, -2, 0], "max": [2, 2, 3]},
    "swarms": [
      {"name": "midges", "count": 2300, "model": "boids", "initial_speed": 0.3,
       "spawn": {"type": "sphere", "center": [0, 0, 1.5], "radius": 0.6},
       "params": {"jitter": 0.4}},
      {"name": "gnats", "count": 40, "model": "boids", "initial_speed": 0.5,
       "spawn": {"type": "box", "min": [-0.5, -0.5, 1], "max": [0.5, 0.5, 2]}, "params": {}}
    ]})"),
                                          dir.file("s.json"));
  swarmsim::RunOptions opt;
  opt.output = dir.file("out.h5");
  opt.quiet = true;
  swarmsim::runScenario(sc, opt);
  const std::string f = opt.output;
  REQUIRE(looksLikeHdf5(f));

  EvaluateOptions o;
  o.sim = o.reference = f;
  CHECK_THAT(inputErrorOf([&] { evaluate(o); }),
             Catch::Matchers::Contains("2 swarms; choose one with --swarm (swarms: midges, gnats)"));
  o.source.swarm = "bees";
  CHECK_THAT(inputErrorOf([&] { evaluate(o); }), Catch::Matchers::Contains("no swarm \"bees\""));
  o.source.swarm = "midges";
  const int saved = swarmsim::threadCount();
  swarmsim::setThreadCount(1);
  const auto r1 = evaluate(o);
  swarmsim::setThreadCount(2);
  const auto r2 = evaluate(o);
  swarmsim::setThreadCount(saved);
  CHECK(r1.toJson() == r2.toJson());  // thread-independent, bit for bit
  checkIdentical(r1);
  CHECK(r1.sim.dt == Approx(0.02));
  CHECK(r1.sim.individuals == 2300);
  CHECK(r1.metrics[kSpeed].samplesSim == 20 * 2300);  // recorded velocities
  CHECK(r1.metrics[kAlpha].samplesSim == 16 * 2300);
  CHECK(r1.metrics[kNnDistance].samplesSim == 20 * 2300);

  o.source.frames = FrameRange::parse("5:15");
  const auto rf = evaluate(o);
  checkIdentical(rf);
  CHECK(rf.metrics[kSpeed].samplesSim == 10 * 2300);
  CHECK(rf.metrics[kAccel].samplesSim == 8 * 2300);

  o.source.frames = FrameRange::parse("-1:");
  CHECK_THAT(inputErrorOf([&] { evaluate(o); }), Catch::Matchers::Contains("1 frame(s) of swarm \"midges\" selected"));

  // --sim-scale 2: speeds and distances x2, z-scored shapes unchanged
  o.source.frames = FrameRange{};
  o.simScale = 2.0;
  const auto rs = evaluate(o);
  CHECK(rs.metrics[kSpeed].medianSim == Approx(2 * rs.metrics[kSpeed].medianRef).epsilon(1e-3));
  CHECK(rs.metrics[kOmega].w1 == Approx(0.0).margin(1e-12));  // scale-free
  CHECK(rs.total == Approx(1.0).margin(1e-9));

  // the command line: exit codes and JSON
  const std::string exe = SWARMSIM_EXE;
  auto res =
      swarmsim_test::runCommand(exe + " evaluate " + f + " --reference " + f + " --swarm gnats --json", dir.path());
  REQUIRE(res.exitCode == 0);
  const auto j = nlohmann::json::parse(res.out);
  CHECK(j.at("sim").at("swarm") == "gnats");
  CHECK(j.at("total").get<double>() == Approx(1.0).margin(1e-12));
  res = swarmsim_test::runCommand(exe + " evaluate " + f + " --reference " + f + " --swarm bees", dir.path());
  CHECK(res.exitCode == 2);
  CHECK_THAT(res.err, Catch::Matchers::Contains("no swarm \"bees\""));
  res = swarmsim_test::runCommand(exe + " evaluate " + f + " --reference " + f + " --frames x", dir.path());
  CHECK(res.exitCode == 2);
}

TEST_CASE("evaluate: the real moustic tracks against themselves", "[eval]") {
  const std::string f = SWARMSIM_SOURCE_DIR "/../shared/data/real/anopheles_swarm_moustic/tracks.csv";
  if (!std::ifstream(f)) {
    WARN("skipped: " << f << " not found");
    return;
  }
  const auto r = evalFiles(f, f);
  checkIdentical(r);
  CHECK(r.sim.dt == Approx(0.02));
  CHECK(r.sim.individuals == 36);
  CHECK(r.metrics[kSpeed].samplesSim == 29999);  // velocity columns: every row
  CHECK(r.metrics[kSpeed].medianSim > 0.40);
  CHECK(r.metrics[kSpeed].medianSim < 0.55);
}
