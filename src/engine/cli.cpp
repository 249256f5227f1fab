// Verbs of granary-engine (docs/run-directory.md "Command line of an engine").
#include "engine/cli.h"

#include <algorithm>
#include <csignal>
#include <cstdio>
#include <exception>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "engine/files.h"
#include "engine/run.h"
#include "engine/stop.h"

namespace granary::engine {

int ParsePositiveInt(const std::string& flag, const std::string& value) {
  std::size_t used = 0;
  int v = 0;
  try {
    v = std::stoi(value, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != value.size() || v < 1) throw std::invalid_argument(flag + ": expected a positive integer (got \"" + value + "\")");
  return v;
}

namespace {

constexpr char kUsage[] =
    "usage: granary-engine <verb> [options]\n"
    "verbs:\n"
    "  run DIR [--threads N]   run DIR/run.json (continues from DIR/checkpoint.bin if present)\n"
    "  bench [--bodies N] [--steps N] [--threads-list 1,2] [--repeat N] [--bed FILE]\n"
    "                          standard benchmark: dumbbells in the chapter-3 silo, W = 14, reinject\n"
    "  help                    this text\n";
constexpr char kRunHelp[] =
    "usage: granary-engine run DIR [--threads N]\n"
    "Runs the native DEM engine on DIR/run.json and writes events.csv, frames.dump,\n"
    "contacts.dump, progress.json, checkpoint.bin, summary.json and DONE into DIR.\n"
    "SIGTERM / SIGINT during the discharge: a checkpoint, then the engine ends by that signal.\n"
    "Exit 75: another engine holds DIR (DIR/engine.lock).\n"
    "  --threads N   OpenMP threads (default: OMP_NUM_THREADS or all cores)\n";
constexpr char kBenchHelp[] =
    "usage: granary-engine bench [--bodies 8000] [--steps 2000] [--threads-list 1,2] [--repeat 1] [--bed FILE]\n"
    "Settles (or loads the cached) bed of dumbbells in a silo of width 100 with one outlet\n"
    "W = 14, then times a fixed number of reinject-mode discharge steps per thread count and\n"
    "prints disc-steps per second. Bed preparation is not timed. With --repeat N, N rounds\n"
    "over the thread counts, then per thread count the best and median rate and the median\n"
    "speed-up over the first thread count (a round's runs share the machine's state).\n";

int Run(const std::vector<std::string>& args) {
  RunOptions options;
  std::string dir;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a == "--help" || a == "-h") {
      std::cout << kRunHelp;
      return 0;
    } else if (a == "--threads" && i + 1 < args.size()) {
      options.threads = ParsePositiveInt("--threads", args[++i]);
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
    std::signal(e.signal(), SIG_DFL);
    std::raise(e.signal());
    return 128 + e.signal();
  }
  std::cout << "done end_reason=" << r.end_reason << " exited=" << r.exited << " t_end=" << r.t_end
            << " steps=" << r.steps << (r.continued ? " (continued from checkpoint)" : "") << "\n";
  return 0;
}

int Bench(const std::vector<std::string>& args) {
  BenchOptions options;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a == "--help" || a == "-h") {
      std::cout << kBenchHelp;
      return 0;
    } else if (a == "--bodies" && i + 1 < args.size()) {
      options.bodies = ParsePositiveInt(a, args[++i]);
    } else if (a == "--steps" && i + 1 < args.size()) {
      options.steps = ParsePositiveInt(a, args[++i]);
    } else if (a == "--repeat" && i + 1 < args.size()) {
      options.repeat = ParsePositiveInt(a, args[++i]);
    } else if (a == "--bed" && i + 1 < args.size()) {
      options.bed_file = args[++i];
    } else if (a == "--threads-list" && i + 1 < args.size()) {
      options.threads.clear();
      std::stringstream ss(args[++i]);
      std::string item;
      while (std::getline(ss, item, ',')) options.threads.push_back(ParsePositiveInt(a, item));
    } else {
      throw std::invalid_argument("bench: unknown option \"" + a + "\"\n" + kBenchHelp);
    }
  }
  const auto results = RunBenchmark(options);
  const std::size_t per_round = options.threads.size();
  std::map<int, std::vector<double>> rates, speedups;
  for (std::size_t k = 0; k < results.size(); ++k) {
    const BenchResult& r = results[k];
    const double base = results[k - k % per_round].disc_steps_per_s;  // the round's first thread count
    if (options.repeat > 1) std::printf("round=%d ", r.round);
    std::printf("threads=%d disc_steps_per_s=%.4g wall_s=%.3f speedup=%.3f\n", r.threads, r.disc_steps_per_s, r.wall_s,
                r.disc_steps_per_s / base);
    rates[r.threads].push_back(r.disc_steps_per_s);
    speedups[r.threads].push_back(r.disc_steps_per_s / base);
  }
  if (options.repeat > 1)
    for (auto& [threads, v] : rates) {
      std::printf("summary threads=%d rounds=%zu best=%.4g median=%.4g median_speedup=%.3f\n", threads, v.size(),
                  *std::max_element(v.begin(), v.end()), BenchMedian(v), BenchMedian(speedups[threads]));
    }
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
    std::cerr << "granary-engine: unknown verb \"" << args[0] << "\"\n" << kUsage;
    return 2;
  } catch (const RunDirectoryBusy& e) {
    std::cerr << "granary-engine " << args[0] << ": " << e.what() << "\n";
    return kExitRunDirectoryBusy;
  } catch (const std::exception& e) {
    std::cerr << "granary-engine " << args[0] << ": error: " << e.what() << "\n";
    return 1;
  }
}

}  // namespace granary::engine
