// Verbs of granary-engine (docs/run-directory.md "Command line of an engine").
#include "engine/cli.h"

#include <algorithm>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "engine/bench.h"
#include "rundir/files.h"
#include "engine/run.h"
#include "external/bench_log.h"
#include "external/cli.h"
#include "rundir/stop.h"

namespace granary::engine {

double ParsePositiveNumber(const std::string& flag, const std::string& value) {
  std::size_t used = 0;
  double v = 0.0;
  try {
    v = std::stod(value, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != value.size() || !std::isfinite(v) || v <= 0.0)
    throw std::invalid_argument(flag + ": expected a positive number (got \"" + value + "\")");
  return v;
}

namespace {

constexpr char kUsage[] =
    "usage: granary-engine <verb> [options]\n"
    "verbs:\n"
    "  run DIR [--threads N]   run DIR/run.json (continues from DIR/checkpoint.bin if present)\n"
    "  bench [--shape S] [--bodies N] [--steps N] [--threads-list 1,2] [--repeat N] [--bed FILE]\n"
    "        [--versus lammps [--lammps-dir DIR]] [--output-cost T] [--bed-prep]\n"
    "                          standard benchmark: discs, dumbbells or the ch. 4 mixture in the\n"
    "                          chapter-3 silo, W = 14, reinject; the disc case also on LAMMPS\n"
    "  start-frame DIR FILE [--threads N]\n"
    "                          the bed DIR/run.json starts from, as one frame, for another engine\n"
    "  help                    this text\n";
constexpr char kStartFrameHelp[] =
    "usage: granary-engine start-frame DIR FILE [--threads N]\n"
    "Obtains the bed of DIR/run.json as `run` does (from bed.cache_file, or prepared and cached),\n"
    "places it with the outlets open and the bodies an obstacle overlaps taken out, and writes it\n"
    "into FILE as one frame at t = 0 in the frames.dump format (docs/run-directory.md), whatever\n"
    "engine the spec names: the LAMMPS backend starts from it (docs/lammps.md). Prints one JSON\n"
    "line with the bed's provenance. Writes bed progress into DIR/progress.json; takes no lock.\n"
    "  --threads N   OpenMP threads for the bed preparation\n";
constexpr char kRunHelp[] =
    "usage: granary-engine run DIR [--threads N]\n"
    "Runs the native DEM engine on DIR/run.json and writes events.csv, frames.dump,\n"
    "contacts.dump, progress.json, checkpoint.bin, summary.json and DONE into DIR.\n"
    "SIGTERM / SIGINT during the discharge: a checkpoint, then the engine ends by that signal.\n"
    "Exit 75: another engine holds DIR (DIR/engine.lock).\n"
    "  --threads N   OpenMP threads (default: OMP_NUM_THREADS or all cores)\n";
constexpr char kBenchHelp[] =
    "usage: granary-engine bench [--shape dumbbell] [--bodies 8000] [--steps 2000] [--threads-list 1,2]\n"
    "                            [--repeat 1] [--bed FILE] [--versus lammps [--lammps-dir DIR]]\n"
    "                            [--output-cost T] [--bed-prep]\n"
    "Settles (or loads the cached) bed in a silo of width 100 with one outlet W = 14, then\n"
    "times a fixed number of reinject-mode discharge steps per thread count and prints\n"
    "disc-steps per second. Bed preparation is not timed. With --repeat N, N rounds over the\n"
    "thread counts, then per thread count the best and median rate and the median speed-up\n"
    "over the first thread count (a round's runs share the machine's state). Before a round\n"
    "with two threads or more (in every mode), two threads hand a cache line back and forth:\n"
    "its round trip (core_round_trip_ns on the two-thread lines, 0 if the second thread got\n"
    "no core) is what every line crossing between the threads' shares costs, and on a\n"
    "virtual machine it moves when the host moves the virtual CPUs (100 or 500 ns on the\n"
    "CI machine), and two-thread rates with it.\n"
    "  --shape S     disc (d = 1), dumbbell, or mixture (ch. 4: half dumbbells, half discs of\n"
    "                diameter sqrt(2) d, by number)\n"
    "  --bed FILE    where the settled bed is cached (default: granary-bench-bed-S-N-KEY.json\n"
    "                in the temp directory, KEY the hash of the bed key)\n"
    "  --versus lammps  the same case on LAMMPS (`lmp`; with --shape disc only): its input is\n"
    "                written from the same settled bed (pair_style gran/hertz/history, true\n"
    "                2-D); each round runs LAMMPS, then the engine, per thread count (LAMMPS:\n"
    "                as many MPI ranks), and prints both rates and native/LAMMPS; with\n"
    "                --repeat N also the best and median of each and the ratios of those\n"
    "  --lammps-dir DIR  where the LAMMPS input, data file and log are written (default:\n"
    "                granary-bench-lammps-N in the temp directory); kept after the run\n"
    "  --output-cost T  what output costs: each round runs the case without output and with\n"
    "                frames and contact frames every T time units, and prints both rates\n"
    "  --bed-prep    bed preparation instead of discharge: --repeat N replicas (seeds 1..N),\n"
    "                each prepared from scratch by the old procedure (bed step = time_step,\n"
    "                fixed wait per batch, skin 0.2: bed/next_batch fixed) and by the\n"
    "                default one (8 x time_step, next batch once the last has landed, skin\n"
    "                0.4), interleaved, on the largest thread count; prints wall time,\n"
    "                simulated time, top, surface and packing fraction, and per procedure\n"
    "                their mean and spread over the replicas\n";

int Run(const std::vector<std::string>& args) {
  RunOptions options;
  std::string dir;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a == "--help" || a == "-h") {
      std::cout << kRunHelp;
      return 0;
    } else if (a == "--threads" && i + 1 < args.size()) {
      options.threads = external::ParsePositive("--threads", args[++i]);
    } else if (!a.empty() && a[0] == '-') {
      throw std::invalid_argument("run: unknown option \"" + a + "\"\n" + kRunHelp);
    } else if (dir.empty()) {
      dir = a;
    } else {
      throw std::invalid_argument("run: more than one directory (\"" + dir + "\", \"" + a + "\")");
    }
  }
  if (dir.empty()) throw std::invalid_argument(std::string("run: missing DIR\n") + kRunHelp);
  InstallStopHandlers();
  RunResult r;
  try {
    r = RunDirectory(dir, options);
  } catch (const Stopped& e) {
    // Ended as the signal would have ended it: the runner sees an interruption.
    std::cerr << "granary-engine run: " << e.what() << "\n";
    std::cerr.flush();
    std::signal(e.Signal(), SIG_DFL);
    std::raise(e.Signal());
    return 128 + e.Signal();
  }
  std::cout << "done end_reason=" << r.end_reason << " exited=" << r.exited << " t_end=" << r.t_end
            << " steps=" << r.steps << (r.continued ? " (continued from checkpoint)" : "") << "\n";
  return 0;
}

// Per-round lines of both engines and their ratio; with several rounds, the best and median
// of each engine per thread count and the ratios of the bests and of the medians.
int BenchVersusLammps(const BenchOptions& options, const std::string& dir) {
  if (options.shape != "disc")
    throw std::invalid_argument("bench --versus lammps: only --shape disc is set up on LAMMPS");
  std::printf("bench: %d discs, %lld steps, LAMMPS and native side by side; LAMMPS input in %s\n", options.bodies,
              static_cast<long long>(options.steps), dir.c_str());
  std::fflush(stdout);
  const std::vector<VersusResult> results = RunBenchVersusLammps(options, dir);
  std::map<int, std::vector<double>> native, lammps;
  for (const VersusResult& r : results) {
    const std::string tag = options.repeat > 1 ? "round=" + std::to_string(r.round) + " " : "";
    std::printf("%sthreads=%d lammps_disc_steps_per_s=%.4g native_disc_steps_per_s=%.4g native/lammps=%.2f",
                tag.c_str(), r.threads, r.lammps, r.native, r.native / r.lammps);
    if (r.threads > 1) std::printf(" core_round_trip_ns=%.0f", r.core_round_trip_ns);
    std::printf("\n");
    native[r.threads].push_back(r.native);
    lammps[r.threads].push_back(r.lammps);
  }
  if (options.repeat > 1)
    for (auto& [threads, v] : native) {
      const std::vector<double>& l = lammps[threads];
      const double nb = *std::max_element(v.begin(), v.end()), lb = *std::max_element(l.begin(), l.end());
      std::printf(
          "summary threads=%d rounds=%zu lammps best=%.4g median=%.4g native best=%.4g median=%.4g "
          "native/lammps of the bests %.2f, of the medians %.2f\n",
          threads, v.size(), lb, external::BenchMedian(l), nb, external::BenchMedian(v), nb / lb,
          external::BenchMedian(v) / external::BenchMedian(l));
    }
  return 0;
}

// Per round and thread count the rate without and with output and what it costs; with
// several rounds the median cost per thread count.
int BenchOutputCost(const BenchOptions& options, double interval) {
  std::printf("bench: output cost, frames and contact frames every %g time units\n", interval);
  std::fflush(stdout);
  std::map<int, std::vector<double>> costs;
  for (const OutputCostResult& r : RunOutputCost(options, interval)) {
    const double cost = 1.0 - r.with / r.without;
    if (options.repeat > 1) std::printf("round=%d ", r.round);
    std::printf("threads=%d without_output=%.4g with_output=%.4g output_cost=%.1f%% bytes=%.4g", r.threads, r.without,
                r.with, 100.0 * cost, r.bytes);
    if (r.threads > 1) std::printf(" core_round_trip_ns=%.0f", r.core_round_trip_ns);
    std::printf("\n");
    costs[r.threads].push_back(cost);
  }
  if (options.repeat > 1)
    for (auto& [threads, v] : costs)
      std::printf("summary threads=%d rounds=%zu median_output_cost=%.1f%%\n", threads, v.size(),
                  100.0 * external::BenchMedian(v));
  return 0;
}

// Per replica and procedure the wall time and the bed's shape; then per procedure the median
// wall time and the mean and standard deviation of the shape over the replicas. "old" is the
// fixed procedure (bed step = time step, fixed wait per batch), "new" the default.
int BenchBedPrep(const BenchOptions& options) {
  const std::vector<BedProcedure> procedures = {{"old", 1.0, NextBatch::kFixed, WorldParams{}.skin},
                                                {"new", kBedTimeStepFactor, NextBatch::kLanded, kBedSkin}};
  std::printf(
      "bench: preparing %d %s beds of %d bodies, old (bed step 1 x time_step, fixed wait per batch, skin %g) "
      "and new (%g x, next batch once the last has landed, skin %g)\n",
      options.repeat, options.shape.c_str(), options.bodies, WorldParams{}.skin, kBedTimeStepFactor, kBedSkin);
  std::fflush(stdout);
  std::map<std::string, std::vector<BedPrepResult>> by_name;
  for (const BedPrepResult& r : RunBedPrep(options, procedures)) {
    std::printf(
        "seed=%d procedure=%s step_factor=%g next_batch=%s wall_s=%.2f settle_time=%.2f top=%.3f "
        "surface=%.3f phi=%.4f\n",
        r.seed, r.procedure.name.c_str(), r.procedure.step_factor, ToString(r.procedure.next_batch).c_str(), r.wall_s,
        r.settle_time, r.shape.top, r.shape.surface, r.shape.phi);
    std::fflush(stdout);
    by_name[r.procedure.name].push_back(r);
  }
  auto mean_sd = [](const std::vector<double>& v) {
    double m = 0, q = 0;
    for (double x : v) m += x / static_cast<double>(v.size());
    for (double x : v) q += (x - m) * (x - m);
    return std::pair{m, v.size() > 1 ? std::sqrt(q / static_cast<double>(v.size() - 1)) : 0.0};
  };
  std::map<std::string, double> median_wall;
  for (const BedProcedure& p : procedures) {
    const std::vector<BedPrepResult>& rs = by_name[p.name];
    std::vector<double> wall, settle, top, surface, phi;
    for (const BedPrepResult& r : rs) {
      wall.push_back(r.wall_s);
      settle.push_back(r.settle_time);
      top.push_back(r.shape.top);
      surface.push_back(r.shape.surface);
      phi.push_back(r.shape.phi);
    }
    median_wall[p.name] = external::BenchMedian(wall);
    const auto [tm, ts] = mean_sd(top);
    const auto [sm, ss] = mean_sd(surface);
    const auto [pm, ps] = mean_sd(phi);
    std::printf(
        "summary procedure=%s step_factor=%g next_batch=%s replicas=%zu wall_s median=%.2f best=%.2f "
        "settle_time median=%.2f top=%.3f+-%.3f surface=%.3f+-%.3f phi=%.4f+-%.4f (mean+-sd)\n",
        p.name.c_str(), p.step_factor, ToString(p.next_batch).c_str(), rs.size(), median_wall[p.name],
        *std::min_element(wall.begin(), wall.end()), external::BenchMedian(settle), tm, ts, sm, ss, pm, ps);
  }
  std::printf("summary speedup of the median wall time (old / new): %.2f\n", median_wall["old"] / median_wall["new"]);
  return 0;
}

int Bench(const std::vector<std::string>& args) {
  BenchOptions options;
  std::string versus, lammps_dir;
  double output_cost = 0.0;
  bool bed_prep = false;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a == "--help" || a == "-h") {
      std::cout << kBenchHelp;
      return 0;
    } else if (a == "--shape" && i + 1 < args.size()) {
      options.shape = args[++i];
      BenchSpecies(options.shape);  // an unknown shape fails here, before any work
    } else if (a == "--bodies" && i + 1 < args.size()) {
      options.bodies = external::ParsePositive(a, args[++i]);
    } else if (a == "--steps" && i + 1 < args.size()) {
      options.steps = external::ParsePositive(a, args[++i]);
    } else if (a == "--repeat" && i + 1 < args.size()) {
      options.repeat = external::ParsePositive(a, args[++i]);
    } else if (a == "--bed" && i + 1 < args.size()) {
      options.bed_file = args[++i];
    } else if (a == "--output-cost" && i + 1 < args.size()) {
      output_cost = ParsePositiveNumber(a, args[++i]);
    } else if (a == "--bed-prep") {
      bed_prep = true;
    } else if (a == "--versus" && i + 1 < args.size()) {
      versus = args[++i];
      if (versus != "lammps") throw std::invalid_argument("bench: --versus takes \"lammps\" (got \"" + versus + "\")");
    } else if (a == "--lammps-dir" && i + 1 < args.size()) {
      lammps_dir = args[++i];
    } else if (a == "--threads-list" && i + 1 < args.size()) {
      options.threads.clear();
      std::stringstream ss(args[++i]);
      std::string item;
      while (std::getline(ss, item, ',')) options.threads.push_back(external::ParsePositive(a, item));
    } else {
      throw std::invalid_argument("bench: unknown option \"" + a + "\"\n" + kBenchHelp);
    }
  }
  if (bed_prep) return BenchBedPrep(options);
  if (output_cost > 0) return BenchOutputCost(options, output_cost);
  if (!versus.empty()) {
    if (lammps_dir.empty())
      lammps_dir = (std::filesystem::temp_directory_path() / ("granary-bench-lammps-" + std::to_string(options.bodies)))
                       .string();
    return BenchVersusLammps(options, lammps_dir);
  }
  const auto results = RunBenchmark(options);
  const std::size_t per_round = options.threads.size();
  std::map<int, std::vector<double>> rates, speedups, round_trips;
  for (std::size_t k = 0; k < results.size(); ++k) {
    const BenchResult& r = results[k];
    const double base = results[k - k % per_round].disc_steps_per_s;  // the round's first thread count
    if (options.repeat > 1) std::printf("round=%d ", r.round);
    std::printf("threads=%d disc_steps_per_s=%.4g wall_s=%.3f speedup=%.3f", r.threads, r.disc_steps_per_s, r.wall_s,
                r.disc_steps_per_s / base);
    if (r.threads > 1) std::printf(" core_round_trip_ns=%.0f", r.core_round_trip_ns);
    std::printf(" cpu_disc_steps_per_s=%.4g\n", r.cpu_disc_steps_per_s);
    rates[r.threads].push_back(r.disc_steps_per_s);
    speedups[r.threads].push_back(r.disc_steps_per_s / base);
    if (r.threads > 1) round_trips[r.threads].push_back(r.core_round_trip_ns);
  }
  if (options.repeat > 1)
    for (auto& [threads, v] : rates) {
      std::printf("summary threads=%d rounds=%zu best=%.4g median=%.4g median_speedup=%.3f", threads, v.size(),
                  *std::max_element(v.begin(), v.end()), external::BenchMedian(v),
                  external::BenchMedian(speedups[threads]));
      if (threads > 1) std::printf(" median_core_round_trip_ns=%.0f", external::BenchMedian(round_trips[threads]));
      std::printf("\n");
    }
  return 0;
}

}  // namespace

namespace {

int StartFrame(const std::vector<std::string>& args) {
  RunOptions options;
  options.quiet = true;
  std::vector<std::string> positional;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a == "--help" || a == "-h") {
      std::cout << kStartFrameHelp;
      return 0;
    } else if (a == "--threads" && i + 1 < args.size()) {
      options.threads = external::ParsePositive("--threads", args[++i]);
    } else if (!a.empty() && a[0] == '-') {
      throw std::invalid_argument("start-frame: unknown option \"" + a + "\"\n" + kStartFrameHelp);
    } else {
      positional.push_back(a);
    }
  }
  if (positional.size() != 2)
    throw std::invalid_argument(std::string("start-frame: expected DIR FILE\n") + kStartFrameHelp);
  const StartState s = WriteStartFrame(positional[0], positional[1], options);
  const nlohmann::json j = {{"bed_file", s.bed_file},
                            {"prepared_here", s.bed_prepared_here},
                            {"height", s.bed_height},
                            {"settle_time", s.settle_time},
                            {"bed_wall_s", s.bed_wall_s},
                            {"refused", s.bed_refused},
                            {"cleared_by_obstacles", s.cleared_by_obstacles}};
  std::cout << j.dump() << "\n";
  return 0;
}

}  // namespace

int EngineMain(const std::vector<std::string>& args) {
  if (args.empty() || args[0] == "help" || args[0] == "--help" || args[0] == "-h") {
    std::cout << kUsage;
    return args.empty() ? 2 : 0;
  }
  const std::vector<std::string> rest(args.begin() + 1, args.end());
  try {
    if (args[0] == "run") return Run(rest);
    if (args[0] == "bench") return Bench(rest);
    if (args[0] == "start-frame") return StartFrame(rest);
    std::cerr << "granary-engine: unknown verb \"" << args[0] << "\"\n" << kUsage;
    return 2;
  } catch (const RunDirectoryBusy& e) {
    std::cerr << "granary-engine " << args[0] << ": " << e.what() << "\n";
    return kExitRunDirectoryBusy;
  } catch (const SpecError& e) {
    // A run.json the engine refuses is the caller's input, as with the external backends.
    std::cerr << "granary-engine " << args[0] << ": error: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "granary-engine " << args[0] << ": error: " << e.what() << "\n";
    return 1;
  }
}

}  // namespace granary::engine
