#pragma once
// `swarmsim fit`: tune any model's numeric scenario values against real tracks (docs/evaluation.md#fit).
//
// The objective of a candidate x (one value per --param PATH=LO:HI, set with the same paths as `run --set`)
// is 1 - S, with S the physical score of `swarmsim evaluate` (eval/score.hpp) of the scenario run with x,
// averaged over K seeds (--seeds; the scenario's seed + 0 .. K-1: every candidate is run with the same seeds,
// so the objective is a deterministic function of x). The runs are child processes of this same binary
// (`swarmsim run ... --threads T --quiet`), J at a time (--jobs, default: the CPUs, with T = 1), so the
// candidates of one generation and their seeds run in parallel on all cores.
//
// The optimiser is pagmo2's generational particle swarm (pagmo::pso_gen, Debian's libpagmo-dev), chosen
// because it evaluates a whole generation as one batch (pagmo's batch fitness evaluator), which is what lets
// the runs go in parallel; its own random numbers come from --seed, so a fit is reproducible for a seed.
// --budget N candidates in all: a population of P (--population, default 8) per generation, ceil(N / P)
// generations. The best candidate is the one with the lowest objective of all evaluated (the first on a tie).
//
// Output: the best scenario (the input scenario with the best values set, resolved as `validate` prints it)
// as JSON (-o), and a log of every candidate (--log, JSON lines: generation, index, the values, per seed S
// with its bootstrap interval and E, the mean S, the objective). --validate TRACKS2 scores the best
// candidate against a second data set that the fit never saw, with the same seeds (--validate-frames picks
// its samples, e.g. the other half of the reference file).
#include <cstdint>
#include <functional>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "eval/score.hpp"

namespace swarmsim::fit {

struct ParamRange {
  std::string path;
  double lo = 0, hi = 0;
  // "PATH=LO:HI"; throws InputError naming the text
  static ParamRange parse(const std::string& text);
};

// minimise a batch objective over a box with pagmo's pso_gen
struct OptimizerOptions {
  int budget = 40;      // candidates evaluated in all (at least one generation)
  int population = 8;   // candidates per generation
  std::uint64_t seed = 1;
};
struct OptimizeResult {
  std::vector<double> best;
  double bestValue = 0;
  int evaluations = 0;
  int generations = 0;
};
// evaluate(batch, generation) -> one objective value per row of batch
using BatchObjective = std::function<std::vector<double>(const std::vector<std::vector<double>>&, int)>;
OptimizeResult minimise(const std::vector<ParamRange>& box, const BatchObjective& evaluate,
                        const OptimizerOptions& options);

struct FitOptions {
  std::string scenario, reference, validate;
  std::vector<ParamRange> params;
  std::vector<std::string> sets;  // fixed --set overrides applied to every run
  int budget = 40, population = 8, seeds = 1, jobs = 0, frames = -1;
  std::uint64_t seed = 1;
  eval::EvaluateOptions eval;  // swarm, sim/ref frames, scale, bootstrap (reference and sim are filled per run)
  std::optional<eval::FrameRange> validateFrames;  // samples of --validate (default: --ref-frames)
  std::string output;          // best scenario JSON
  std::string log;             // JSON lines
  bool force = false;
  std::string exe;             // this binary
};

// runs the fit; prints progress to err and a summary to out; returns the exit code
int runFit(const FitOptions& options, std::ostream& out, std::ostream& err);

}  // namespace swarmsim::fit
