#include "bench.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ostream>
#include <sstream>
#include <stdexcept>

#include "core/error.hpp"
#include "core/parallel.hpp"
#include "core/threads.hpp"
#include "core/rng.hpp"
#include "io/scenario.hpp"
#include "orca/orca.hpp"
#include "run.hpp"
#include "spatial/uniform_grid.hpp"

namespace swarmsim {

namespace {

struct BuiltinCase {
  const char* name;
  const char* json;
  // a variant: `json` names an earlier case and these are `--set` assignments on it (one per line)
  const char* overrides = nullptr;
};

// Built-in cases. boids-100k: 100,000 boids with the default zones (outer
// radius 0.3 m) at 88 agents/m^3, i.e. about 10 neighbours inside the
// attraction radius (88 * 4/3 pi 0.3^3 = 10.0).
const BuiltinCase kCases[] = {
    {"fmm-128", R"({
      "name": "fmm-128", "description": "fast marching alone: a 128^3 cost grid, one point goal, no obstacles",
      "seed": 1, "dt": 0.01, "frames": 2, "steps_per_frame": 1,
      "domain": {"min": [0, 0, 0], "max": [128, 128, 128]},
      "swarms": [{"name": "probe", "count": 1, "model": "field",
                  "spawn": {"type": "sphere", "center": [10, 10, 10], "radius": 0},
                  "params": {"speed": 1.0, "cost_cells": [128, 128, 128],
                             "noise": {"cells": [4, 4, 4], "gain": 0},
                             "goals": [{"type": "sphere", "center": [64, 64, 64], "radius": 0.5}]}}]
    })"},
    {"fmm-128-order2", "fmm-128", "name=fmm-128-order2\nswarms[0].params.cost_order=2"},
    {"boids-100k", R"({
      "name": "boids-100k", "seed": 7, "dt": 0.01, "frames": 20, "steps_per_frame": 1,
      "domain": {"min": [-12, -12, -12], "max": [12, 12, 12]},
      "swarms": [{"name": "boids", "count": 100000, "model": "boids", "initial_speed": 0.5,
                  "spawn": {"type": "sphere", "center": [0, 0, 0], "radius": 6.463},
                  "params": {"jitter": 0.05}}]
    })"},
};

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

using Clock = std::chrono::steady_clock;

// The field model's rows again, in the columns of wang2014's Table 1: per swarm,
// agents, noise scale and gain, s0, grid, preprocessing split, steps/s, MDE %.
void printTable1(const std::vector<BenchRow>& rows, std::ostream& out) {
  bool header = false;
  char line[320];
  for (const auto& row : rows) {
    for (const auto& info : row.modelInfo) {
      if (!info.contains("cost_grid")) continue;
      if (!header) {
        out << "\nTable 1 columns (field model):\n";
        std::snprintf(line, sizeof line, "%-20s %9s %6s %6s %5s %-13s %10s %8s %8s %8s %10s %7s\n", "scenario",
                      "agents", "scale", "gain", "s0", "cost grid", "distance_s", "cost_s", "fmm_s", "noise_s",
                      "steps/s", "MDE_%");
        out << line;
        header = true;
      }
      std::snprintf(line, sizeof line, "%-20s %9lld %6.3g %6.3g %5.3g %-13s %10.4f %8.4f %8.4f %8.4f %10.1f %7.2f\n",
                    (row.scenario + (row.modelInfo.size() > 1 ? "/" + info.value("swarm", std::string()) : "")).c_str(),
                    static_cast<long long>(info.value("agents", row.agents)), info.value("scale", 0.0),
                    info.value("gain", 0.0), info.value("s0", 0.0), info.value("cost_grid", std::string()).c_str(),
                    info.value("t_distance", 0.0), info.value("t_cost", 0.0), info.value("t_fast_marching", 0.0),
                    info.value("t_noise", 0.0), row.stepsPerSecond, info.value("mde_percent", 0.0));
      out << line;
    }
  }
}

// One result row: a JSON line, or a table line (with the header before the
// first) followed by one line of model facts per swarm that has any.
void printRow(const BenchRow& row, const BenchOptions& options, std::ostream& out, bool& headerDone) {
  char line[256];
  if (options.json) {
    Json j = {{"scenario", row.scenario},
              {"model", row.model},
              {"agents", row.agents},
              {"threads", row.threads},
              {"preprocess_s", row.preprocessSeconds},
              {"steps_per_s", row.stepsPerSecond},
              {"ns_per_agent_step", row.nsPerAgentStep},
              {"steps", row.steps},
              {"skipped_steps", row.skipped},
              {"threads_used", row.threadsUsed},
              {"repeat", options.repeat},
              {"model_info", row.modelInfo}};
    out << j.dump() << "\n";
    out.flush();
    return;
  }
  if (!headerDone) {
    std::snprintf(line, sizeof line, "%-24s %-10s %10s %7s %13s %12s %14s\n", "scenario", "model", "agents", "threads",
                  "preprocess_s", "steps/s", "ns/agent-step");
    out << line;
    headerDone = true;
  }
  std::snprintf(line, sizeof line, "%-24s %-10s %10lld %7d %13.4f %12.2f %14.1f\n", row.scenario.c_str(),
                row.model.c_str(), static_cast<long long>(row.agents), row.threads, row.preprocessSeconds,
                row.stepsPerSecond, row.nsPerAgentStep);
  out << line;
  // model facts (e.g. the field model's Table 1 columns)
  for (const Json& info : row.modelInfo) {
    if (info.empty()) continue;
    std::string facts;
    for (const auto& item : info.items()) {
      if (item.key() == "swarm" || item.key() == "agents") continue;
      std::string v;
      if (item.value().is_number_float()) {
        char num[32];
        std::snprintf(num, sizeof num, "%.4g", item.value().get<double>());
        v = num;
      } else if (item.value().is_array() && item.value().size() > 2) {
        // a long list (the shape model's keyframes: one per mesh and time) would bury the table
        v = "[" + std::to_string(item.value().size()) + " entries; --json lists them]";
      } else {
        v = item.value().is_string() ? item.value().get<std::string>() : item.value().dump();
      }
      facts += " " + item.key() + "=" + v;
    }
    out << "    " << info.value("swarm", std::string()) << ":" << facts << "\n";
  }
  out.flush();
}

// Steps (step() per call) until the thread governor has chosen its team, at most 3 s: on a busy
// machine, before timing. Callers time a fresh run afterwards, so the same steps are timed whatever
// the governor did.
template <typename F>
void untilSettled(F&& step) {
  for (const auto w0 = Clock::now();
       !threadsSettled() && std::chrono::duration<double>(Clock::now() - w0).count() < 3.0;) {
    step();
  }
}

// orca-100k: the ORCA solver alone (lib/orca, docs/orca.md), no model. 100,000
// agents on a cubic lattice of spacing 4 m (47 per side, the top layer partly
// filled), at rest, radius 1.5 m, maxNeighbors 10, neighborDistance 15 m, both
// time horizons 10 s, maxSpeed 2 m/s, dt 0.25 s; each flies at maxSpeed towards
// its own random goal in the cube (AgentRng, seed 1). A step bins the agents on
// a UniformGrid (minCell = neighborDistance, as a model would; timed apart as
// grid_ms), solves, and moves them. Rows: steps/s and ns/agent-step of
// neighbours + ORCA (medians over all timed steps of all repetitions).
// --agents N puts N agents on the same lattice; --set does not apply.
constexpr const char* kOrcaCase = "orca-100k";

void runOrcaBench(const BenchOptions& options, const std::vector<std::int64_t>& agentsList,
                  const std::vector<int>& threadList, std::ostream& out, bool& headerDone,
                  std::vector<BenchRow>& rows) {
  orca::Params params;
  params.radius = 1.5f;
  params.maxNeighbors = 10;
  params.neighborDistance = 15.0f;
  params.timeHorizon = 10.0f;
  params.timeHorizonObstacle = 10.0f;
  params.maxSpeed = 2.0f;
  const float dt = 0.25f, spacing = 4.0f;
  const std::int64_t steps = options.frames > 0 ? options.frames : 10;
  for (const std::int64_t requested : agentsList) {
    const auto n = static_cast<std::size_t>(requested > 0 ? requested : 100000);
    auto side = static_cast<std::size_t>(std::cbrt(static_cast<double>(n)));
    while (side * side * side < n) ++side;
    const float extent = spacing * static_cast<float>(side - 1);
    for (const int threads : threadList) {
      requestThreads(threads);
      std::vector<double> pre, neighbours, lp, grid, total, team;
      std::size_t infeasible = 0;
      for (int r = 0; r < std::max(1, options.repeat); ++r) {
        const auto t0 = Clock::now();
        // state in the grid's order after each step (x, v, goal move together)
        std::vector<float> x(n), y(n), z(n), vx(n), vy(n), vz(n), gx(n), gy(n), gz(n);
        const auto start = [&] {
          for (std::size_t i = 0; i < n; ++i) {
            x[i] = spacing * static_cast<float>(i % side);
            y[i] = spacing * static_cast<float>((i / side) % side);
            z[i] = spacing * static_cast<float>(i / (side * side));
            vx[i] = vy[i] = vz[i] = 0.0f;
            AgentRng rng(1, 0, static_cast<std::uint32_t>(i), RngPurpose::kSpawnPosition);
            gx[i] = rng.uniform(0.0f, extent);
            gy[i] = rng.uniform(0.0f, extent);
            gz[i] = rng.uniform(0.0f, extent);
          }
        };
        start();
        std::vector<float> px(n), py(n), pz(n), ox(n), oy(n), oz(n), tmp;
        UniformGrid uniformGrid;
        orca::Solver solver;
        pre.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
        // one step; returns the grid's build time
        const auto step = [&]() -> double {
          threadTick();  // as Simulation::step does: fewer threads on a busy machine
          const auto g0 = Clock::now();
          // as a model does: cells as the k-nearest search wants them, so the solver searches this grid
          uniformGrid.build(x.data(), y.data(), z.data(), n, solver.suggestedCell(params));
          for (auto* v : {&vx, &vy, &vz, &gx, &gy, &gz}) {
            uniformGrid.gather(*v, tmp);
            v->swap(tmp);
          }
          const double g = std::chrono::duration<double>(Clock::now() - g0).count();
          const float* sx = uniformGrid.sortedX().data();
          const float* sy = uniformGrid.sortedY().data();
          const float* sz = uniformGrid.sortedZ().data();
          parallelFor(n, [&](std::size_t k) {
            const float dx = gx[k] - sx[k], dy = gy[k] - sy[k], dz = gz[k] - sz[k];
            const float d = std::sqrt(dx * dx + dy * dy + dz * dz);
            const float f = d > 0.0f ? std::min(params.maxSpeed, d / dt) / d : 0.0f;
            px[k] = dx * f;
            py[k] = dy * f;
            pz[k] = dz * f;
          });
          solver.solve(uniformGrid, vx.data(), vy.data(), vz.data(), px.data(), py.data(), pz.data(), params, {}, dt,
                       ox.data(), oy.data(), oz.data());
          parallelFor(n, [&](std::size_t k) {
            x[k] = sx[k] + ox[k] * dt;
            y[k] = sy[k] + oy[k] * dt;
            z[k] = sz[k] + oz[k] * dt;
          });
          vx.swap(ox);
          vy.swap(oy);
          vz.swap(oz);
          return g;
        };
        // warm-up: the first step sizes the scratch buffers; on a busy machine the warm-up lasts until the
        // thread governor has chosen its team (at most 3 s), and then the run starts again, so that the
        // same steps are timed whatever the governor did
        step();
        if (!threadsSettled()) {
          untilSettled(step);
          start();
          step();
        }
        for (std::int64_t s = 0; s < steps; ++s) {
          const double g = step();
          neighbours.push_back(solver.neighbourSeconds());
          lp.push_back(solver.lpSeconds());
          total.push_back(solver.neighbourSeconds() + solver.lpSeconds());
          team.push_back(threadsInUse());
          grid.push_back(g);
          infeasible = solver.infeasibleCount();
        }
      }
      BenchRow row;
      row.scenario = kOrcaCase;
      row.model = "orca";
      row.agents = static_cast<std::int64_t>(n);
      row.threads = threads;
      row.preprocessSeconds = median(pre);
      row.stepsPerSecond = 1.0 / median(total);
      row.threadsUsed = median(team);
      row.nsPerAgentStep = 1e9 / (row.stepsPerSecond * static_cast<double>(n));
      row.steps = steps;
      row.modelInfo = Json::array({Json{{"neighbours_ms", 1e3 * median(neighbours)},
                                        {"orca_ms", 1e3 * median(lp)},
                                        {"grid_ms", 1e3 * median(grid)},
                                        {"infeasible", infeasible},
                                        {"swarm", "agents"},
                                        {"agents", row.agents}}});
      rows.push_back(row);
      printRow(row, options, out, headerDone);
      out.flush();
    }
  }
}

// The bswarm model's rows: where the time of a step goes, per agent-step.
void printBswarmTable(const std::vector<BenchRow>& rows, std::ostream& out) {
  bool header = false;
  char line[320];
  for (const auto& row : rows) {
    for (const auto& info : row.modelInfo) {
      if (!info.contains("ns_forces")) continue;
      if (!header) {
        out << "\nBSwarm columns (ns per agent-step):\n";
        std::snprintf(line, sizeof line, "%-20s %9s %7s %6s %10s %10s %10s %10s %10s %10s\n", "scenario", "agents",
                      "threads", "theta", "grid", "forces", "orca_nbrs", "orca_lp", "steps/s", "infeas_%");
        out << line;
        header = true;
      }
      std::snprintf(line, sizeof line, "%-20s %9lld %7d %6.3g %10.0f %10.0f %10.0f %10.0f %10.1f %10.3f\n",
                    (row.scenario + (row.modelInfo.size() > 1 ? "/" + info.value("swarm", std::string()) : "")).c_str(),
                    static_cast<long long>(info.value("agents", row.agents)), row.threads, info.value("theta", 0.0),
                    info.value("ns_grid", 0.0), info.value("ns_forces", 0.0), info.value("ns_orca_neighbours", 0.0),
                    info.value("ns_orca_lp", 0.0), row.stepsPerSecond, info.value("infeasible_percent", 0.0));
      out << line;
    }
  }
}

// The shape model's rows in the columns of chen2019's Table 1 (scenario, agents, max speed, FPS), with
// where a step's time goes and the preprocessing (sampling, assignment) that the paper leaves out.
void printShapeTable(const std::vector<BenchRow>& rows, std::ostream& out) {
  bool header = false;
  char line[320];
  for (const auto& row : rows) {
    for (const auto& info : row.modelInfo) {
      if (!info.contains("t_assignment")) continue;
      if (!header) {
        out << "\nShape columns (chen2019 Table 1; ms per step, preprocessing s):\n";
        std::snprintf(line, sizeof line, "%-22s %9s %7s %9s %10s %7s %7s %9s %9s %7s %9s %9s\n", "scenario", "agents",
                      "threads", "max_speed", "steps/s", "grid", "noise", "f_int_all", "per_insect", "mde", "sampling",
                      "assign");
        out << line;
        header = true;
      }
      std::snprintf(line, sizeof line, "%-22s %9lld %7d %9.3g %10.1f %7.3f %7.3f %9.3f %9.3f %7.3f %9.3f %9.3f\n",
                    (row.scenario + (row.modelInfo.size() > 1 ? "/" + info.value("swarm", std::string()) : "")).c_str(),
                    static_cast<long long>(info.value("agents", row.agents)), row.threads,
                    info.value("max_speed", 0.0), row.stepsPerSecond, info.value("ms_grid", 0.0),
                    info.value("ms_noise", 0.0), info.value("ms_interaction", 0.0),
                    info.value("ms_forces", 0.0), info.value("ms_mde", 0.0), info.value("t_sampling", 0.0),
                    info.value("t_assignment", 0.0));
      out << line;
    }
  }
}

}  // namespace

std::vector<std::string> builtinBenchCases() {
  std::vector<std::string> names;
  for (const auto& c : kCases) names.emplace_back(c.name);
  names.emplace_back(kOrcaCase);
  return names;
}

std::vector<BenchRow> runBench(const BenchOptions& options, std::ostream& out) {
  struct Source {
    std::string label;
    Json json;
  };
  std::vector<Source> sources;
  const std::vector<std::string> known = builtinBenchCases();
  for (const auto& name : options.cases) {
    if (std::find(known.begin(), known.end(), name) == known.end()) {
      std::string list;
      for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
      throw InputError("bench --case: no built-in case \"" + name + "\" (expected one of " + list + ")");
    }
  }
  if (!options.cases.empty() && !options.scenarios.empty()) {
    throw InputError("bench: --case selects built-in cases, which run only without scenario files");
  }
  const auto wanted = [&](const std::string& name) {
    return options.cases.empty() || std::find(options.cases.begin(), options.cases.end(), name) != options.cases.end();
  };
  if (options.scenarios.empty()) {
    for (const auto& c : kCases) {
      if (!c.overrides) {
        sources.push_back({c.name, parseJsonText(c.json, std::string("builtin:") + c.name)});
        continue;
      }
      // a variant of an earlier case: its JSON with the assignments applied
      const auto base = std::find_if(sources.begin(), sources.end(), [&](const Source& e) { return e.label == c.json; });
      if (base == sources.end()) throw std::logic_error(std::string("bench: built-in ") + c.name + " varies no earlier case");
      Json json = base->json;
      std::istringstream lines(c.overrides);
      for (std::string line; std::getline(lines, line);) applyOverride(json, line);
      sources.push_back({c.name, json});
    }
    // the cases not asked for go after their variants were made from them
    sources.erase(std::remove_if(sources.begin(), sources.end(), [&](const Source& e) { return !wanted(e.label); }),
                  sources.end());
  } else {
    for (const auto& f : options.scenarios) sources.push_back({f, readJsonFile(f)});
  }
  std::vector<std::int64_t> agentsList = options.agents.empty() ? std::vector<std::int64_t>{0} : options.agents;
  std::vector<int> threadList = options.threads.empty() ? std::vector<int>{threadCount()} : options.threads;

  std::vector<BenchRow> rows;
  bool headerDone = false;
  for (const auto& src : sources) {
    for (const std::int64_t agents : agentsList) {
      Json json = src.json;
      for (const auto& o : options.overrides) applyOverride(json, o);
      if (agents > 0) rescaleAgents(json, agents, src.label);
      const Scenario sc = parseScenario(json, src.label);
      for (const int threads : threadList) {
        requestThreads(threads);
        const std::int64_t frames = options.frames > 0 ? options.frames : std::min<std::int64_t>(sc.frames, 10);
        std::int64_t steps = std::max<std::int64_t>(1, frames * sc.stepsPerFrame);
        const std::int64_t skipSteps = options.skip * sc.stepsPerFrame;
        std::vector<double> pre, rate, team;
        Json info = Json::array();
        for (int r = 0; r < std::max(1, options.repeat); ++r) {
          if (!threadsSettled()) {
            // on a busy machine, steps of a run of its own until the thread governor has chosen its team
            // (at most 3 s), so that the same steps are timed whatever the governor did
            Simulation warm(sc);
            untilSettled([&] { warm.step(); });
          }
          Simulation sim(sc);
          pre.push_back(sim.preprocessSeconds());
          sim.step();  // warm-up: sizes scratch buffers
          if (skipSteps > 0) {  // --skip: the frames before the timed ones (a swarm past its gathering, say)
            for (std::int64_t k = 0; k < skipSteps; ++k) sim.step();
            sim.restartBenchTimers();
          }
          if (options.frames == 0 && r == 0) {
            // by default at least 0.1 s is timed: steps of a few agents are below the clock's resolution
            const auto w0 = Clock::now();
            sim.step();
            const double one = std::chrono::duration<double>(Clock::now() - w0).count();
            if (one * static_cast<double>(steps) < 0.1) {
              steps = std::min<std::int64_t>(1000000, static_cast<std::int64_t>(std::ceil(0.1 / std::max(one, 1e-9))));
            }
          }
          long long teamSum = 0;
          const auto t0 = Clock::now();
          for (std::int64_t k = 0; k < steps; ++k) {
            sim.step();
            teamSum += threadsInUse();
          }
          const double s = std::chrono::duration<double>(Clock::now() - t0).count();
          rate.push_back(static_cast<double>(steps) / s);
          team.push_back(static_cast<double>(teamSum) / static_cast<double>(steps));
          info = Json::array();
          for (std::size_t i = 0; i < sc.swarms.size(); ++i) {
            Json facts = sim.model(i).benchInfo();
            if (!facts.empty()) {
              facts["swarm"] = sc.swarms[i].name;
              facts["agents"] = sc.swarms[i].count;
            }
            info.push_back(std::move(facts));
          }
        }
        BenchRow row;
        row.scenario = sc.name;
        for (const auto& sw : sc.swarms) {
          if (row.model.find(sw.model) == std::string::npos) row.model += (row.model.empty() ? "" : "+") + sw.model;
        }
        row.agents = sc.agentCount();
        row.threads = threads;
        row.preprocessSeconds = median(pre);
        row.stepsPerSecond = median(rate);
        row.threadsUsed = median(team);
        row.nsPerAgentStep = 1e9 / (row.stepsPerSecond * static_cast<double>(row.agents));
        row.steps = steps;
        row.skipped = skipSteps;
        row.modelInfo = info;
        rows.push_back(row);
        printRow(row, options, out, headerDone);
        out.flush();
      }
    }
  }
  if (options.scenarios.empty() && wanted(kOrcaCase)) runOrcaBench(options, agentsList, threadList, out, headerDone, rows);
  if (!options.json) {
    printTable1(rows, out);
    printBswarmTable(rows, out);
    printShapeTable(rows, out);
  }
  return rows;
}

}  // namespace swarmsim
