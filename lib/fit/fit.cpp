#include "fit/fit.hpp"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <pagmo/algorithms/pso_gen.hpp>
#include <pagmo/bfe.hpp>
#include <pagmo/population.hpp>
#include <pagmo/problem.hpp>
#include <sstream>

#include "core/error.hpp"
#include "core/threads.hpp"
#include "io/atomic_file.hpp"
#include "io/scenario.hpp"

extern char** environ;

namespace swarmsim::fit {

namespace fs = std::filesystem;

ParamRange ParamRange::parse(const std::string& text) {
  const auto bad = [&](const std::string& why) {
    return InputError("--param \"" + text + "\": " + why +
                      " (expected PATH=LO:HI, e.g. swarms[0].params.w_rep=0.5:4, with the paths of --set)");
  };
  const auto eq = text.rfind('=');
  if (eq == std::string::npos || eq == 0) throw bad("no PATH=");
  ParamRange p;
  p.path = text.substr(0, eq);
  const std::string range = text.substr(eq + 1);
  const auto colon = range.find(':');
  if (colon == std::string::npos) throw bad("no LO:HI");
  const auto number = [&](const std::string& s) {
    char* end = nullptr;
    const double v = std::strtod(s.c_str(), &end);
    if (s.empty() || *end != '\0' || !std::isfinite(v)) throw bad("\"" + s + "\" is not a number");
    return v;
  };
  p.lo = number(range.substr(0, colon));
  p.hi = number(range.substr(colon + 1));
  if (!(p.lo < p.hi)) throw bad("LO must be below HI");
  return p;
}

namespace {

// pagmo's problem: the box, and a single fitness that goes through the batch objective
struct Problem {
  std::vector<double> lo, hi;
  const BatchObjective* objective = nullptr;
  const int* generation = nullptr;
  pagmo::vector_double fitness(const pagmo::vector_double& x) const { return {(*objective)({x}, *generation)[0]}; }
  std::pair<pagmo::vector_double, pagmo::vector_double> get_bounds() const { return {lo, hi}; }
};

// pagmo's batch fitness evaluator: a whole generation at once, so the objective can run it in parallel
struct Batch {
  const BatchObjective* objective = nullptr;
  const int* generation = nullptr;
  pagmo::vector_double operator()(const pagmo::problem& p, const pagmo::vector_double& dvs) const {
    const std::size_t dim = p.get_nx();
    std::vector<std::vector<double>> rows;
    for (std::size_t i = 0; i + dim <= dvs.size(); i += dim) rows.emplace_back(dvs.begin() + static_cast<std::ptrdiff_t>(i), dvs.begin() + static_cast<std::ptrdiff_t>(i + dim));
    return (*objective)(rows, *generation);
  }
};

}  // namespace

OptimizeResult minimise(const std::vector<ParamRange>& box, const BatchObjective& evaluate,
                        const OptimizerOptions& options) {
  if (box.empty()) throw InputError("fit: no --param to fit");
  if (options.population < 2) throw InputError("--population: expected at least 2");
  if (options.budget < 1) throw InputError("--budget: expected at least 1 candidate");
  OptimizeResult best;
  best.bestValue = std::numeric_limits<double>::infinity();
  int generation = 0;
  // every evaluation passes here: the best of all (the first on a tie), whatever pagmo keeps
  const BatchObjective tracked = [&](const std::vector<std::vector<double>>& rows, int gen) {
    std::vector<double> v = evaluate(rows, gen);
    for (std::size_t i = 0; i < rows.size(); ++i) {
      ++best.evaluations;
      if (v[i] < best.bestValue) {
        best.bestValue = v[i];
        best.best = rows[i];
      }
    }
    return v;
  };
  Problem udp;
  for (const ParamRange& p : box) {
    udp.lo.push_back(p.lo);
    udp.hi.push_back(p.hi);
  }
  udp.objective = &tracked;
  udp.generation = &generation;
  const Batch udbfe{&tracked, &generation};
  const auto seed = static_cast<unsigned>(options.seed ^ (options.seed >> 32));
  const int P = options.population;
  const int G = (options.budget + P - 1) / P;
  pagmo::problem prob(udp);
  pagmo::population pop(prob, pagmo::bfe(udbfe), static_cast<pagmo::population::size_type>(P), seed);
  best.generations = 1;
  // pso_gen one generation per call, its velocities and memory kept between calls
  pagmo::pso_gen algo(1u, 0.7298, 2.05, 2.05, 0.5, 5u, 2u, 4u, true, seed);
  algo.set_bfe(pagmo::bfe(udbfe));
  for (generation = 1; generation < G; ++generation) {
    pop = algo.evolve(pop);
    ++best.generations;
  }
  return best;
}

namespace {

std::atomic<bool> gFitStop{false};
extern "C" void onFitSignal(int) { gFitStop.store(true); }

struct Job {
  std::size_t candidate = 0;
  int seedIndex = 0;
  std::vector<std::string> argv;
  std::string output, log;
  pid_t pid = -1;
  int status = -1;
};

// run jobs, at most `parallel` at a time; returns when all ended (or throws on an interrupt, killing them)
void runJobs(std::vector<Job>& jobs, int parallel) {
  std::size_t next = 0, running = 0;
  std::map<pid_t, std::size_t> live;
  const auto killAll = [&]() {
    for (auto& [pid, j] : live) kill(pid, SIGTERM);
    for (auto& [pid, j] : live) waitpid(pid, nullptr, 0);
  };
  while (next < jobs.size() || running > 0) {
    while (running < static_cast<std::size_t>(parallel) && next < jobs.size()) {
      Job& j = jobs[next];
      std::vector<char*> args;
      for (auto& a : j.argv) args.push_back(a.data());
      args.push_back(nullptr);
      posix_spawn_file_actions_t fa;
      posix_spawn_file_actions_init(&fa);
      posix_spawn_file_actions_addopen(&fa, 0, "/dev/null", O_RDONLY, 0);
      posix_spawn_file_actions_addopen(&fa, 1, j.log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      posix_spawn_file_actions_adddup2(&fa, 1, 2);
      pid_t pid = -1;
      const int rc = posix_spawn(&pid, args[0], &fa, nullptr, args.data(), environ);
      posix_spawn_file_actions_destroy(&fa);
      if (rc != 0) {
        killAll();
        throw std::runtime_error(std::string("fit: cannot start ") + args[0] + ": " + std::strerror(rc));
      }
      j.pid = pid;
      live[pid] = next;
      ++running;
      ++next;
    }
    int status = 0;
    const pid_t done = waitpid(-1, &status, 0);
    if (done < 0) {
      if (errno == EINTR) {
        if (gFitStop.load()) {
          killAll();
          throw Error(kExitInterrupted, "fit: interrupted; nothing written");
        }
        continue;
      }
      killAll();
      throw std::runtime_error(std::string("fit: waitpid: ") + std::strerror(errno));
    }
    auto it = live.find(done);
    if (it == live.end()) continue;
    jobs[it->second].status = status;
    live.erase(it);
    --running;
    if (gFitStop.load()) {
      killAll();
      throw Error(kExitInterrupted, "fit: interrupted; nothing written");
    }
  }
}

std::string tail(const std::string& path, std::size_t n) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  std::string s = ss.str();
  return s.size() > n ? "..." + s.substr(s.size() - n) : s;
}

std::string number(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

std::string duration(double s) {
  char buf[64];
  if (s < 90) {
    std::snprintf(buf, sizeof buf, "%.0f s", s);
  } else if (s < 5400) {
    std::snprintf(buf, sizeof buf, "%.1f min", s / 60);
  } else {
    std::snprintf(buf, sizeof buf, "%.1f h", s / 3600);
  }
  return buf;
}

struct SeedScore {
  double s = 0, e = 0;
  eval::Interval ci;
  bool ok = false;
  std::string error;
};

// what --force may replace: a file that starts as a JSON object (a scenario or a JSON-lines log), checked
// before the work and again when the file is written
bool looksLikeJson(const std::string& path) {
  std::ifstream in(path);
  return in.peek() == '{';
}

nlohmann::json intervalJson(const eval::Interval& iv) {
  return iv.valid ? nlohmann::json::array({iv.lo, iv.hi}) : nlohmann::json(nullptr);
}

}  // namespace

int runFit(const FitOptions& o, std::ostream& out, std::ostream& err) {
  if (o.params.empty()) throw InputError("fit: give at least one --param PATH=LO:HI");
  if (o.seeds < 1) throw InputError("--seeds: expected at least 1");
  if (o.output.empty()) throw InputError("fit: -o BEST.json is required (the best scenario is written there)");
  // every path and both ends of every range must make a valid scenario; the reference must read
  std::vector<std::string> base = o.sets;
  for (const ParamRange& p : o.params) {
    for (double v : {p.lo, p.hi}) {
      std::vector<std::string> sets = base;
      sets.push_back(p.path + "=" + number(v));
      try {
        (void)loadScenario(o.scenario, sets);
      } catch (const InputError& e) {
        throw InputError(std::string(e.what()) + " (with --param " + p.path + " at " + number(v) + ")");
      }
    }
  }
  const Scenario plain = loadScenario(o.scenario, base);
  {
    eval::SourceOptions so = o.eval.source;
    if (o.eval.refFrames) so.frames = *o.eval.refFrames;
    (void)eval::openTracks(o.reference, so);
    if (!o.validate.empty()) {
      if (o.validateFrames) so.frames = *o.validateFrames;
      (void)eval::openTracks(o.validate, so);
    }
  }
  // refuse the outputs before the work, as run does
  for (const std::string& path : {o.output, o.log}) {
    if (path.empty()) continue;
    const std::string why = refusalToWrite(path, o.force, looksLikeJson);
    if (!why.empty()) throw OutputError(why);
  }

  const int cpus = std::max(1, defaultThreadCount());
  const int jobs = o.jobs > 0 ? o.jobs : cpus;
  const int threadsPerRun = std::max(1, cpus / jobs);
  char tmpl[] = "/tmp/swarmsim-fit-XXXXXX";
  const char* made = mkdtemp(tmpl);
  if (!made) throw OutputError(std::string("fit: cannot make a temporary folder: ") + std::strerror(errno));
  const fs::path tmp(made);
  struct Cleanup {
    fs::path p;
    ~Cleanup() {
      std::error_code ec;
      fs::remove_all(p, ec);
    }
  } cleanup{tmp};

  struct sigaction sa {};
  sa.sa_handler = onFitSignal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);

  const auto t0 = std::chrono::steady_clock::now();
  const auto elapsed = [&]() { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); };
  const std::int64_t scenarioSeed = plain.resolved.value("seed", static_cast<std::int64_t>(1));
  nlohmann::json logLines = nlohmann::json::array();
  int evaluated = 0;
  double bestS = -1;
  const int total = ((o.budget + o.population - 1) / o.population) * o.population;
  const bool tty = isatty(STDERR_FILENO);

  // runs candidates x seeds, scores each run against `tracks`
  const auto score = [&](const std::vector<std::vector<double>>& xs, const std::string& tracks, const std::string& tag,
                         bool baseline, std::vector<std::vector<SeedScore>>& scores,
                         std::vector<eval::EvaluationResult>* results) {
    std::vector<Job> list;
    for (std::size_t c = 0; c < xs.size(); ++c) {
      for (int s = 0; s < o.seeds; ++s) {
        Job j;
        j.candidate = c;
        j.seedIndex = s;
        const std::string stem = tag + "_" + std::to_string(c) + "_" + std::to_string(s);
        j.output = (tmp / (stem + ".h5")).string();
        j.log = (tmp / (stem + ".log")).string();
        j.argv = {o.exe, "run", o.scenario, "-o", j.output, "--quiet", "--force", "--threads",
                  std::to_string(threadsPerRun), "--fixed-threads", "--seed", std::to_string(scenarioSeed + s)};
        if (o.frames > 0) {
          j.argv.push_back("--frames");
          j.argv.push_back(std::to_string(o.frames));
        }
        for (const std::string& set : o.sets) {
          j.argv.push_back("--set");
          j.argv.push_back(set);
        }
        for (std::size_t k = 0; k < o.params.size(); ++k) {
          j.argv.push_back("--set");
          j.argv.push_back(o.params[k].path + "=" + number(xs[c][k]));
        }
        list.push_back(std::move(j));
      }
    }
    runJobs(list, jobs);
    scores.assign(xs.size(), std::vector<SeedScore>(static_cast<std::size_t>(o.seeds)));
    for (Job& j : list) {
      SeedScore& sc = scores[j.candidate][static_cast<std::size_t>(j.seedIndex)];
      if (!(WIFEXITED(j.status) && WEXITSTATUS(j.status) == 0)) {
        sc.error = "the run failed (" +
                   (WIFEXITED(j.status) ? "exit code " + std::to_string(WEXITSTATUS(j.status)) : std::string("killed")) +
                   "): " + tail(j.log, 400);
        continue;
      }
      eval::EvaluateOptions eo = o.eval;
      if (tag == "valid" && o.validateFrames) eo.refFrames = o.validateFrames;
      eo.sim = j.output;
      eo.reference = tracks;
      eo.json = false;
      eo.baseline = baseline;
      try {
        eval::EvaluationResult r = eval::evaluate(eo);
        sc.s = r.summary.physical;
        sc.e = r.summary.wang2015;
        sc.ci = r.summary.physicalCi;
        sc.ok = std::isfinite(sc.s);
        if (results) results->push_back(std::move(r));
      } catch (const InputError& e) {
        sc.error = std::string("evaluate: ") + e.what();
      }
      std::error_code ec;
      fs::remove(j.output, ec);
      fs::remove(j.log, ec);
    }
  };

  const BatchObjective objective = [&](const std::vector<std::vector<double>>& xs, int generation) {
    std::vector<std::vector<SeedScore>> scores;
    score(xs, o.reference, "g" + std::to_string(generation), false, scores, nullptr);
    std::vector<double> values(xs.size());
    for (std::size_t c = 0; c < xs.size(); ++c) {
      double sum = 0;
      bool ok = true;
      nlohmann::json perSeed = nlohmann::json::array();
      std::string error;
      for (const SeedScore& sc : scores[c]) {
        ok = ok && sc.ok;
        if (!sc.ok && error.empty()) error = sc.error;
        sum += sc.ok ? sc.s : 0.0;
        perSeed.push_back({{"S", sc.ok ? nlohmann::json(sc.s) : nlohmann::json(nullptr)},
                           {"S_ci", intervalJson(sc.ci)},
                           {"E", sc.ok ? nlohmann::json(sc.e) : nlohmann::json(nullptr)}});
      }
      const double meanS = ok ? sum / o.seeds : 0.0;
      values[c] = 1.0 - meanS + (ok ? 0.0 : 1.0);  // a failed run ranks below every scored one
      nlohmann::json line = {{"generation", generation}, {"index", evaluated}, {"params", nlohmann::json::object()}};
      for (std::size_t k = 0; k < o.params.size(); ++k) line["params"][o.params[k].path] = xs[c][k];
      line["seeds"] = perSeed;
      line["S_mean"] = ok ? nlohmann::json(meanS) : nlohmann::json(nullptr);
      line["objective"] = values[c];
      if (!ok) {
        line["error"] = error;
        err << "\nswarmsim: warning: fit: candidate " << evaluated << ": " << error << "\n";
      }
      logLines.push_back(line);
      ++evaluated;
      if (ok) bestS = std::max(bestS, meanS);
    }
    const double t = elapsed();
    const double eta = evaluated > 0 ? t / evaluated * (total - evaluated) : 0.0;
    char buf[256];
    std::snprintf(buf, sizeof buf, "fit: %d/%d candidates (generation %d), best S %.4f, %s elapsed, ETA %s", evaluated,
                  total, generation + 1, bestS, duration(t).c_str(), duration(eta).c_str());
    err << (tty ? "\r\033[K" : "") << buf << (tty ? "" : "\n") << std::flush;
    return values;
  };

  OptimizerOptions oo;
  oo.budget = o.budget;
  oo.population = o.population;
  oo.seed = o.seed;
  const OptimizeResult best = minimise(o.params, objective, oo);
  if (tty) err << "\n";
  if (best.best.empty()) throw Error(kExitOther, "fit: no candidate could be scored (every run failed; see the warnings)");

  // the best candidate, scored again (same seeds, same runs) with the baseline, and on the validation data
  std::vector<std::vector<SeedScore>> fitScores, validScores;
  std::vector<eval::EvaluationResult> fitResults, validResults;
  score({best.best}, o.reference, "best", true, fitScores, &fitResults);
  if (!o.validate.empty()) score({best.best}, o.validate, "valid", true, validScores, &validResults);

  std::vector<std::string> bestSets = o.sets;
  for (std::size_t k = 0; k < o.params.size(); ++k) bestSets.push_back(o.params[k].path + "=" + number(best.best[k]));
  const Scenario bestScenario = loadScenario(o.scenario, bestSets);

  // the report
  std::ostringstream rep;
  char buf[512];
  std::snprintf(buf, sizeof buf, "fit: %d candidates in %d generations (population %d, pso_gen, seed %llu), %d seed(s) each, %s\n",
                best.evaluations, best.generations, o.population, static_cast<unsigned long long>(o.seed), o.seeds,
                duration(elapsed()).c_str());
  rep << buf << "best values:\n";
  for (std::size_t k = 0; k < o.params.size(); ++k) {
    std::snprintf(buf, sizeof buf, "  %s = %.6g   (range %g .. %g)\n", o.params[k].path.c_str(), best.best[k],
                  o.params[k].lo, o.params[k].hi);
    rep << buf;
  }
  nlohmann::json summary = {{"budget", o.budget}, {"evaluations", best.evaluations}, {"generations", best.generations},
                            {"seeds", o.seeds}, {"wall_seconds", elapsed()}, {"best", nlohmann::json::object()}};
  for (std::size_t k = 0; k < o.params.size(); ++k) summary["best"][o.params[k].path] = best.best[k];
  const auto report = [&](const char* label, const std::string& tracks, const std::vector<eval::EvaluationResult>& rs,
                          const char* key) {
    nlohmann::json runs = nlohmann::json::array();
    for (std::size_t s = 0; s < rs.size(); ++s) {
      const eval::EvaluationResult& r = rs[s];
      std::snprintf(buf, sizeof buf,
                    "%s (%s), seed %lld: S = %.4f [%.3f, %.3f], E = %.4f; OU baseline S = %.4f [%.3f, %.3f]\n", label,
                    tracks.c_str(), static_cast<long long>(scenarioSeed + static_cast<std::int64_t>(s)), r.summary.physical,
                    r.summary.physicalCi.lo, r.summary.physicalCi.hi, r.summary.wang2015,
                    r.baseline ? r.baseline->physical : NAN, r.baseline ? r.baseline->physicalCi.lo : NAN,
                    r.baseline ? r.baseline->physicalCi.hi : NAN);
      rep << buf;
      runs.push_back({{"S", r.summary.physical},
                      {"S_ci", intervalJson(r.summary.physicalCi)},
                      {"E", r.summary.wang2015},
                      {"baseline_S", r.baseline ? nlohmann::json(r.baseline->physical) : nlohmann::json(nullptr)},
                      {"baseline_S_ci", r.baseline ? intervalJson(r.baseline->physicalCi) : nlohmann::json(nullptr)}});
    }
    summary[key] = runs;
  };
  report("fit data       ", o.reference, fitResults, "fit_data");
  if (!o.validate.empty()) report("validation data", o.validate, validResults, "validation_data");

  // outputs, each atomically
  {
    AtomicFile f(o.output, o.force, looksLikeJson);
    const std::string text = bestScenario.resolved.dump(2) + "\n";
    f.write(text.data(), text.size());
    f.commit();
  }
  if (!o.log.empty()) {
    AtomicFile f(o.log, o.force, looksLikeJson);
    for (const auto& line : logLines) {
      const std::string text = line.dump() + "\n";
      f.write(text.data(), text.size());
    }
    const std::string text = nlohmann::json{{"summary", summary}}.dump() + "\n";
    f.write(text.data(), text.size());
    f.commit();
  }
  rep << "best scenario: " << o.output << (o.log.empty() ? "" : ", log: " + o.log) << "\n";
  out << rep.str();
  return kExitOk;
}

}  // namespace swarmsim::fit
