#pragma once
// `swarmsim bench`: time scenarios without writing trajectories.
#include <cstdint>
#include <iosfwd>
#include <string>
#include <vector>

#include "core/json_reader.hpp"

namespace swarmsim {

struct BenchOptions {
  std::vector<std::string> scenarios;  // files; empty: the built-in cases
  std::vector<std::string> cases;      // with no files: only these built-in cases (builtinBenchCases()); empty: all
  std::vector<std::int64_t> agents;    // rescale to these totals (density kept); empty: as in the scenario
  std::vector<int> threads;            // thread counts; empty: the current default
  std::vector<std::string> overrides;  // --set PATH=VALUE, applied to every scenario
  std::int64_t frames = 0;             // frames to time (0: min(scenario frames, 10))
  std::int64_t skip = 0;               // frames stepped untimed before them (after the first step)
  int repeat = 3;                      // repetitions; the median is reported
  bool json = false;                   // JSON lines instead of a table
};

struct BenchRow {
  std::string scenario, model;
  std::int64_t agents = 0;
  int threads = 0;
  double preprocessSeconds = 0.0;  // median
  double stepsPerSecond = 0.0;     // median
  double nsPerAgentStep = 0.0;     // from the median steps/s
  std::int64_t steps = 0;          // steps timed per repetition
  std::int64_t skipped = 0;        // steps run untimed before them (--skip), besides the first
  double threadsUsed = 0.0;        // the thread team over the timed steps, averaged (median over repetitions)
  Json modelInfo;                  // per swarm, Model::benchInfo() (last repetition)
};

// names of the built-in cases
std::vector<std::string> builtinBenchCases();
std::vector<BenchRow> runBench(const BenchOptions& options, std::ostream& out);

}  // namespace swarmsim
