// swarmsim fit (issue 13): the optimiser on synthetic objectives, reproducibility, and the command end to end.
#include <catch2/catch.hpp>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "fit/fit.hpp"
#include "test_util.hpp"

using namespace swarmsim::fit;
using swarmsim_test::runSwarmsim;
using swarmsim_test::shellQuote;
using swarmsim_test::TempDir;

namespace {

// a shifted, stretched quadratic bowl with its minimum 0 at `opt`
BatchObjective bowl(const std::vector<double>& opt, std::vector<std::vector<double>>* seen = nullptr) {
  return [opt, seen](const std::vector<std::vector<double>>& xs, int) {
    std::vector<double> v;
    for (const auto& x : xs) {
      if (seen) seen->push_back(x);
      double f = 0;
      for (std::size_t k = 0; k < x.size(); ++k) f += (static_cast<double>(k) + 1.0) * (x[k] - opt[k]) * (x[k] - opt[k]);
      v.push_back(f);
    }
    return v;
  };
}

std::vector<ParamRange> box(int dims, double lo, double hi) {
  std::vector<ParamRange> b;
  for (int k = 0; k < dims; ++k) b.push_back({"p" + std::to_string(k), lo, hi});
  return b;
}

}  // namespace

TEST_CASE("fit: --param PATH=LO:HI is parsed, and bad ones are refused naming the text", "[fit]") {
  const ParamRange p = ParamRange::parse("swarms[0].params.w_rep=0.5:4");
  CHECK(p.path == "swarms[0].params.w_rep");
  CHECK(p.lo == 0.5);
  CHECK(p.hi == 4.0);
  CHECK(ParamRange::parse("dt=-1e-3:2e-2").lo == -1e-3);
  for (const char* bad : {"w_rep", "w_rep=1", "w_rep=4:0.5", "w_rep=a:2", "=1:2", "w_rep=1:inf"}) {
    INFO(bad);
    try {
      (void)ParamRange::parse(bad);
      FAIL("accepted");
    } catch (const swarmsim::InputError& e) {
      CHECK_THAT(e.what(), Catch::Matchers::Contains(std::string("\"") + bad + "\""));
    }
  }
}

TEST_CASE("fit: the optimiser finds the minimum of a synthetic objective, within the box", "[fit]") {
  const std::vector<double> opt = {0.3, -1.2, 0.8};
  std::vector<std::vector<double>> seen;
  OptimizerOptions o;
  o.budget = 600;
  o.population = 20;
  o.seed = 7;
  const OptimizeResult r = minimise(box(3, -2.0, 2.0), bowl(opt, &seen), o);
  CHECK(r.evaluations == 600);
  CHECK(r.generations == 30);
  REQUIRE(r.best.size() == 3u);
  for (int k = 0; k < 3; ++k) CHECK(r.best[static_cast<std::size_t>(k)] == Approx(opt[static_cast<std::size_t>(k)]).margin(0.05));
  CHECK(r.bestValue < 1e-2);
  for (const auto& x : seen) {
    for (double v : x) {
      CHECK(v >= -2.0);
      CHECK(v <= 2.0);
    }
  }
}

TEST_CASE("fit: the optimiser is reproducible for a seed", "[fit]") {
  OptimizerOptions o;
  o.budget = 60;
  o.population = 6;
  o.seed = 3;
  std::vector<std::vector<double>> a, b, c;
  const OptimizeResult ra = minimise(box(2, 0.0, 5.0), bowl({1.0, 4.0}, &a), o);
  const OptimizeResult rb = minimise(box(2, 0.0, 5.0), bowl({1.0, 4.0}, &b), o);
  CHECK(a == b);  // every candidate, in order
  CHECK(ra.best == rb.best);
  o.seed = 4;
  (void)minimise(box(2, 0.0, 5.0), bowl({1.0, 4.0}, &c), o);
  CHECK(a != c);
}

TEST_CASE("fit: the command fits a value back from a run made with it, and writes scenario and log", "[fit]") {
  TempDir dir;
  const std::string scen = shellQuote(std::string(SWARMSIM_SOURCE_DIR) + "/tests/data/tiny.json");
  // the reference: the midges of tiny.json flying at a jitter of 0.9
  REQUIRE(runSwarmsim("run " + scen + " -o ref.h5 --quiet --frames 60 --set 'swarms[0].params.jitter=0.9'",
                      dir.path())
              .exitCode == 0);
  const std::string common = "fit " + scen +
                             " --reference ref.h5 --swarm midges --frames 60 --param 'swarms[0].params.jitter=0.05:2'"
                             " --budget 16 --population 4 --bootstrap 20 --jobs 2 --force";
  const auto r = runSwarmsim(common + " -o best.json --log log.jsonl", dir.path());
  INFO(r.out << r.err);
  REQUIRE(r.exitCode == 0);
  CHECK_THAT(r.out, Catch::Matchers::Contains("best values:"));
  CHECK_THAT(r.out, Catch::Matchers::Contains("OU baseline S"));
  // the best scenario is a valid scenario with the fitted value
  const auto v = runSwarmsim("validate best.json", dir.path());
  REQUIRE(v.exitCode == 0);
  const nlohmann::json best = nlohmann::json::parse(swarmsim_test::readText(dir.file("best.json")));
  const double jitter = best["swarms"][0]["params"]["jitter"].get<double>();
  CHECK(jitter > 0.05);
  CHECK(jitter < 2.0);
  // the log: one line per candidate with its values and scores, then the summary
  std::ifstream in(dir.file("log.jsonl"));
  std::string line;
  int candidates = 0;
  double bestS = -1, bestJitter = 0;
  nlohmann::json summary;
  while (std::getline(in, line)) {
    const nlohmann::json j = nlohmann::json::parse(line);
    if (j.contains("summary")) {
      summary = j["summary"];
      continue;
    }
    ++candidates;
    REQUIRE(j["seeds"].size() == 1u);
    CHECK(j["seeds"][0]["S_ci"].is_array());
    const double s = j["S_mean"].get<double>();
    if (s > bestS) {
      bestS = s;
      bestJitter = j["params"]["swarms[0].params.jitter"].get<double>();
    }
  }
  CHECK(candidates == 16);
  CHECK(bestJitter == jitter);  // the scenario holds the best logged candidate
  CHECK(summary["evaluations"] == 16);
  // the true value scores higher than the ends of the range, and the fit lands nearer it than the worst end
  CHECK(std::abs(jitter - 0.9) < 0.6);
  // reproducible: the same fit again gives the same log
  REQUIRE(runSwarmsim(common + " -o best2.json --log log2.jsonl", dir.path()).exitCode == 0);
  std::string a = swarmsim_test::readText(dir.file("log.jsonl")), b = swarmsim_test::readText(dir.file("log2.jsonl"));
  a = a.substr(0, a.rfind("{\"summary\""));  // the summary holds the wall time
  b = b.substr(0, b.rfind("{\"summary\""));
  CHECK(a == b);
  CHECK(swarmsim_test::readText(dir.file("best.json")) == swarmsim_test::readText(dir.file("best2.json")));
}

TEST_CASE("fit: bad input is exit 2 naming what is wrong, an existing output exit 3", "[fit]") {
  TempDir dir;
  const std::string scen = shellQuote(std::string(SWARMSIM_SOURCE_DIR) + "/tests/data/tiny.json");
  REQUIRE(runSwarmsim("run " + scen + " -o ref.h5 --quiet --frames 20", dir.path()).exitCode == 0);
  auto r = runSwarmsim("fit " + scen + " --reference ref.h5 --swarm midges --param 'swarms[0].params.nothing=0:1' -o b.json",
                       dir.path());
  CHECK(r.exitCode == 2);
  CHECK_THAT(r.err, Catch::Matchers::Contains("nothing"));
  r = runSwarmsim("fit " + scen + " --reference ref.h5 --swarm midges --param 'swarms[0].params.jitter=2:1' -o b.json",
                  dir.path());
  CHECK(r.exitCode == 2);
  CHECK_THAT(r.err, Catch::Matchers::Contains("LO must be below HI"));
  r = runSwarmsim("fit " + scen + " --reference missing.csv --param 'swarms[0].params.jitter=0:1' -o b.json", dir.path());
  CHECK(r.exitCode == 2);
  CHECK_THAT(r.err, Catch::Matchers::Contains("missing.csv"));
  swarmsim_test::writeText(dir.file("b.json"), "{}\n");
  r = runSwarmsim("fit " + scen + " --reference ref.h5 --swarm midges --param 'swarms[0].params.jitter=0.1:1' -o b.json",
                  dir.path());
  CHECK(r.exitCode == 3);
  CHECK(swarmsim_test::readText(dir.file("b.json")) == "{}\n");
}
