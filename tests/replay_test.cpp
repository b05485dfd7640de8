// The replay model (models/replay) and swarms that see each other ("sees", core/world.hpp SeenSwarms):
// replayed agents are exactly at their recorded positions, interpolated between samples and absent outside
// their tracks; a fastswarm agent whose only neighbour is replayed reacts to it; the mixing scenario is the
// same for 1 and 2 threads; `evaluate` of a replay against its own file is a perfect score; bad "sees" and
// replay blocks are exit 2 naming the JSON path.
#include <catch2/catch.hpp>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "io/trajectory_reader.hpp"
#include "refusal_check.hpp"
#include "test_util.hpp"

using Catch::Matchers::Contains;
using swarmsim_test::runSwarmsim;
using swarmsim_test::shellQuote;
using swarmsim_test::TempDir;

namespace {

using Json = nlohmann::json;

// two tracks sampled every 0.1 s: "a" from 0 to 0.4 s, "b" from 0.2 to 0.6 s with no sample at 0.4 s (a gap)
const char* kTracks =
    "id,time,x,y,z\n"
    "a,0.0,0,0,0\n"
    "a,0.1,1,0,0\n"
    "b,0.2,5,5,5\n"
    "a,0.2,1,2,0\n"
    "a,0.3,1,2,3\n"
    "b,0.3,6,5,5\n"
    "a,0.4,0,0,0\n"
    "b,0.5,7,5,5\n"
    "b,0.6,8,5,5\n";

Json replayScenario(double dt, int frames, const Json& params) {
  return Json{{"name", "replay_test"},
              {"seed", 1},
              {"dt", dt},
              {"frames", frames},
              {"domain", {{"min", {-20, -20, -20}}, {"max", {20, 20, 20}}}},
              {"swarms", Json::array({Json{{"name", "real"}, {"model", "replay"}, {"params", params}}})}};
}

struct Run {
  std::vector<float> pos, vel;
  std::vector<std::uint64_t> shape;
};

Run read(const std::string& file, const std::string& swarm) {
  Run r;
  r.pos = swarmsim::readFloatDataset(file, "swarms/" + swarm + "/position", &r.shape);
  r.vel = swarmsim::readFloatDataset(file, "swarms/" + swarm + "/velocity");
  return r;
}

}  // namespace

TEST_CASE("replay: agents at their recorded positions, interpolated between samples, absent outside their tracks",
          "[replay][scenario]") {
  TempDir dir;
  swarmsim_test::writeText(dir.file("tracks.csv"), kTracks);
  // the simulation steps at half the sample interval: every other frame falls between two samples
  swarmsim_test::writeText(dir.file("s.json"), replayScenario(0.05, 15, {{"file", "tracks.csv"}}).dump());
  const auto r = runSwarmsim("run s.json -o out.h5 --quiet", dir.path());
  INFO(r.err);
  REQUIRE(r.exitCode == 0);
  const Run run = read(dir.file("out.h5"), "real");
  REQUIRE(run.shape == std::vector<std::uint64_t>{15, 2, 3});
  const auto stat = swarmsim::readDoubleDataset(dir.file("out.h5"), "swarms/real/stats/present");
  // expected: NaN = absent; agent 0 is "a", agent 1 "b" (the order the file first names them)
  const double N = std::nan("");
  const double a[15][3] = {{0, 0, 0},   {0.5, 0, 0}, {1, 0, 0}, {1, 1, 0}, {1, 2, 0}, {1, 2, 1.5}, {1, 2, 3},
                           {0.5, 1, 1.5}, {0, 0, 0}, {N, N, N}, {N, N, N}, {N, N, N}, {N, N, N}, {N, N, N},
                           {N, N, N}};
  const double b[15][3] = {{N, N, N}, {N, N, N}, {N, N, N}, {N, N, N}, {5, 5, 5}, {5.5, 5, 5}, {6, 5, 5},
                           {N, N, N}, {N, N, N}, {N, N, N}, {7, 5, 5}, {7.5, 5, 5}, {8, 5, 5}, {N, N, N},
                           {N, N, N}};
  // velocities: forward differences of the positions over 0.1 s; at the end of a track or before a gap, the
  // backward one
  const double va[15][3] = {{10, 0, 0}, {10, 0, 0}, {0, 20, 0},  {0, 20, 0},   {0, 0, 30}, {0, 0, 30},
                            {-10, -20, -30}, {-10, -20, -30}, {-10, -20, -30}};
  const double vb[15][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}, {0, 0, 0}, {10, 0, 0}, {10, 0, 0}, {10, 0, 0},
                            {0, 0, 0}, {0, 0, 0}, {0, 0, 0}, {10, 0, 0}, {10, 0, 0}, {10, 0, 0}};
  for (std::size_t f = 0; f < 15; ++f) {
    INFO("frame " << f << " (t = " << 0.05 * static_cast<double>(f) << " s)");
    int present = 0;
    for (std::size_t agent = 0; agent < 2; ++agent) {
      const double(&want)[3] = agent == 0 ? a[f] : b[f];
      const double* wantV = agent == 0 ? (f < 9 ? va[f] : nullptr) : (f < 13 ? vb[f] : nullptr);
      const std::size_t at = 3 * (2 * f + agent);
      if (std::isnan(want[0])) {
        for (int c = 0; c < 3; ++c) {
          CHECK(std::isnan(run.pos[at + static_cast<std::size_t>(c)]));
          CHECK(std::isnan(run.vel[at + static_cast<std::size_t>(c)]));
        }
        continue;
      }
      ++present;
      for (int c = 0; c < 3; ++c) {
        const float got = run.pos[at + static_cast<std::size_t>(c)];
        if (f % 2 == 0) {
          CHECK(got == static_cast<float>(want[c]));  // on a sample: exactly the recorded value
        } else {
          CHECK(got == Approx(want[c]).margin(1e-5));
        }
        REQUIRE(wantV != nullptr);
        CHECK(run.vel[at + static_cast<std::size_t>(c)] == Approx(wantV[c]).margin(1e-3));
      }
    }
    CHECK(stat[f] == present);
  }

  // start and translate: frame 0 is the file at 0.2 s, moved by (10, 0, 0)
  swarmsim_test::writeText(
      dir.file("t.json"),
      replayScenario(0.1, 3, {{"file", "tracks.csv"}, {"start", 0.2}, {"translate", {10, 0, 0}}}).dump());
  const auto t = runSwarmsim("run t.json -o t.h5 --quiet", dir.path());
  INFO(t.err);
  REQUIRE(t.exitCode == 0);
  const Run moved = read(dir.file("t.h5"), "real");
  CHECK(moved.pos[0] == 11.0f);
  CHECK(moved.pos[1] == 2.0f);
  CHECK(moved.pos[3] == 15.0f);
  CHECK(std::isnan(moved.pos[3 * 2 * 2 + 3]));  // frame 2 (0.4 s): "b" is in its gap
}

TEST_CASE("replay: a replay of real tracks scores as the file itself, and the mixing scenario is thread-count free",
          "[replay][scenario]") {
  TempDir dir;
  const std::string scenario = swarmsim_test::kSourceTree + "/scenarios/fastswarm_mixing.json";
  const std::string tracks = swarmsim_test::kSourceTree + "/data/tracks/anopheles_moustic_36-46s.csv";
  for (const int threads : {1, 2}) {
    const auto r = runSwarmsim("run " + shellQuote(scenario) + " --fixed-threads --quiet --threads " +
                                   std::to_string(threads) + " -o t" + std::to_string(threads) + ".h5",
                               dir.path());
    INFO(r.err);
    REQUIRE(r.exitCode == 0);
  }
  for (const char* swarm : {"real", "simulated"}) {
    const Run one = read(dir.file("t1.h5"), swarm), two = read(dir.file("t2.h5"), swarm);
    INFO(swarm);
    REQUIRE(one.pos.size() == two.pos.size());
    CHECK(std::memcmp(one.pos.data(), two.pos.data(), one.pos.size() * sizeof(float)) == 0);
    CHECK(std::memcmp(one.vel.data(), two.vel.data(), one.vel.size() * sizeof(float)) == 0);
  }
  // the 36 s to 46 s excerpt, 21 mosquitoes: evaluate reads the absent agents as absent, so the replayed
  // swarm has exactly the file's samples and distributions
  const auto e = runSwarmsim("evaluate t1.h5 --swarm real --json --reference " + shellQuote(tracks), dir.path());
  INFO(e.err);
  REQUIRE(e.exitCode == 0);
  const Json j = Json::parse(e.out);
  CHECK(j["total"].get<double>() == Approx(1.0).margin(1e-9));
  for (const Json& m : j["metrics"]) {
    INFO(m["name"]);
    CHECK(m["samples_sim"] == m["samples_ref"]);
    // per individual and sample; pol and mill: one per sample (the 500 frames)
    CHECK(m["samples_sim"].get<std::int64_t>() > (m["paper"].get<bool>() || m["unit"] == "m" ? 5000 : 400));
    if (m["scored"].get<bool>()) CHECK(m["score"].get<double>() == Approx(1.0).margin(1e-5));  // float32 positions
  }
  CHECK(j["scores"]["physical"].get<double>() == Approx(1.0).margin(1e-5));
  // the simulated mosquitoes come near the replayed ones (they see them and are drawn to the same centre)
  const Run real = read(dir.file("t1.h5"), "real"), sim = read(dir.file("t1.h5"), "simulated");
  const std::size_t frames = real.shape[0], nr = real.shape[1], ns = sim.shape[1];
  std::size_t close = 0;
  for (std::size_t f = 0; f < frames; ++f) {
    for (std::size_t i = 0; i < nr; ++i) {
      const float* p = &real.pos[3 * (f * nr + i)];
      if (std::isnan(p[0])) continue;
      for (std::size_t k = 0; k < ns; ++k) {
        const float* q = &sim.pos[3 * (f * ns + k)];
        const double d2 = std::pow(p[0] - q[0], 2) + std::pow(p[1] - q[1], 2) + std::pow(p[2] - q[2], 2);
        if (d2 < 0.6 * 0.6) ++close;
      }
    }
  }
  CHECK(close > frames);  // on average more than one simulated neighbour within d_att,2 of some real one
}

TEST_CASE("replay: a fastswarm agent whose only neighbour is a replayed insect is drawn to it", "[replay][fastswarm]") {
  TempDir dir;
  // one recorded insect hovering at (0, 0, 1) for 6 s
  std::string csv = "id,time,x,y,z\n";
  for (int k = 0; k <= 300; ++k) csv += "m," + std::to_string(0.02 * k) + ",0,0,1\n";
  swarmsim_test::writeText(dir.file("hover.csv"), csv);
  Json s = replayScenario(0.02, 200, {{"file", "hover.csv"}});
  // only E_oa (attraction between d_att,1 = 0.3 and d_att,2 = 0.6 m) acts: no other term, no stimulus
  s["swarms"].push_back(Json{{"name", "fly"},
                             {"count", 1},
                             {"model", "fastswarm"},
                             {"sees", {"real"}},
                             {"initial_speed", 0.46},
                             {"spawn", {{"type", "box"}, {"min", {0.45, 0, 1}}, {"max", {0.45, 0, 1}}}},
                             {"params",
                              {{"reference", swarmsim_test::kSourceTree + "/data/reference/anopheles_moustic.h5"},
                               {"center", {0, 0, 1}},
                               {"w_rep", 0},
                               {"w_oa", 1},
                               {"w_cos", 0},
                               {"w_dir", 0},
                               {"w_acc", 0},
                               {"w_n", 0}}}});
  swarmsim_test::writeText(dir.file("sees.json"), s.dump());
  s["swarms"][1].erase("sees");
  swarmsim_test::writeText(dir.file("blind.json"), s.dump());
  for (const char* name : {"sees", "blind"}) {
    const auto r = runSwarmsim(std::string("run ") + name + ".json --quiet -o " + name + ".h5", dir.path());
    INFO(r.err);
    REQUIRE(r.exitCode == 0);
  }
  const auto distances = [&](const std::string& file) {
    const Run fly = read(dir.file(file), "fly");
    std::vector<double> d;
    for (std::size_t f = 0; f < fly.shape[0]; ++f) {
      d.push_back(std::sqrt(std::pow(fly.pos[3 * f], 2) + std::pow(fly.pos[3 * f + 1], 2) +
                            std::pow(fly.pos[3 * f + 2] - 1.0, 2)));
    }
    return d;
  };
  const std::vector<double> seeing = distances("sees.h5"), blind = distances("blind.h5");
  CHECK(seeing[1] < seeing[0]);  // its first step goes toward the replayed insect
  double lo = 1e9, hi = 0.0;
  for (const double d : seeing) lo = std::min(lo, d), hi = std::max(hi, d);
  CHECK(lo < 0.3);   // it comes inside d_att,1
  CHECK(hi < 0.47);  // and never strays (starting 0.45 away; one step is about 1 cm)
  // without "sees" the replayed insect does not exist for it: E = 0 for every candidate, and it does not
  // come near
  double blindLo = 1e9;
  for (const double d : blind) blindLo = std::min(blindLo, d);
  CHECK(blindLo > 0.35);
}

TEST_CASE("replay and sees: bad blocks are exit 2 naming the JSON path", "[replay][input]") {
  TempDir dir;
  const std::string scenario = swarmsim_test::kSourceTree + "/scenarios/fastswarm_mixing.json";
  const std::vector<swarmsim_test::Refusal> cases = {
      {"'swarms[1].sees=[\"ghosts\"]'", "swarms[1].sees[0]: expected the name of a swarm of this scenario (real, simulated)"},
      {"'swarms[1].sees=[\"simulated\"]'", "swarms[1].sees[0]: expected another swarm's name"},
      {"'swarms[1].sees=[\"real\",\"real\"]'", "swarms[1].sees[1]: expected a swarm not listed before"},
      {"'swarms[1].sees=\"real\"'", "swarms[1].sees: expected an array of swarm names"},
      {"'swarms[1].model=\"boids\"' --set 'swarms[1].params={}'", "model \"boids\" does not look at other swarms (models that do: fastswarm)"},
      {"'swarms[0].spawn={\"type\":\"sphere\",\"center\":[0,0,0],\"radius\":1}'", "swarms[0].spawn: model \"replay\" places its agents itself"},
      {"'swarms[0].count=5'", "swarms[0].count: model \"replay\" places 21 agents"},
      {"'swarms[0].params.file=\"missing.csv\"'", "swarms[0].params.file"},
      {"'swarms[0].params.start=-1'", "swarms[0].params.start"},
      {"'swarms[1].spawn=null'", "swarms[1].spawn"},
  };
  swarmsim_test::checkRefusals(scenario, cases, "places its agents itself; --agents cannot rescale it", dir.path());
}
