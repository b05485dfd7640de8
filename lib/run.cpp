#include "run.hpp"

#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <iostream>
#include <cstring>
#include <filesystem>
#include <optional>

#include "core/error.hpp"
#include "core/parallel.hpp"
#include "core/rng.hpp"
#include "io/output_target.hpp"
#include "io/trajectory_reader.hpp"
#include "io/trajectory_writer.hpp"

namespace swarmsim {

namespace {

std::atomic<bool> gStop{false};
std::atomic<bool> gCheckpointNow{false};

// first stop signal: stop after the step in progress; a second one: default
// action (the run dies, leaving its partial file and last checkpoint, which
// --resume continues; never a half-written output)
extern "C" void onStopSignal(int sig) {
  if (gStop.exchange(true)) {
    std::signal(sig, SIG_DFL);
    std::raise(sig);
  }
}

extern "C" void onCheckpointSignal(int) { gCheckpointNow.store(true); }

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
  gCheckpointNow.store(false);
  struct sigaction sa {};
  sa.sa_handler = onStopSignal;
  sigemptyset(&sa.sa_mask);
  for (int sig : {SIGINT, SIGTERM, SIGHUP}) sigaction(sig, &sa, nullptr);
  struct sigaction ck {};
  ck.sa_handler = onCheckpointSignal;
  sigemptyset(&ck.sa_mask);
  ck.sa_flags = SA_RESTART;
  sigaction(SIGUSR1, &ck, nullptr);
  std::signal(SIGXFSZ, SIG_IGN);
}

SwarmState spawnSwarm(const SwarmSpec& spec, std::uint64_t seed, std::uint32_t swarmIndex) {
  SwarmState s;
  s.name = spec.name;
  s.resize(static_cast<std::size_t>(spec.count));
  const SpawnRegion& r = spec.spawn;
  const float speed = static_cast<float>(spec.initialSpeed);
  if (r.kind == SpawnRegion::Kind::kTracks) {  // the recorded individuals, as they were at that sample
    for (std::size_t i = 0; i < s.size(); ++i) {
      const float* p = r.positions->data() + 3 * i;
      const float* v = r.velocities->data() + 3 * i;
      s.setPosition(i, Vec3(p[0], p[1], p[2]));
      s.setVelocity(i, Vec3(v[0], v[1], v[2]));
    }
    return s;
  }
  if (r.kind == SpawnRegion::Kind::kModel) return s;  // the model places them (Model::place)
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
  const std::size_t n = scenario.swarms.size();
  seen_.resize(n);
  snapshots_.resize(n);
  watched_.assign(n, 0);
  for (std::size_t i = 0; i < n; ++i) {
    const SwarmSpec& spec = scenario.swarms[i];
    swarms_.push_back(spawnSwarm(spec, scenario.seed, static_cast<std::uint32_t>(i)));
    models_.push_back(spec.config->build(world_));
    if (spec.spawn.kind == SpawnRegion::Kind::kModel) models_.back()->place(world_, swarms_.back(), 0.0);
    for (std::uint32_t j : spec.sees) {
      watched_[j] = 1;
      seen_[i].swarms.push_back(&snapshots_[j]);
    }
  }
  for (std::size_t j = 0; j < n; ++j) snapshots_[j].name = swarms_[j].name;
  preprocessSeconds_ = secondsSince(t0);
}

void Simulation::step() {
  // the swarms that others see, as they are before anyone moves (docs/architecture.md): every model of this
  // step sees the same state, whatever the order the swarms are stepped in
  for (std::size_t j = 0; j < swarms_.size(); ++j) {
    if (!watched_[j]) continue;
    const SwarmState& s = swarms_[j];
    SwarmState& c = snapshots_[j];
    c.px.assign(s.px.begin(), s.px.end());
    c.py.assign(s.py.begin(), s.py.end());
    c.pz.assign(s.pz.begin(), s.pz.end());
    c.vx.assign(s.vx.begin(), s.vx.end());
    c.vy.assign(s.vy.begin(), s.vy.end());
    c.vz.assign(s.vz.begin(), s.vz.end());
    c.id.assign(s.id.begin(), s.id.end());
  }
  for (std::size_t i = 0; i < swarms_.size(); ++i) {
    models_[i]->step(world_, swarms_[i], StepInfo{step_, static_cast<std::uint32_t>(i), time(), &seen_[i]});
  }
  ++step_;
  threadTick();  // fewer threads while other processes hold CPUs
}

void Simulation::takeFrameStats(std::vector<std::vector<double>>& out) {
  out.resize(models_.size());
  for (std::size_t i = 0; i < models_.size(); ++i) models_[i]->takeFrameStats(out[i]);
}

CheckpointView Simulation::checkpoint() const {
  CheckpointView c;
  c.step = step_;
  for (const SwarmState& s : swarms_) c.swarms.push_back(&s);
  for (const auto& m : models_) {
    StateOut out;
    m->saveState(out);
    c.modelStates.push_back(out.bytes());
  }
  return c;
}

void Simulation::restore(const Checkpoint& c, const std::string& file) {
  const auto bad = [&](const std::string& why) { return InputError(file + ": checkpoint does not fit the scenario: " + why); };
  if (c.swarms.size() != swarms_.size() || c.modelStates.size() != models_.size()) throw bad("swarm count");
  for (std::size_t i = 0; i < swarms_.size(); ++i) {
    if (c.swarms[i].name != swarms_[i].name || c.swarms[i].size() != swarms_[i].size()) {
      throw bad("swarm " + std::to_string(i) + " (" + swarms_[i].name + ")");
    }
  }
  for (std::size_t i = 0; i < swarms_.size(); ++i) {
    swarms_[i] = c.swarms[i];
    StateIn in(c.modelStates[i]);
    try {
      models_[i]->loadState(in, world_);
    } catch (const std::runtime_error& e) {
      throw bad("model of swarm " + swarms_[i].name + ": " + e.what());
    }
    if (!in.atEnd()) throw bad("model of swarm " + swarms_[i].name + " has trailing state");
  }
  step_ = c.step;
}

namespace {

std::int64_t stat64(const std::string& path) {
  std::error_code ec;
  const auto n = std::filesystem::file_size(path, ec);
  return ec ? -1 : static_cast<std::int64_t>(n);
}

// temporary files of swarmsim versions before checkpoints (.NAME.tmp-PID) whose
// process is gone: unusable, so they are removed, and said so
void removeOldLeftovers(const OutputTarget& target) {
  namespace fs = std::filesystem;
  const fs::path p(target.path());
  const std::string prefix = "." + p.filename().string() + ".tmp-";
  std::error_code ec;
  const fs::path dir = p.has_parent_path() ? p.parent_path() : fs::path(".");
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.rfind(prefix, 0) != 0 || !it->is_regular_file(ec)) continue;
    const std::string pidText = name.substr(prefix.size());
    if (pidText.empty() || pidText.find_first_not_of("0123456789") != std::string::npos || pidText.size() > 9) continue;
    const pid_t pid = static_cast<pid_t>(std::stol(pidText));
    if (::kill(pid, 0) == 0 || errno != ESRCH) continue;  // alive (or not ours to judge)
    std::fprintf(stderr, "swarmsim: note: removing %s (%lld bytes), left by a killed run of an older swarmsim\n",
                 it->path().c_str(), static_cast<long long>(stat64(it->path().string())));
    fs::remove(it->path(), ec);
  }
}

}  // namespace

RunResult runScenario(const Scenario& scenario, const RunOptions& options) {
  const auto t0 = Clock::now();
  RunResult result;
  const std::string requested = options.output.empty() ? scenario.output.path : options.output;
  result.agents = scenario.agentCount();
  // refuse early, before any precomputation: path rules, the lock
  const OutputTarget target(requested, options.force, options.resume);
  result.path = target.requested();
  removeOldLeftovers(target);

  // the file records where it was written
  Scenario recorded = scenario;
  recorded.resolved["output"]["path"] = std::filesystem::absolute(target.path()).lexically_normal().string();
  const std::string recordedJson = recorded.resolved.dump();
  const auto sameScenario = [&](const std::string& json, const std::string& what) {
    if (json != recordedJson) {
      throw InputError(what + ": written by a run of another scenario or other options (--set, --frames, --seed); "
                       "resume with exactly the same ones, or start again with --force");
    }
  };

  // what is there from an interrupted run
  const bool hasPart = target.partExists(), hasCkpt = target.checkpointExists();
  enum class Start { kFresh, kReopen, kCopy, kCopyPart } start = Start::kFresh;
  Checkpoint ckpt;
  if (options.resume) {
    if (hasPart && hasCkpt) {
      ckpt = readCheckpoint(target.checkpointPath());
      sameScenario(ckpt.scenario, target.checkpointPath());
      // Written on in place, unless compressed (writing allocates space, so a killed run's file is not
      // extended) or closed: a run that stopped but could not place its output has its datasets cut.
      // Then its frames are copied into a new file.
      bool closed = false;
      try {
        const TrajectoryInfo part = readTrajectoryInfo(target.partPath());
        closed = part.complete || part.interrupted;
      } catch (const Error&) {  // a killed run's file: the reopen checks it
      }
      start = TrajectoryWriter::canReopen(scenario) && !closed ? Start::kReopen : Start::kCopyPart;
    } else if (target.finalExists()) {
      TrajectoryInfo info;
      try {
        info = readTrajectoryInfo(target.path());
      } catch (const Error& e) {
        throw OutputError(std::string(e.what()) + "; nothing to resume (use --force to overwrite it)");
      }
      sameScenario(info.scenarioJson, target.path());
      if (info.complete) {
        target.removeCheckpoint();  // a stale one, if any
        result.alreadyComplete = true;
        result.frames = info.frames;
        std::error_code ec;
        result.bytes = std::filesystem::file_size(target.path(), ec);
        if (options.json) {
          std::cout << summaryJson(result).dump() << "\n" << std::flush;
        } else if (!options.quiet) {
          std::printf("complete: %s is already complete (%lld frames); nothing to resume\n", result.path.c_str(),
                      static_cast<long long>(info.frames));
        }
        return result;
      }
      if (!hasCkpt) {
        throw OutputError(target.path() + ": interrupted output without a checkpoint beside it (" +
                          target.checkpointPath() + "): cannot resume; start again with --force");
      }
      ckpt = readCheckpoint(target.checkpointPath());
      sameScenario(ckpt.scenario, target.checkpointPath());
      if (info.frames != ckpt.frames) {
        throw InputError(target.checkpointPath() + ": checkpoint is for frame " + std::to_string(ckpt.frames) +
                         " but " + target.path() + " has " + std::to_string(info.frames) +
                         " frames: cannot resume; start again with --force");
      }
      start = Start::kCopy;
    } else if (hasPart) {
      std::fprintf(stderr, "swarmsim: note: removing %s: its run was killed before its first checkpoint\n",
                   target.partPath().c_str());
    }
  } else if (hasPart || hasCkpt) {
    if (!options.force) {
      std::string at;
      if (hasCkpt) {
        try {
          const Checkpoint c = readCheckpoint(target.checkpointPath());
          at = " at frame " + std::to_string(c.frames) + " of " + std::to_string(scenario.frames);
        } catch (const Error&) {
        }
      }
      throw OutputError(requested + ": an interrupted run of this output left its partial output" + at + " (" +
                        (hasPart ? target.partPath() : target.checkpointPath()) +
                        "): continue it with --resume, or start again with --force");
    }
    std::fprintf(stderr, "swarmsim: note: --force: discarding the interrupted run's partial output of %s\n",
                 requested.c_str());
  }
  if (start == Start::kFresh || start == Start::kCopy) {
    target.removePart();
    if (start == Start::kFresh) target.removeCheckpoint();
  }
  // a resume that copies frames writes a new file beside and renames it over the
  // partial file once it holds them all (a kill meanwhile leaves both as they were)
  const std::string copySource = start == Start::kCopy ? target.path() : target.partPath();
  const std::string copyTarget = target.partPath() + ".new";
  ::unlink(copyTarget.c_str());  // left by a resume killed while copying

  Simulation sim(scenario);
  std::vector<std::vector<std::string>> statNames;
  std::vector<std::string> facts;
  for (std::size_t i = 0; i < scenario.swarms.size(); ++i) {
    statNames.push_back(sim.model(i).statNames());
    const Json f = sim.model(i).facts();
    facts.push_back(f.empty() ? std::string() : f.dump());
  }
  std::optional<TrajectoryWriter> writer;
  // after a failure, the partial output is kept only if a checkpoint can continue it
  bool keepOnError = start != Start::kFresh;
  const auto saveCheckpoint = [&] {
    writer->flush();
    CheckpointView c = sim.checkpoint();
    c.scenario = recordedJson;
    c.frames = writer->framesWritten();
    c.dataHash = writer->dataHash();
    writeCheckpoint(target.checkpointPath(), c);
    keepOnError = true;
  };

  std::vector<std::vector<double>> stats;
  try {
    if (start == Start::kReopen) {
      writer.emplace(target.partPath(), recorded, sim.swarms(), statNames, TrajectoryWriter::Mode::kReopen, ckpt.frames);
      if (writer->hashStoredFrames(ckpt.frames) != ckpt.dataHash) {
        throw InputError(target.partPath() + ": the partial output does not match its checkpoint (damaged?): "
                         "cannot resume; start again with --force");
      }
      writer->setDataHash(ckpt.dataHash);
    } else {
      const bool copy = start == Start::kCopy || start == Start::kCopyPart;
      writer.emplace(copy ? copyTarget : target.partPath(), recorded, sim.swarms(), statNames,
                     TrajectoryWriter::Mode::kCreate, 0, facts);
      if (copy) {
        writer->copyFramesFrom(copySource, ckpt.frames);
        if (writer->dataHash() != ckpt.dataHash) {
          throw InputError(copySource + ": its frames do not match the checkpoint (damaged or changed?): cannot "
                           "resume; start again with --force");
        }
        writer->flush();
        writer->moveTo(target.partPath());
      }
    }
    if (start == Start::kFresh) {
      // frame 0: no step yet; each model says what its statistics are then (0, or NaN for "not computed")
      sim.takeFrameStats(stats);
      writer->writeFrame(sim.time(), sim.swarms(), stats);
      saveCheckpoint();
    } else {
      sim.restore(ckpt, target.checkpointPath());
      result.resumedFrom = ckpt.frames;
      keepOnError = true;
    }

    const bool tty = isatty(STDERR_FILENO) != 0;
    auto lastReport = Clock::now(), lastCheckpoint = Clock::now();
    const auto loopStart = Clock::now();
    const std::uint64_t firstStep = sim.stepsDone();
    const std::uint64_t spf = static_cast<std::uint64_t>(scenario.stepsPerFrame);
    bool stopped = false;
    for (std::int64_t f = writer->framesWritten(); f < scenario.frames && !stopped; ++f) {
      while (sim.stepsDone() < static_cast<std::uint64_t>(f) * spf) {
        if (gStop.load()) {
          stopped = true;
          break;
        }
        if (gCheckpointNow.exchange(false)) {
          saveCheckpoint();
          lastCheckpoint = Clock::now();
        }
        sim.step();
      }
      if (stopped) break;
      sim.takeFrameStats(stats);
      writer->writeFrame(sim.time(), sim.swarms(), stats);
      if (gCheckpointNow.exchange(false) || secondsSince(lastCheckpoint) >= options.checkpointSeconds) {
        saveCheckpoint();
        lastCheckpoint = Clock::now();
      }
      if (options.progress && (secondsSince(lastReport) >= 0.5 || f + 1 == scenario.frames)) {
        lastReport = Clock::now();
        const double elapsed = secondsSince(loopStart);
        const double rate = static_cast<double>(sim.stepsDone() - firstStep) / std::max(elapsed, 1e-9);
        const double remaining = static_cast<double>((scenario.frames - 1 - f) * scenario.stepsPerFrame) / rate;
        std::fprintf(stderr, "%sframe %lld/%lld  agents %lld  %.1f steps/s  ETA %s%s", tty ? "\r\033[K" : "",
                     static_cast<long long>(f + 1), static_cast<long long>(scenario.frames),
                     static_cast<long long>(result.agents), rate, formatDuration(remaining).c_str(), tty ? "" : "\n");
        std::fflush(stderr);
      }
    }
    if (options.progress && tty) std::fprintf(stderr, "\n");
    result.interrupted = writer->framesWritten() < scenario.frames;  // only a stop ends the loop early
    result.frames = writer->framesWritten();
    result.steps = static_cast<std::int64_t>(sim.stepsDone() - firstStep);
    result.stepSeconds = secondsSince(loopStart);
    if (result.interrupted) saveCheckpoint();  // the exact step reached, mid-frame or not
    writer->close(!result.interrupted);
    // an interrupted output of this scenario that this run continued is replaced
    target.place(options.force || start == Start::kCopy);
    if (!result.interrupted) target.removeCheckpoint();
  } catch (const OutputError& e) {
    writer.reset();
    ::unlink(copyTarget.c_str());
    if (keepOnError && target.checkpointExists()) {
      throw OutputError(std::string(e.what()) + "; the run so far is kept (" + target.partPath() +
                        "): continue it with --resume");
    }
    target.removePart();
    target.removeCheckpoint();
    throw;
  } catch (...) {
    writer.reset();
    ::unlink(copyTarget.c_str());
    if (start == Start::kFresh) {
      target.removePart();
      target.removeCheckpoint();
    }
    throw;
  }
  result.wallSeconds = secondsSince(t0);
  std::error_code ec;
  result.bytes = std::filesystem::file_size(target.path(), ec);
  if (options.json) {
    std::cout << summaryJson(result).dump() << "\n" << std::flush;
  } else if (!options.quiet) {
    std::string resumed;
    if (result.resumedFrom >= 0) resumed = " (resumed at frame " + std::to_string(result.resumedFrom) + ")";
    std::printf("%s: %lld frames%s, %lld agents, %.2f s wall, output %s (%s)\n",
                result.interrupted ? "interrupted" : "done", static_cast<long long>(result.frames), resumed.c_str(),
                static_cast<long long>(result.agents), result.wallSeconds, result.path.c_str(),
                formatBytes(result.bytes).c_str());
    std::fflush(stdout);
  }
  return result;
}

nlohmann::json summaryJson(const RunResult& r) {
  return {{"output", r.path},
          {"frames", r.frames},
          {"agents", r.agents},
          {"wall_seconds", r.wallSeconds},
          {"steps", r.steps},
          {"steps_per_second", r.stepSeconds > 0.0 ? static_cast<double>(r.steps) / r.stepSeconds : 0.0},
          {"bytes", r.bytes},
          {"interrupted", r.interrupted},
          {"complete", !r.interrupted},
          {"resumed_from", r.resumedFrom >= 0 ? nlohmann::json(r.resumedFrom) : nlohmann::json(nullptr)},
          {"already_complete", r.alreadyComplete}};
}

}  // namespace swarmsim
