// swarmsim: command-line batch simulator of flying insect swarms.
// Subcommands: run, validate, info, bench, evaluate, reference, export, fit. Exit codes: see core/error.hpp.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <hdf5.h>
#include <cerrno>
#include <cstdio>
#include <filesystem>
#include <cstdlib>
#include <iostream>
#include <sstream>

#include "bench.hpp"
#include "core/error.hpp"
#include "core/parallel.hpp"
#include "fit/fit.hpp"
#include "core/threads.hpp"
#include "eval/score.hpp"
#include "io/export.hpp"
#include "io/scenario.hpp"
#include "io/scene_io.hpp"
#include "io/trajectory_reader.hpp"
#include "models/fastswarm/reference.hpp"
#include "run.hpp"
#include "swarmsim/version.hpp"

using namespace swarmsim;

namespace {

// comma-separated list of positive integers ("1000,10000")
template <typename T>
std::vector<T> parseList(const std::string& text, const char* option) {
  std::vector<T> out;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    char* end = nullptr;
    const long long v = std::strtoll(item.c_str(), &end, 10);
    if (item.empty() || *end != '\0' || v <= 0) {
      throw InputError(std::string(option) + ": expected a comma-separated list of positive integers, got \"" + text +
                       "\"");
    }
    out.push_back(static_cast<T>(v));
  }
  return out;
}

// --seed: a whole number 0 .. 2^64-1, checked here (CLI11 would saturate larger values)
std::string checkedSeed(const std::string& text) {
  errno = 0;
  char* end = nullptr;
  const unsigned long long v = std::strtoull(text.c_str(), &end, 10);
  if (text.empty() || text.find_first_not_of("0123456789") != std::string::npos || *end != '\0' || errno == ERANGE) {
    throw InputError("--seed: expected a whole number from 0 to 18446744073709551615, got \"" + text + "\"");
  }
  return std::to_string(v);
}

std::vector<std::string> overridesFrom(const std::vector<std::string>& sets, const std::string& seed) {
  std::vector<std::string> o = sets;
  if (!seed.empty()) o.push_back("seed=" + checkedSeed(seed));
  return o;
}

}  // namespace

int main(int argc, char** argv) {
  // HDF5's own exit handler would close files a failed write left open, and can
  // crash doing so (a full disk); our handles close everything that is closable
  H5dont_atexit();
  CLI::App app{"swarmsim " + std::string(kVersion) +
               ": batch simulator of flying insect swarms.\n"
               "Exit codes: 0 success, 1 other error, 2 invalid input (arguments, scenario, referenced files),\n"
               "3 output cannot be written, 4 interrupted (partial but valid output)."};
  app.set_version_flag("--version", std::string("swarmsim ") + kVersion);
  app.require_subcommand(1);

  // run
  std::string scenarioFile, outPath;
  long long frames = -1;
  std::string seed;
  int threads = 0;
  std::vector<std::string> sets;
  bool force = false, quiet = false, progress = false;
  CLI::App* run = app.add_subcommand("run", "Run a scenario and write its trajectories to HDF5");
  CLI::Option* scenarioOption =
      run->add_option("scenario", scenarioFile, "Scenario JSON file (- reads it from standard input)");
  std::string fromFile;
  run->add_option("--from", fromFile,
                  "Run the scenario stored in a swarmsim output file again, with the mesh files stored in it")
      ->type_name("OUT.h5")
      ->excludes(scenarioOption);
  bool runJson = false;
  run->add_flag("--json", runJson, "Print the run's summary as one line of JSON on stdout");
  CLI::Option* outOption =
      run->add_option("-o,--output", outPath, "Output HDF5 file (default: the scenario's output.path)");
  run->add_option("--frames", frames, "Number of frames to write (overrides the scenario)")->check(CLI::Range(1LL, 100000000LL));
  run->add_option("--threads", threads, "Worker threads (default: the CPUs this process may use)")
      ->check(CLI::Range(1, 1024));
  bool fixedThreads = false;
  run->add_flag("--fixed-threads", fixedThreads, "Keep the thread count even when other processes busy the CPUs");
  run->add_option("--seed", seed, "Random seed 0..2^64-1 (overrides the scenario)")->type_name("UINT64");
  run->add_option("--set", sets, "Override a scenario value, e.g. --set swarms[0].count=5000 (repeatable)")
      ->type_name("PATH=VALUE");
  run->add_flag("--force", force, "Overwrite an existing output file (a swarmsim output or an empty file)");
  bool resume = false;
  double checkpointSeconds = 30.0;
  run->add_flag("--resume", resume,
                "Continue an interrupted run of this output from its last checkpoint (or start it if there is none)");
  run->add_option("--checkpoint-every", checkpointSeconds, "Seconds of wall time between checkpoints (0: every frame)")
      ->check(CLI::Range(0.0, 1e9));
  run->add_flag("--quiet", quiet, "No summary line");
  run->add_flag("--progress", progress, "Progress on stderr (default when stderr is a terminal)");

  // validate
  std::string validateFile;
  std::vector<std::string> validateSets;
  CLI::App* validate = app.add_subcommand("validate", "Check a scenario and print it resolved (defaults filled in) as JSON");
  validate->add_option("scenario", validateFile, "Scenario JSON file")->required();
  validate->add_option("--set", validateSets, "Override a scenario value (as for run)")->type_name("PATH=VALUE");

  // info
  std::string infoFile;
  bool infoJson = false;
  CLI::App* info = app.add_subcommand("info", "Describe a swarmsim output file");
  info->add_option("file", infoFile, "HDF5 output file")->required();
  info->add_flag("--json", infoJson, "Print JSON");

  // bench
  std::vector<std::string> benchFiles;
  std::string benchAgents, benchThreads;
  long long benchFrames = 0, benchSkip = 0;
  int benchRepeat = 3;
  bool benchJson = false;
  CLI::App* bench = app.add_subcommand("bench", "Time scenarios (no output written); without files, the built-in cases");
  bench->add_option("scenarios", benchFiles, "Scenario JSON files");
  std::string benchCases;
  bench->add_option("--case", benchCases, "Without files: only these built-in cases (fmm-128, fmm-128-order2, boids-100k, orca-100k)")
      ->type_name("NAME[,NAME...]");
  bench->add_option("--agents", benchAgents, "Agent counts N[,N...]; the spawn region and domain are rescaled to keep the density")
      ->type_name("N[,N...]");
  bench->add_option("--frames", benchFrames, "Frames to time per repetition (default: min(scenario frames, 10), more if that is under 0.1 s)")
      ->check(CLI::Range(1LL, 100000000LL));
  bench
      ->add_option("--skip", benchSkip,
                   "Frames to run untimed before the timed ones (e.g. past a swarm's gathering; default 0)")
      ->check(CLI::Range(0LL, 100000000LL));
  bench->add_option("--threads", benchThreads, "Thread counts T[,T...] (default: the CPUs this process may use)")
      ->type_name("T[,T...]");
  bench->add_flag("--fixed-threads", fixedThreads, "Keep each thread count even when other processes busy the CPUs");
  bench->add_option("--repeat", benchRepeat, "Repetitions; the median is reported")->check(CLI::Range(1, 1000));
  bench->add_flag("--json", benchJson, "JSON lines instead of a table");
  std::vector<std::string> benchSets;
  bench->add_option("--set", benchSets, "Override a value of every benched scenario (as for run)")->type_name("PATH=VALUE");

  // evaluate
  eval::EvaluateOptions evalOpt;
  std::string evalFrames, evalSimFrames, evalRefFrames;
  const CLI::Validator kSeedCheck(
      [](std::string& v) {
        return v.empty() || v.find_first_not_of("0123456789") != std::string::npos
                   ? std::string("expected a whole number of 0 or more, got \"") + v + "\""
                   : std::string();
      },
      "SEED");
  CLI::App* evaluate = app.add_subcommand(
      "evaluate", "Score a simulation against reference tracks (physical score and wang2015's E; HDF5 or CSV)");
  evaluate->add_option("sim", evalOpt.sim, "Simulation: swarmsim HDF5 output or tracks CSV")->required();
  evaluate->add_option("--reference", evalOpt.reference, "Reference: HDF5 output or tracks CSV")->required();
  evaluate->add_option("--swarm", evalOpt.source.swarm, "Swarm of an HDF5 file (default: the only one)");
  evaluate->add_option("--frames", evalFrames, "Samples A:B of both files (half-open, either side optional)")
      ->type_name("A:B");
  evaluate->add_option("--sim-frames", evalSimFrames, "Samples A:B of SIM only (over --frames)")->type_name("A:B");
  evaluate->add_option("--ref-frames", evalRefFrames, "Samples A:B of the reference only (over --frames)")
      ->type_name("A:B");
  evaluate->add_option("--bootstrap", evalOpt.bootstrap, "Bootstrap replicates for the intervals (0: none)")
      ->check(CLI::Range(0, 100000));
  evaluate->add_option("--blocks", evalOpt.blocks, "Time blocks of the block bootstrap")->check(CLI::Range(1, 100000));
  evaluate->add_option("--seed", evalOpt.seed, "Seed of the bootstrap and the baseline (0 or more)")
      ->check(kSeedCheck);
  evaluate->add_flag("--baseline", evalOpt.baseline,
                     "Also score Ornstein-Uhlenbeck walkers matched to the reference (where noise lands)");
  evaluate->add_flag("--json", evalOpt.json, "Print JSON");
  evaluate->add_option("--bins", evalOpt.bins, "Z-score bins of the PDFs")->check(CLI::Range(2, 1000000));
  evaluate->add_option("--sim-scale", evalOpt.simScale, "Multiply SIM positions and velocities by F")
      ->check(CLI::PositiveNumber);
  evaluate->add_option("--delimiter", evalOpt.source.csv.delimiter, "CSV delimiter: , ; or tab (default: detect)");
  evaluate->add_option("--columns", evalOpt.source.csv.columns, "CSV columns, e.g. id=object,time=t,x=X,...")
      ->type_name("KEY=NAME,...");

  // fit: tune scenario values against real tracks (pagmo's pso_gen over the physical score)
  fit::FitOptions fitOpt;
  std::vector<std::string> fitParams;
  std::string fitSimFrames, fitRefFrames, fitValidateFrames;
  CLI::App* fitCmd = app.add_subcommand(
      "fit", "Fit a scenario's numeric values to real tracks (maximise evaluate's physical score; pagmo2)");
  fitCmd->add_option("scenario", fitOpt.scenario, "Scenario JSON file")->required();
  fitCmd->add_option("--reference", fitOpt.reference, "Real tracks to fit to (CSV or HDF5, as for evaluate)")->required();
  fitCmd->add_option("--param", fitParams, "A value to fit and its range, PATH=LO:HI (paths as for --set); repeatable")
      ->required()
      ->type_name("PATH=LO:HI");
  fitCmd->add_option("-o,--output", fitOpt.output, "The best scenario (JSON)")->required();
  fitCmd->add_option("--log", fitOpt.log, "Every candidate as JSON lines (values, scores, intervals)");
  fitCmd->add_option("--validate", fitOpt.validate, "Score the best candidate on these tracks too (never fitted to)");
  fitCmd->add_option("--budget", fitOpt.budget, "Candidates to evaluate (default 40)")->check(CLI::Range(1, 1000000));
  fitCmd->add_option("--population", fitOpt.population, "Candidates per generation (default 8)")
      ->check(CLI::Range(2, 100000));
  fitCmd->add_option("--seeds", fitOpt.seeds, "Runs per candidate with seeds seed..seed+K-1, scores averaged (default 1)")
      ->check(CLI::Range(1, 1000));
  fitCmd->add_option("--seed", fitOpt.seed, "Seed of the optimiser (and of the bootstraps and baselines; 0 or more)")
      ->check(kSeedCheck);
  fitCmd->add_option("--jobs", fitOpt.jobs, "Runs at a time (default: the CPUs, one thread each)")
      ->check(CLI::Range(1, 1024));
  fitCmd->add_option("--frames", fitOpt.frames, "Frames per run (default: the scenario's)")->check(CLI::Range(1, 100000000));
  fitCmd->add_option("--set", fitOpt.sets, "A fixed override for every run (as for run)")->type_name("PATH=VALUE");
  fitCmd->add_option("--swarm", fitOpt.eval.source.swarm, "The swarm to score (default: the only one)");
  fitCmd->add_option("--sim-frames", fitSimFrames, "Samples A:B of each run to score (e.g. 100: skips a warm-up)")
      ->type_name("A:B");
  fitCmd->add_option("--ref-frames", fitRefFrames, "Samples A:B of the reference (and of --validate by default)")
      ->type_name("A:B");
  fitCmd->add_option("--validate-frames", fitValidateFrames, "Samples A:B of the --validate tracks")->type_name("A:B");
  fitCmd->add_option("--sim-scale", fitOpt.eval.simScale, "Multiply the runs' positions and velocities by F")
      ->check(CLI::PositiveNumber);
  fitCmd->add_option("--bootstrap", fitOpt.eval.bootstrap, "Bootstrap replicates per score (default 200; 0: none)")
      ->check(CLI::Range(0, 100000));
  fitCmd->add_flag("--force", fitOpt.force, "Replace existing output and log files");

  // reference: FASTSWARM's (v, a) samples from real tracks
  CLI::App* reference = app.add_subcommand("reference", "Build or describe a FASTSWARM reference of real (v, a) samples");
  reference->require_subcommand(1);
  fastswarm::ReferenceBuildOptions refOpt;
  std::string refOut, refFrames, refInfoFile;
  bool refForce = false, refInfoJson = false;
  CLI::App* refBuild = reference->add_subcommand("build", "Difference real tracks (CSV or HDF5) into a reference file");
  refBuild->add_option("tracks", refOpt.tracks, "Track files: CSV or swarmsim HDF5, as for evaluate")->required();
  refBuild->add_option("-o,--output", refOut, "Reference file to write (HDF5)")->required();
  refBuild->add_flag("--force", refForce, "Replace an existing swarmsim file");
  refBuild->add_option("--group-size", refOpt.groupSize, "Samples per speed group (default 100)")
      ->check(CLI::Range(static_cast<std::int64_t>(1), static_cast<std::int64_t>(1) << 40));
  refBuild->add_option("--fence", refOpt.fence, "Tukey fence factor for |v| and |a| outliers (default 3; 0: none)")
      ->check(CLI::NonNegativeNumber);
  refBuild->add_option("--max-speed", refOpt.maxSpeed, "Drop samples faster than this, m/s (default 0: no bound)")
      ->check(CLI::NonNegativeNumber);
  refBuild->add_option("--max-accel", refOpt.maxAccel, "Drop samples with |a| above this, m/s^2 (default 0: no bound)")
      ->check(CLI::NonNegativeNumber);
  std::string refVelocity = "auto";
  refBuild->add_option("--velocity", refVelocity,
                       "v from the recorded velocities or from positions: auto (recorded when present), recorded, positions")
      ->check(CLI::IsMember({"auto", "recorded", "positions"}));
  refBuild->add_option("--swarm", refOpt.source.swarm, "Swarm of an HDF5 file (default: the only one)");
  refBuild->add_option("--frames", refFrames, "Samples A:B of each file (half-open, either side optional)")
      ->type_name("A:B");
  refBuild->add_option("--delimiter", refOpt.source.csv.delimiter, "CSV delimiter: , ; or tab (default: detect)");
  refBuild->add_option("--columns", refOpt.source.csv.columns, "CSV columns, e.g. id=object,time=t,x=X,...")
      ->type_name("KEY=NAME,...");
  CLI::App* refInfo = reference->add_subcommand("info", "Describe a reference file");
  refInfo->add_option("file", refInfoFile, "Reference file")->required();
  refInfo->add_flag("--json", refInfoJson, "Print JSON");

  // export
  ExportOptions exportOpt;
  std::string exportFrames;
  bool exportQuiet = false;
  CLI::App* exportCmd = app.add_subcommand(
      "export", "Write an output file as XDMF (ParaView), PLY point clouds (Blender, Houdini, MeshLab) or CSV");
  exportCmd->add_option("file", exportOpt.input, "swarmsim output file (.h5)")->required();
  exportCmd->add_option("--format", exportOpt.format, "xdmf, ply or csv")->required()->check(CLI::IsMember({"xdmf", "ply", "csv"}));
  exportCmd->add_option("-o,--output", exportOpt.output,
                        "xdmf/csv: the file (csv: - for standard output); ply: the folder (default: beside the .h5)");
  exportCmd->add_option("--frames", exportFrames, "Frames A:B (half-open, either side optional)")->type_name("A:B");
  exportCmd->add_option("--swarm", exportOpt.swarm, "Only this swarm (default: every swarm)");
  exportCmd->add_flag("--force", exportOpt.force, "Replace files an earlier export wrote");
  exportCmd->add_flag("--relative", exportOpt.relative,
                      "xdmf: name the .h5 relative to the .xmf (to move both together) instead of by absolute path");
  exportCmd->add_flag("--quiet", exportQuiet, "No summary line");

  // an unknown first word is an unknown subcommand (CLI11 would only say that one is required)
  if (argc > 1 && argv[1][0] != '-') {
    std::string known;
    bool found = false;
    for (const CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) {
      known += (known.empty() ? "" : ", ") + sub->get_name();
      found = found || sub->get_name() == argv[1];
    }
    if (!found) {
      std::fprintf(stderr, "swarmsim: error: unknown subcommand \"%s\" (expected one of %s; see swarmsim --help)\n",
                   argv[1], known.c_str());
      return kExitInvalidInput;
    }
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e) == 0 ? kExitOk : kExitInvalidInput;
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e) == 0 ? kExitOk : kExitInvalidInput;
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e) == 0 ? kExitOk : kExitInvalidInput;
  } catch (const CLI::ParseError& e) {
    // one line, like every other error
    std::fprintf(stderr, "swarmsim: error: %s (see swarmsim --help)\n", e.what());
    return kExitInvalidInput;
  }

  try {
    if (*run) {
      if (outOption->count() > 0 && outPath.empty()) {
        throw InputError("-o/--output: empty path (expected an output file path)");
      }
      setThreadAdaptation(!fixedThreads);
      requestThreads(threads > 0 ? threads : defaultThreadCount());
      if (scenarioFile.empty() && fromFile.empty()) {
        throw InputError("run: expected a scenario file (or - for standard input, or --from OUT.h5)");
      }
      Scenario sc;
      if (!fromFile.empty()) {
        StoredScenario stored = readStoredScenario(fromFile);
        for (const auto& o : overridesFrom(sets, seed)) applyOverride(stored.scenario, o);
        sc = parseScenario(stored.scenario, fromFile, stored.inputs);
      } else {
        sc = loadScenario(scenarioFile, overridesFrom(sets, seed));
      }
      // --frames runs the scenario for a different number of frames: the scenario itself (keyframe times
      // and what else it checks against its own length) is parsed as written
      if (frames >= 0) {
        sc.frames = frames;
        sc.resolved["frames"] = frames;
      }
      for (const auto& w : sc.warnings) std::fprintf(stderr, "swarmsim: warning: %s\n", w.c_str());
      RunOptions opt;
      opt.output = outPath;
      opt.force = force;
      opt.resume = resume;
      opt.checkpointSeconds = checkpointSeconds;
      opt.quiet = quiet;
      opt.json = runJson;
      opt.progress = progress || isatty(STDERR_FILENO);
      installStopHandlers();
      const RunResult r = runScenario(sc, opt);
      return r.interrupted ? kExitInterrupted : kExitOk;
    }
    if (*validate) {
      const Scenario sc = loadScenario(validateFile, validateSets);
      for (const auto& w : sc.warnings) std::fprintf(stderr, "swarmsim: warning: %s\n", w.c_str());
      std::cout << sc.resolved.dump(2) << "\n";
      return kExitOk;
    }
    if (*info) {
      const TrajectoryInfo ti = readTrajectoryInfo(infoFile);
      if (infoJson) {
        std::cout << ti.toJson().dump(2) << "\n";
      } else {
        std::printf("file:       %s\n", ti.path.c_str());
        std::printf("format:     %s %lld (swarmsim %s)\n", ti.format.c_str(), static_cast<long long>(ti.formatVersion),
                    ti.swarmsimVersion.c_str());
        std::printf("scenario:   %s\n", ti.scenarioName.c_str());
        std::printf("seed:       %llu\n", static_cast<unsigned long long>(ti.seed));
        std::printf("dt:         %g s (%lld steps per frame, %g s per frame)\n", ti.dt,
                    static_cast<long long>(ti.stepsPerFrame), ti.frameDt);
        std::printf("frames:     %lld%s\n", static_cast<long long>(ti.frames),
                    ti.interrupted ? " (interrupted run)" : (ti.complete ? "" : " (incomplete)"));
        for (const auto& s : ti.swarms) {
          std::string q;
          for (const auto& x : s.quantities) q += (q.empty() ? "" : ", ") + x;
          std::printf("swarm:      %s: %lld agents, model %s, %lld frames of %s\n", s.name.c_str(),
                      static_cast<long long>(s.agents), s.model.c_str(), static_cast<long long>(s.frames), q.c_str());
        }
      }
      return kExitOk;
    }
    if (*bench) {
      setThreadAdaptation(!fixedThreads);
      requestThreads(defaultThreadCount());
      BenchOptions opt;
      opt.scenarios = benchFiles;
      for (std::size_t a = 0; a < benchCases.size();) {  // NAME[,NAME...]
        const std::size_t b = std::min(benchCases.find(',', a), benchCases.size());
        opt.cases.push_back(benchCases.substr(a, b - a));
        a = b + 1;
      }
      opt.overrides = benchSets;
      if (!benchAgents.empty()) opt.agents = parseList<std::int64_t>(benchAgents, "--agents");
      if (!benchThreads.empty()) opt.threads = parseList<int>(benchThreads, "--threads");
      opt.frames = benchFrames;
      opt.skip = benchSkip;
      opt.repeat = benchRepeat;
      opt.json = benchJson;
      runBench(opt, std::cout);
      return kExitOk;
    }
    if (*refBuild) {
      if (!refFrames.empty()) refOpt.source.frames = eval::FrameRange::parse(refFrames);
      refOpt.velocity = refVelocity == "recorded"    ? fastswarm::VelocitySource::Recorded
                        : refVelocity == "positions" ? fastswarm::VelocitySource::Positions
                                                     : fastswarm::VelocitySource::Auto;
      if (refOut.empty()) throw InputError("-o/--output: empty path (expected a reference file path)");
      const fastswarm::Reference ref = fastswarm::buildReference(refOpt);
      fastswarm::writeReference(ref, refOut, refForce);
      std::printf("reference: %zu samples in %zu speed groups from %zu file(s) -> %s\n", ref.size(), ref.groups(),
                  ref.sources.size(), refOut.c_str());
      return kExitOk;
    }
    if (*refInfo) {
      fastswarm::printReferenceInfo(fastswarm::readReference(refInfoFile), refInfoFile, refInfoJson, std::cout);
      return kExitOk;
    }
    if (*exportCmd) {
      if (!exportFrames.empty()) exportOpt.frames = eval::FrameRange::parse(exportFrames);
      const ExportResult r = runExport(exportOpt, stdout);
      if (!exportQuiet) {
        std::fprintf(stderr, "export: %lld frames, %lld %s, %lld file%s -> %s\n", static_cast<long long>(r.frames),
                     static_cast<long long>(r.rows), exportOpt.format == "xdmf" ? "points referenced" : "points",
                     static_cast<long long>(r.files), r.files == 1 ? "" : "s", r.where.c_str());
      }
      return kExitOk;
    }
    if (*fitCmd) {
      for (const std::string& p : fitParams) fitOpt.params.push_back(fit::ParamRange::parse(p));
      if (!fitSimFrames.empty()) fitOpt.eval.simFrames = eval::FrameRange::parse(fitSimFrames);
      if (!fitRefFrames.empty()) fitOpt.eval.refFrames = eval::FrameRange::parse(fitRefFrames);
      if (!fitValidateFrames.empty()) fitOpt.validateFrames = eval::FrameRange::parse(fitValidateFrames);
      fitOpt.eval.seed = fitOpt.seed;
      std::error_code ec;
      fitOpt.exe = std::filesystem::read_symlink("/proc/self/exe", ec).string();
      if (ec || fitOpt.exe.empty()) fitOpt.exe = argv[0];
      return fit::runFit(fitOpt, std::cout, std::cerr);
    }
    if (*evaluate) {
      if (!evalFrames.empty()) evalOpt.source.frames = eval::FrameRange::parse(evalFrames);
      if (!evalSimFrames.empty()) evalOpt.simFrames = eval::FrameRange::parse(evalSimFrames);
      if (!evalRefFrames.empty()) evalOpt.refFrames = eval::FrameRange::parse(evalRefFrames);
      eval::runEvaluate(evalOpt, std::cout, std::cerr);
      return kExitOk;
    }
  } catch (const Error& e) {
    std::fprintf(stderr, "swarmsim: error: %s\n", e.what());
    return e.code();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "swarmsim: error: %s\n", e.what());
    return kExitOther;
  }
  return kExitOther;
}
