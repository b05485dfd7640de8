// FASTSWARM's reference (models/fastswarm/reference.hpp): forward differences of synthetic tracks with
// gaps give the exact (v, a) and never reach across a gap; the Tukey fence drops a spike; the samples
// are sorted by speed and the groups tile them; a written file reads back the same; bad input is exit 2;
// and the shipped data/reference/anopheles_moustic.h5 is what the command in its README builds from
// ../shared (skipped when ../shared is absent).
#include <catch2/catch.hpp>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/error.hpp"
#include "models/fastswarm/reference.hpp"
#include "test_util.hpp"

using Catch::Matchers::Contains;
using swarmsim::fastswarm::buildReference;
using swarmsim::fastswarm::readReference;
using swarmsim::fastswarm::Reference;
using swarmsim::fastswarm::ReferenceBuildOptions;
using swarmsim::fastswarm::VelocitySource;
using swarmsim_test::runSwarmsim;
using swarmsim_test::shellQuote;
using swarmsim_test::TempDir;

namespace {

// id 1: p(t) = (t^2, 2t, 1) on samples 0..9 except sample 5 (a gap); id 2: p(t) = (-t, 0, 3t^3) on samples
// 2..6; id 3: a single sample (too short); dt = 0.1 s. Rows shuffled between ids, as files may have them.
struct Synthetic {
  static constexpr double dt = 0.1;
  static double px(int id, double t) { return id == 1 ? t * t : -t; }
  static double py(int id, double t) { return id == 1 ? 2.0 * t : 0.0; }
  static double pz(int id, double t) { return id == 1 ? 1.0 : 3.0 * t * t * t; }
  static std::vector<int> samples(int id) {
    if (id == 1) return {0, 1, 2, 3, 4, 6, 7, 8, 9};
    if (id == 2) return {2, 3, 4, 5, 6};
    return {4};
  }
  static std::string csv(bool withVelocity) {
    std::ostringstream s;
    s.precision(17);
    s << "id,time,x,y,z" << (withVelocity ? ",vx,vy,vz" : "") << "\n";
    for (int k = 0; k < 10; ++k) {
      for (int id : {2, 1, 3}) {
        const auto ks = samples(id);
        if (std::find(ks.begin(), ks.end(), k) == ks.end()) continue;
        const double t = k * dt;
        s << id << "," << t << "," << px(id, t) << "," << py(id, t) << "," << pz(id, t);
        // recorded velocities: something other than the position differences, to tell the two apart
        if (withVelocity) s << "," << 10.0 * id + k << "," << 0.5 * k << "," << -1.0;
        s << "\n";
      }
    }
    return s.str();
  }
};

std::string writeFile(const TempDir& dir, const std::string& name, const std::string& text) {
  std::ofstream(dir.file(name)) << text;
  return dir.file(name);
}

// the (v, a) rows of a reference as a multiset keyed by the printed values (order: by speed, ties stable)
std::vector<std::array<double, 6>> rows(const Reference& r) {
  std::vector<std::array<double, 6>> out;
  for (std::size_t i = 0; i < r.size(); ++i) {
    out.push_back({r.v[3 * i], r.v[3 * i + 1], r.v[3 * i + 2], r.a[3 * i], r.a[3 * i + 1], r.a[3 * i + 2]});
  }
  return out;
}

}  // namespace

TEST_CASE("reference: forward differences of positions are exact and never cross a gap", "[fastswarm][reference]") {
  TempDir dir;
  ReferenceBuildOptions opt;
  opt.tracks = {writeFile(dir, "tracks.csv", Synthetic::csv(false))};
  opt.fence = 0.0;  // keep every sample
  opt.groupSize = 2;
  const Reference r = buildReference(opt);
  REQUIRE(r.dt == Approx(Synthetic::dt));
  // expected: every k with k, k+1, k+2 all present for the id
  std::vector<std::array<double, 6>> want;
  for (int id : {1, 2, 3}) {
    const auto ks = Synthetic::samples(id);
    for (int k : ks) {
      const auto has = [&](int s) { return std::find(ks.begin(), ks.end(), s) != ks.end(); };
      if (!has(k + 1) || !has(k + 2)) continue;
      const double t0 = k * Synthetic::dt, t1 = t0 + Synthetic::dt;
      const double h = Synthetic::dt;
      // by hand: x = t^2 gives v = (2 t0 + h), a = 2; x = -t: v = -1, a = 0; z = 3 t^3: v = 3 (t1^3 - t0^3) / h,
      // a = 3 (t2^3 - 2 t1^3 + t0^3) / h^2 = 18 t1
      if (id == 1) {
        want.push_back({2.0 * t0 + h, 2.0, 0.0, 2.0, 0.0, 0.0});
      } else {
        want.push_back({-1.0, 0.0, 3.0 * (t1 * t1 * t1 - t0 * t0 * t0) / h, 0.0, 0.0, 18.0 * t1});
      }
    }
  }
  // id 1: k = 0, 1, 2 and 6, 7 (not 3, 4: sample 5 is missing); id 2: k = 2, 3, 4
  REQUIRE(want.size() == 8);
  REQUIRE(r.size() == want.size());
  const auto got = rows(r);
  for (const auto& w : want) {
    bool found = false;
    for (const auto& g : got) {
      bool same = true;
      for (int c = 0; c < 6; ++c) same = same && std::fabs(g[c] - w[c]) <= 1e-9 * (1.0 + std::fabs(w[c]));
      found = found || same;
    }
    INFO("v = (" << w[0] << ", " << w[1] << ", " << w[2] << "), a = (" << w[3] << ", " << w[4] << ", " << w[5] << ")");
    CHECK(found);
  }
  // sorted by speed, the groups tile the samples (4 groups of 2)
  for (std::size_t i = 1; i < r.size(); ++i) CHECK(r.speed[i] >= r.speed[i - 1]);
  for (std::size_t i = 0; i < r.size(); ++i) CHECK(r.speed[i] == Approx(std::hypot(r.v[3 * i], r.v[3 * i + 1], r.v[3 * i + 2])));
  CHECK(r.groupStart == std::vector<std::int64_t>{0, 2, 4, 6, 8});
  REQUIRE(r.sources.size() == 1);
  CHECK(r.sources[0].individuals == 3);
  CHECK(r.sources[0].shortTracks == 1);  // id 3
  CHECK(r.sources[0].samples == 8);
  CHECK(r.sources[0].velocity == "positions");
  // successors (/samples/next): id 1's k = 0 -> 1 -> 2 and 6 -> 7, id 2's 2 -> 3 -> 4; the last of each run
  // has none (k = 3 of id 1 gave no sample, and nothing follows k = 7 or id 2's k = 4). The successor's v is
  // v + a dt of its predecessor, exactly as the differences were taken
  REQUIRE(r.next.size() == r.size());
  int linked = 0;
  for (std::size_t i = 0; i < r.size(); ++i) {
    if (r.next[i] < 0) continue;
    ++linked;
    const auto j = static_cast<std::size_t>(r.next[i]);
    REQUIRE(j < r.size());
    for (int c = 0; c < 3; ++c) {
      CHECK(r.v[3 * j + c] == Approx(r.v[3 * i + c] + r.a[3 * i + c] * Synthetic::dt).margin(1e-9));
    }
  }
  CHECK(linked == 5);
}

TEST_CASE("reference: recorded velocities give v as recorded and a forward-differenced from them",
          "[fastswarm][reference]") {
  TempDir dir;
  ReferenceBuildOptions opt;
  opt.tracks = {writeFile(dir, "tracks.csv", Synthetic::csv(true))};
  opt.fence = 0.0;
  const Reference r = buildReference(opt);
  // pairs k, k+1 present: id 1: 0-1, 1-2, 2-3, 3-4, 6-7, 7-8, 8-9 (7); id 2: 2-3 .. 5-6 (4)
  REQUIRE(r.size() == 11);
  CHECK(r.sources[0].velocity == "recorded");
  CHECK(r.groupStart == std::vector<std::int64_t>{0, 11});  // fewer than a group: one group
  for (std::size_t i = 0; i < r.size(); ++i) {
    // v = (10 id + k, k / 2, -1): a = ((10 id + k + 1) - (10 id + k), 0.5, 0) / dt = (10, 5, 0)
    const double vx = r.v[3 * i], vy = r.v[3 * i + 1];
    const double k = 2.0 * vy;
    const double id = (vx - k) / 10.0;
    CHECK((id == Approx(1.0) || id == Approx(2.0)));
    CHECK(r.v[3 * i + 2] == -1.0);
    CHECK(r.a[3 * i] == Approx(10.0));
    CHECK(r.a[3 * i + 1] == Approx(5.0));
    CHECK(r.a[3 * i + 2] == Approx(0.0).margin(1e-12));
  }
  // --velocity positions ignores the columns
  opt.velocity = VelocitySource::Positions;
  CHECK(buildReference(opt).size() == 8);
}

TEST_CASE("reference: the Tukey fence and explicit bounds drop outliers", "[fastswarm][reference]") {
  TempDir dir;
  // 60 samples of a steady walk at about 1 m/s along x with a little variation, then one jump of 50 m
  std::ostringstream s;
  s << "id,time,x,y,z\n";
  double x = 0.0;
  for (int k = 0; k < 62; ++k) {
    s << "1," << k * 0.1 << "," << x << ",0,0\n";
    x += k == 40 ? 50.0 : 0.1 * (1.0 + 0.02 * std::sin(1.3 * k));
  }
  ReferenceBuildOptions opt;
  opt.tracks = {writeFile(dir, "walk.csv", s.str())};
  const Reference fenced = buildReference(opt);
  opt.fence = 0.0;
  const Reference all = buildReference(opt);
  CHECK(all.size() == 60);
  // the jump touches the samples k = 39 (a), 40 (v and a): both beyond the fence
  CHECK(fenced.size() == 58);
  CHECK(fenced.sources[0].dropped == 2);
  CHECK(fenced.speed.back() < 2.0);
  CHECK(all.speed.back() > 400.0);
  opt.maxSpeed = 1.01;  // an explicit bound alone
  const Reference bounded = buildReference(opt);
  CHECK(bounded.speed.back() <= 1.01);
  CHECK(bounded.size() < 58);
}

TEST_CASE("reference: a written file reads back the same, and info describes it", "[fastswarm][reference]") {
  TempDir dir;
  ReferenceBuildOptions opt;
  opt.tracks = {writeFile(dir, "tracks.csv", Synthetic::csv(false))};
  opt.fence = 0.0;
  opt.groupSize = 3;
  const Reference r = buildReference(opt);
  swarmsim::fastswarm::writeReference(r, dir.file("ref.h5"), false);
  CHECK(swarmsim::fastswarm::isReferenceFile(dir.file("ref.h5")));
  const Reference back = readReference(dir.file("ref.h5"));
  CHECK(back.v == r.v);
  CHECK(back.a == r.a);
  CHECK(back.speed == r.speed);
  CHECK(back.groupStart == r.groupStart);
  CHECK(back.next == r.next);
  CHECK(back.formatVersion == 2);
  CHECK(back.dt == r.dt);
  // the group of a speed: the last group starting at or below it
  REQUIRE(r.groups() == 2);
  CHECK(r.groupOfSpeed(-1.0) == 0);
  CHECK(r.groupOfSpeed(r.speed[2]) == 0);
  CHECK(r.groupOfSpeed(r.speed[3]) == (r.speed[3] > r.speed[2] ? 1u : 0u));
  CHECK(r.groupOfSpeed(1e9) == 1);
  REQUIRE(back.sources.size() == 1);
  CHECK(back.sources[0].sha256 == r.sources[0].sha256);
  CHECK(back.sources[0].sha256.size() == 64);
  // the CLI: build, info (text and JSON), --force replaces our own file
  const std::string tracks = shellQuote(dir.file("tracks.csv"));
  auto res = runSwarmsim("reference build " + tracks + " -o cli.h5 --group-size 3", dir.path());
  INFO(res.err);
  REQUIRE(res.exitCode == 0);
  CHECK_THAT(res.out, Contains("samples in"));
  res = runSwarmsim("reference info cli.h5 --json", dir.path());
  REQUIRE(res.exitCode == 0);
  const auto j = nlohmann::json::parse(res.out);
  CHECK(j.at("samples") == 8);
  CHECK(j.at("groups") == 2);
  CHECK(j.at("sources").at(0).at("velocity") == "positions");
  res = runSwarmsim("reference info cli.h5", dir.path());
  CHECK_THAT(res.out, Contains("8 (v, a), in 2 speed groups of 3"));
  CHECK(runSwarmsim("reference build " + tracks + " -o cli.h5", dir.path()).exitCode == 3);  // exists
  CHECK(runSwarmsim("reference build " + tracks + " -o cli.h5 --force", dir.path()).exitCode == 0);
  // the sha256 of a known text ("abc")
  CHECK(swarmsim::fastswarm::sha256File(writeFile(dir, "abc.txt", "abc")) ==
        "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
}

TEST_CASE("reference: the group of a speed is the last group starting at or below it, by either look-up",
          "[fastswarm][reference]") {
  // groups of 1 to 4 samples with runs of equal speeds across group boundaries
  Reference r;
  for (int i = 0; i < 200; ++i) r.speed.push_back(0.01 * static_cast<double>(i / 3));
  std::int64_t start = 0;
  for (int g = 0; start < 200; ++g) {
    r.groupStart.push_back(start);
    start += 1 + g % 4;
  }
  r.groupStart.push_back(200);
  REQUIRE(r.groups() > 50);
  Reference plain = r;  // without groupFloor: speeds read through groupStart
  r.indexGroups();
  REQUIRE(r.groupFloor.size() == r.groups());
  REQUIRE(r.groupBin.size() == Reference::kGroupBins);  // the look-up table, then the exact steps
  const auto brute = [&](double s) {
    std::size_t g = 0;
    for (std::size_t k = 0; k < r.groups(); ++k) {
      if (r.speed[static_cast<std::size_t>(r.groupStart[k])] <= s) g = k;
    }
    return g;
  };
  for (int i = -20; i < 7200; ++i) {
    // below, at and between the sample speeds (several per bin of the table)
    const double s = 0.00025 * static_cast<double>(i);
    CHECK(r.groupOfSpeed(s) == brute(s));
    CHECK(plain.groupOfSpeed(s) == brute(s));
  }
  for (std::size_t k = 0; k < r.groups(); ++k) {
    const double s = r.speed[static_cast<std::size_t>(r.groupStart[k])];
    CHECK(r.groupOfSpeed(s) == brute(s));
  }
}

TEST_CASE("reference: bad input is exit 2 with the file named", "[fastswarm][reference][input]") {
  TempDir dir;
  writeFile(dir, "short.csv", "id,time,x,y,z\n1,0,0,0,0\n1,0.1,1,0,0\n2,0,0,0,0\n");
  writeFile(dir, "slow.csv", "id,time,x,y,z\n1,0,0,0,0\n1,0.2,1,0,0\n1,0.4,2,0,0\n");
  writeFile(dir, "fast.csv", "id,time,x,y,z\n1,0,0,0,0\n1,0.1,1,0,0\n1,0.2,2,0,0\n");
  writeFile(dir, "foreign.h5", "not ours");
  struct Case {
    std::string args, message;
    int code;
  } cases[] = {
      {"reference build short.csv -o r.h5", "short.csv: no individual has three consecutive samples", 2},
      {"reference build missing.csv -o r.h5", "missing.csv: cannot open", 2},
      {"reference build fast.csv slow.csv -o r.h5", "slow.csv: time step 0.2 s differs from 0.1 s of fast.csv", 2},
      {"reference build fast.csv -o r.h5 --max-speed 0.5 --fence 0", "the filter left no sample", 2},
      {"reference build fast.csv -o r.h5 --group-size 0", "--group-size", 2},
      {"reference build fast.csv -o r.h5 --velocity recorded", "fast.csv: has no velocity columns", 2},
      {"reference build fast.csv", "--output is required", 2},
      {"reference info fast.csv", "fast.csv: not an HDF5 file", 2},
      {"reference info missing.h5", "missing.h5", 2},
      {"reference build fast.csv -o foreign.h5 --force", "not replaced", 3},
  };
  for (const auto& c : cases) {
    const auto res = runSwarmsim(c.args, dir.path());
    INFO(c.args << "\nstderr: " << res.err);
    CHECK(res.exitCode == c.code);
    CHECK_THAT(res.err, Contains(c.message));
  }
  CHECK(swarmsim_test::readText(dir.file("foreign.h5")) == "not ours");
}

TEST_CASE("reference: the shipped mosquito reference is what its README's command builds", "[fastswarm][reference]") {
  const std::string tracks = swarmsim_test::kSourceTree + "/../shared/data/real/anopheles_swarm_moustic/tracks.csv";
  if (!std::ifstream(tracks)) {
    WARN("skipped: " << tracks << " not found");
    return;
  }
  // the README's commands: every default, and --fence 6 (fastswarm_realistic_37's reference)
  for (const double fence : {3.0, 6.0}) {
    INFO("fence " << fence);
    const Reference shipped = readReference(swarmsim_test::kSourceTree + (fence == 3.0 ? "/data/reference/anopheles_moustic.h5"
                                                                                       : "/data/reference/anopheles_moustic_fence6.h5"));
    ReferenceBuildOptions opt;
    opt.tracks = {tracks};
    opt.fence = fence;
    const Reference rebuilt = buildReference(opt);
    CHECK(rebuilt.v == shipped.v);
    CHECK(rebuilt.a == shipped.a);
    CHECK(rebuilt.speed == shipped.speed);
    CHECK(rebuilt.groupStart == shipped.groupStart);
    CHECK(rebuilt.next == shipped.next);
    CHECK(shipped.formatVersion == 2);
    CHECK(rebuilt.dt == shipped.dt);
    CHECK(rebuilt.speedLimit == shipped.speedLimit);
    CHECK(rebuilt.accelLimit == shipped.accelLimit);
    REQUIRE(shipped.sources.size() == 1);
    CHECK(rebuilt.sources[0].sha256 == shipped.sources[0].sha256);
    CHECK(rebuilt.sources[0].samples == shipped.sources[0].samples);
    CHECK(rebuilt.sources[0].dropped == shipped.sources[0].dropped);
    CHECK(shipped.sources[0].name == "tracks.csv");
    CHECK(shipped.sources[0].velocity == "recorded");
    // the real data's figures (../shared's README: median speed 0.465 m/s, 50 frames/s)
    CHECK(shipped.dt == Approx(0.02));
    CHECK(shipped.speed[shipped.size() / 2] == Approx(0.465).epsilon(0.02));
    CHECK(shipped.size() > 29000);
    CHECK(shipped.sources[0].dropped == (fence == 3.0 ? 269 : 20));  // data/reference/README.md
  }
}
