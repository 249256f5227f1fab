// Verbs of granary-liggghts (docs/liggghts.md, docs/run-directory.md).
#include "liggghts/cli.h"

#include "engine/cli.h"
#include "rundir/version.h"

#include <signal.h>
#include <sys/prctl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <exception>
#include <iostream>
#include <string>

#include "rundir/files.h"
#include "liggghts/backend.h"
#include "liggghts/bench.h"
#include "rundir/layout.h"
#include "rundir/run_spec.h"

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

bool WantsHelp(const std::vector<std::string>& args) {
  for (const auto& a : args)
    if (a == "--help" || a == "-h") return true;
  return false;
}

extern "C" void LiggghtsOnStopSignal(int signal) { RequestStop(signal); }

int Run(const std::vector<std::string>& args) {
  if (WantsHelp(args)) {
    std::cout << kRunHelp;
    return 0;
  }
  BackendOptions options;
  std::string dir;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a == "--threads" && i + 1 < args.size()) options.threads = engine::ParsePositiveInt(a, args[++i]);
    else if (a == "--silence-limit" && i + 1 < args.size()) options.silence_limit = engine::ParsePositiveInt(a, args[++i]);
    else if (!a.empty() && a[0] == '-') throw std::invalid_argument("run: unknown option \"" + a + "\"\n" + kRunHelp);
    else if (dir.empty()) dir = a;
    else throw std::invalid_argument("run: more than one directory (\"" + dir + "\", \"" + a + "\")");
  }
  if (dir.empty()) throw std::invalid_argument(std::string("run: missing DIR\n") + kRunHelp);
  struct sigaction sa {};
  sa.sa_handler = LiggghtsOnStopSignal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGTERM, &sa, nullptr);
  sigaction(SIGINT, &sa, nullptr);
  BackendResult r;
  try {
    r = RunDirectory(dir, options);
  } catch (const Stopped& e) {
    // Ended as the signal would have ended it, so the runner sees an interruption.
    std::cerr << "granary-liggghts run: " << e.what() << "\n";
    std::cerr.flush();
    signal(e.signal(), SIG_DFL);
    raise(e.signal());
    return 128 + e.signal();
  }
  std::cout << "done end_reason=" << r.end_reason << " exited=" << r.exited << " steps=" << r.steps
            << (r.continued ? " (continued from checkpoint)" : "") << "\n";
  return 0;
}

// `exec-helper DIR PROGRAM ARGS...`: how the backend starts each LIGGGHTS process (directly
// or as an MPI rank): it holds DIR's helper lock (engine/files.h), dies with its parent
// (mpirun), and becomes PROGRAM. Open MPI closes inherited descriptors in its ranks, so this
// is what keeps the directory locked until every rank is gone.
int ExecHelper(const std::vector<std::string>& args) {
  if (args.size() < 2) throw std::invalid_argument("exec-helper: expected DIR PROGRAM [ARGS...]");
  HoldRunDirectoryAsHelper(args[0]);
  const pid_t parent = getppid();
  prctl(PR_SET_PDEATHSIG, SIGKILL);
  if (getppid() != parent) return 1;  // the parent died before the line above
  std::vector<char*> argv;
  for (std::size_t i = 1; i < args.size(); ++i) argv.push_back(const_cast<char*>(args[i].c_str()));
  argv.push_back(nullptr);
  execv(argv[0], argv.data());
  std::cerr << "granary-liggghts exec-helper: cannot run " << args[1] << ": " << std::strerror(errno) << "\n";
  return 127;
}

int Inputs(const std::vector<std::string>& args) {
  if (WantsHelp(args)) {
    std::cout << kInputsHelp;
    return 0;
  }
  if (args.size() != 1 || args[0].empty() || args[0][0] == '-')
    throw std::invalid_argument(std::string("inputs: expected exactly one DIR\n") + kInputsHelp);
  for (const std::string& f : WriteInputs(args[0])) std::cout << args[0] << "/" << f << "\n";
  return 0;
}

int Bench(const std::vector<std::string>& args) {
  if (WantsHelp(args)) {
    std::cout << kBenchHelp;
    return 0;
  }
  BenchOptions o;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a == "--bodies" && i + 1 < args.size()) o.bodies = engine::ParsePositiveInt(a, args[++i]);
    else if (a == "--steps" && i + 1 < args.size()) o.steps = engine::ParsePositiveInt(a, args[++i]);
    else if (a == "--bed-dir" && i + 1 < args.size()) o.bed_dir = args[++i];
    else if (a == "--repeat" && i + 1 < args.size()) o.repeat = engine::ParsePositiveInt(a, args[++i]);
    else if (a == "--no-native") o.native = false;
    else throw std::invalid_argument("bench: unknown option \"" + a + "\"\n" + kBenchHelp);
  }
  RunBench(o);
  return 0;
}

}  // namespace

int LiggghtsMain(const std::vector<std::string>& args) {
  if (args.empty() || args[0] == "help" || args[0] == "--help" || args[0] == "-h") {
    std::cout << kUsage;
    return args.empty() ? 2 : 0;
  }
  if (args[0] == "--version") {
    std::cout << "granary-liggghts " << GRANARY_VERSION << " (" << granary::GitCommit() << ")\n";
    return 0;
  }
  const std::vector<std::string> rest(args.begin() + 1, args.end());
  try {
    if (args[0] == "run") return Run(rest);
    if (args[0] == "exec-helper") return ExecHelper(rest);
    if (args[0] == "inputs") return Inputs(rest);
    if (args[0] == "bench") return Bench(rest);
    std::cerr << "granary-liggghts: unknown verb \"" << args[0] << "\"\n" << kUsage;
    return 2;
  } catch (const RunDirectoryBusy& e) {
    std::cerr << "granary-liggghts " << args[0] << ": " << e.what() << "\n";
    return kExitRunDirectoryBusy;
  } catch (const SpecError& e) {
    std::cerr << "granary-liggghts " << args[0] << ": spec error: " << e.what() << "\n";
    return 2;
  } catch (const std::invalid_argument& e) {
    std::cerr << "granary-liggghts " << args[0] << ": error: " << e.what() << "\n";
    return 2;
  } catch (const rundir::ReadError& e) {  // run.json missing or not JSON
    std::cerr << "granary-liggghts " << args[0] << ": error: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "granary-liggghts " << args[0] << ": error: " << e.what() << "\n";
    return 1;
  }
}

}  // namespace granary::liggghts
