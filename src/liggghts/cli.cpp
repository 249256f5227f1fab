// Verbs of granary-liggghts (docs/liggghts.md, docs/run-directory.md).
#include "liggghts/cli.h"

#include <iostream>
#include <string>

#include "external/cli.h"
#include "liggghts/backend.h"
#include "liggghts/bench.h"

namespace granary::liggghts {
namespace {

constexpr char kUsage[] =
    "usage: granary-liggghts <verb> [options]\n"
    "verbs:\n"
    "  run DIR [--threads N]   run DIR/run.json on LIGGGHTS 3.8 (continues from DIR/checkpoint.*.restart)\n"
    "  inputs DIR              write the LIGGGHTS inputs for DIR/run.json (bed.in, discharge.in, meshes); run nothing\n"
    "  bench [--bodies N] [--steps N] [--repeat N] [--no-native]\n"
    "                          standard benchmark on LIGGGHTS and on the native engine, side by side\n"
    "  help                    this text\n"
    "  --version\n";
constexpr char kRunHelp[] =
    "usage: granary-liggghts run DIR [--threads N] [--silence-limit S]\n"
    "Runs DIR/run.json on LIGGGHTS 3.8 (the `liggghts` executable on PATH, or $GRANARY_LIGGGHTS)\n"
    "and writes events.csv, frames.dump, progress.json, summary.json and DONE into DIR, like\n"
    "granary-engine. Its own logs: DIR/log.bed, DIR/log.discharge*.\n"
    "  --threads N          MPI ranks (mpirun -np N); default 1\n"
    "  --silence-limit S    LIGGGHTS printing nothing for S seconds is hung: end it, fail the run\n"
    "                       (default 1800)\n"
    "SIGTERM / SIGINT: during the discharge LIGGGHTS writes a checkpoint at the end of its chunk\n"
    "(0.5 time units) and the run ends by that signal; during the bed preparation it ends at once.\n"
    "Exit 75: another engine holds DIR (DIR/engine.lock).\n";
constexpr char kInputsHelp[] =
    "usage: granary-liggghts inputs DIR\n"
    "Writes the LIGGGHTS input scripts and STL meshes generated from DIR/run.json into DIR,\n"
    "without running LIGGGHTS, and lists them.\n";
constexpr char kBenchHelp[] =
    "usage: granary-liggghts bench [--bodies 8000] [--steps 2000] [--repeat 1] [--no-native] [--bed-dir DIR]\n"
    "The engine issue's standard case (dumbbells in a silo of width 100, W = 14, reinject) on\n"
    "LIGGGHTS, one MPI rank, then the same case on granary-engine with 1 thread; prints\n"
    "disc-steps per second of both and their ratio. Bed preparation is not timed; LIGGGHTS'\n"
    "settled bed is cached in --bed-dir (default: the temp directory). With --repeat N, N\n"
    "rounds of both, then each engine's best and median and the ratios of those.\n";

int Run(const std::vector<std::string>& args) {
  return external::RunVerb("granary-liggghts", args, kRunHelp, [](const external::RunArgs& a) {
    BackendOptions options;
    options.threads = a.threads;
    options.silence_limit = a.silence_limit;
    const BackendResult r = RunDirectory(a.dir, options);
    return "done end_reason=" + r.end_reason + " exited=" + std::to_string(r.exited) +
           " steps=" + std::to_string(r.steps) + (r.continued ? " (continued from checkpoint)" : "");
  });
}

int Inputs(const std::vector<std::string>& args) {
  if (external::WantsHelp(args)) {
    std::cout << kInputsHelp;
    return 0;
  }
  if (args.size() != 1 || args[0].empty() || args[0][0] == '-')
    throw std::invalid_argument(std::string("inputs: expected exactly one DIR\n") + kInputsHelp);
  for (const std::string& f : WriteInputs(args[0])) std::cout << args[0] << "/" << f << "\n";
  return 0;
}

int Bench(const std::vector<std::string>& args) {
  if (external::WantsHelp(args)) {
    std::cout << kBenchHelp;
    return 0;
  }
  BenchOptions o;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a == "--bodies" && i + 1 < args.size())
      o.bodies = external::ParsePositive(a, args[++i]);
    else if (a == "--steps" && i + 1 < args.size())
      o.steps = external::ParsePositive(a, args[++i]);
    else if (a == "--bed-dir" && i + 1 < args.size())
      o.bed_dir = args[++i];
    else if (a == "--repeat" && i + 1 < args.size())
      o.repeat = external::ParsePositive(a, args[++i]);
    else if (a == "--no-native")
      o.native = false;
    else
      throw std::invalid_argument("bench: unknown option \"" + a + "\"\n" + kBenchHelp);
  }
  RunBench(o);
  return 0;
}

}  // namespace

int LiggghtsMain(const std::vector<std::string>& args) {
  return external::Main("granary-liggghts", args, kUsage, {{"run", Run}, {"inputs", Inputs}, {"bench", Bench}});
}

}  // namespace granary::liggghts
