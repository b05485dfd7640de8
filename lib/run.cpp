#include "run.hpp"

#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>

#include "core/error.hpp"
#include "core/parallel.hpp"
#include "core/rng.hpp"
#include "io/trajectory_writer.hpp"

namespace swarmsim {

namespace {

std::atomic<bool> gStop{false};

// first signal: stop at the next frame boundary; a second one: default action
// (the run dies, leaving only its temporary file, never a half-written output)
extern "C" void onStopSignal(int sig) {
  if (gStop.exchange(true)) {
    std::signal(sig, SIG_DFL);
    std::raise(sig);
  }
}

using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

std::string formatDuration(double s) {
  char buf[32];
  if (!std::isfinite(s)) return "?";
  if (s < 60) {
    std::snprintf(buf, sizeof buf, "%.1fs", s);
  } else if (s < 3600) {
    std::snprintf(buf, sizeof buf, "%dm%02ds", static_cast<int>(s / 60), static_cast<int>(s) % 60);
  } else {
    std::snprintf(buf, sizeof buf, "%dh%02dm", static_cast<int>(s / 3600), static_cast<int>(s / 60) % 60);
  }
  return buf;
}

std::string formatBytes(std::uintmax_t b) {
  char buf[32];
  const double v = static_cast<double>(b);
  if (v < 1024.0 * 1024.0) {
    std::snprintf(buf, sizeof buf, "%.1f KiB", v / 1024.0);
  } else if (v < 1024.0 * 1024.0 * 1024.0) {
    std::snprintf(buf, sizeof buf, "%.1f MiB", v / (1024.0 * 1024.0));
  } else {
    std::snprintf(buf, sizeof buf, "%.2f GiB", v / (1024.0 * 1024.0 * 1024.0));
  }
  return buf;
}

}  // namespace

void installStopHandlers() {
  gStop.store(false);
  struct sigaction sa {};
  sa.sa_handler = onStopSignal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
}

SwarmState spawnSwarm(const SwarmSpec& spec, std::uint64_t seed, std::uint32_t swarmIndex) {
  SwarmState s;
  s.name = spec.name;
  s.resize(static_cast<std::size_t>(spec.count));
  const SpawnRegion& r = spec.spawn;
  const float speed = static_cast<float>(spec.initialSpeed);
  parallelFor(s.size(), [&](std::size_t i) {
    AgentRng pr(seed, 0, s.id[i], RngPurpose::kSpawnPosition, swarmIndex);
    Vec3d p;
    if (r.kind == SpawnRegion::Kind::kBox) {
      for (int a = 0; a < 3; ++a) p[a] = r.min[a] + (r.max[a] - r.min[a]) * static_cast<double>(pr.uniform());
    } else {
      p = r.center + pr.inUnitBall().cast<double>() * r.radius;
    }
    s.setPosition(i, p.cast<float>());
    AgentRng vr(seed, 0, s.id[i], RngPurpose::kSpawnVelocity, swarmIndex);
    s.setVelocity(i, vr.unitVector() * speed);
  });
  return s;
}

Simulation::Simulation(const Scenario& scenario) : world_(scenario.world()) {
  const auto t0 = Clock::now();
  for (std::size_t i = 0; i < scenario.swarms.size(); ++i) {
    swarms_.push_back(spawnSwarm(scenario.swarms[i], scenario.seed, static_cast<std::uint32_t>(i)));
    models_.push_back(scenario.swarms[i].config->build(world_));
  }
  preprocessSeconds_ = secondsSince(t0);
}

void Simulation::step() {
  for (std::size_t i = 0; i < swarms_.size(); ++i) {
    models_[i]->step(world_, swarms_[i], StepInfo{step_, static_cast<std::uint32_t>(i), time()});
  }
  ++step_;
}

void Simulation::takeFrameStats(std::vector<std::vector<double>>& out) {
  out.resize(models_.size());
  for (std::size_t i = 0; i < models_.size(); ++i) models_[i]->takeFrameStats(out[i]);
}

RunResult runScenario(const Scenario& scenario, const RunOptions& options) {
  const auto t0 = Clock::now();
  RunResult result;
  result.path = options.output.empty() ? scenario.output.path : options.output;
  result.agents = scenario.agentCount();
  // refuse early, before any precomputation (the writer checks again)
  std::error_code exists;
  if (std::filesystem::is_directory(result.path, exists)) {
    throw OutputError(result.path + ": is a directory (expected an output file path)");
  }
  if (!options.force && std::filesystem::exists(result.path, exists)) {
    throw OutputError(result.path + ": output file exists (use --force to overwrite)");
  }

  Simulation sim(scenario);
  // the file records where it was written
  Scenario recorded = scenario;
  recorded.resolved["output"]["path"] = std::filesystem::absolute(result.path).lexically_normal().string();
  std::vector<std::vector<std::string>> statNames;
  for (std::size_t i = 0; i < scenario.swarms.size(); ++i) statNames.push_back(sim.model(i).statNames());
  TrajectoryWriter writer(result.path, recorded, sim.swarms(), statNames, options.force);
  // frame 0: no step yet; each model says what its statistics are then (0, or NaN for "not computed")
  std::vector<std::vector<double>> stats;
  sim.takeFrameStats(stats);
  writer.writeFrame(sim.time(), sim.swarms(), stats);

  const bool tty = isatty(STDERR_FILENO) != 0;
  auto lastReport = Clock::now();
  const auto loopStart = Clock::now();
  std::uint64_t loopSteps = 0;
  for (std::int64_t f = 1; f < scenario.frames; ++f) {
    if (gStop.load()) break;
    for (std::int64_t k = 0; k < scenario.stepsPerFrame; ++k) sim.step();
    loopSteps += static_cast<std::uint64_t>(scenario.stepsPerFrame);
    sim.takeFrameStats(stats);
    writer.writeFrame(sim.time(), sim.swarms(), stats);
    if (options.progress && (secondsSince(lastReport) >= 0.5 || f + 1 == scenario.frames)) {
      lastReport = Clock::now();
      const double elapsed = secondsSince(loopStart);
      const double rate = static_cast<double>(loopSteps) / std::max(elapsed, 1e-9);
      const double remaining = static_cast<double>((scenario.frames - 1 - f) * scenario.stepsPerFrame) / rate;
      std::fprintf(stderr, "%sframe %lld/%lld  agents %lld  %.1f steps/s  ETA %s%s", tty ? "\r\033[K" : "",
                   static_cast<long long>(f + 1), static_cast<long long>(scenario.frames),
                   static_cast<long long>(result.agents), rate, formatDuration(remaining).c_str(), tty ? "" : "\n");
      std::fflush(stderr);
    }
  }
  if (options.progress && tty) std::fprintf(stderr, "\n");
  result.interrupted = gStop.load();
  result.frames = writer.framesWritten();
  writer.finish(result.interrupted);
  result.wallSeconds = secondsSince(t0);
  std::error_code ec;
  result.bytes = std::filesystem::file_size(result.path, ec);
  if (!options.quiet) {
    std::printf("%s: %lld frames, %lld agents, %.2f s wall, output %s (%s)\n",
                result.interrupted ? "interrupted" : "done", static_cast<long long>(result.frames),
                static_cast<long long>(result.agents), result.wallSeconds, result.path.c_str(),
                formatBytes(result.bytes).c_str());
    std::fflush(stdout);
  }
  return result;
}

}  // namespace swarmsim
