// Verbs of granary-lammps (docs/lammps.md, docs/run-directory.md).
#include "lammps/cli.h"

#include <signal.h>
#include <sys/prctl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <exception>
#include <iostream>
#include <string>

#include "lammps/backend.h"
#include "rundir/files.h"
#include "rundir/run_directory.h"
#include "rundir/run_spec.h"
#include "rundir/version.h"

namespace granary::lammps {
namespace {

constexpr char kUsage[] =
    "usage: granary-lammps <verb> [options]\n"
    "verbs:\n"
    "  run DIR [--threads N]   run DIR/run.json on LAMMPS (continues from DIR/checkpoint.*.restart)\n"
    "  inputs DIR              write the LAMMPS inputs for DIR/run.json (start.dump, bed.data, discharge.in); run nothing\n"
    "  help                    this text\n"
    "  --version\n";
constexpr char kRunHelp[] =
    "usage: granary-lammps run DIR [--threads N] [--silence-limit S]\n"
    "Runs DIR/run.json on LAMMPS (`lmp` on PATH, or $GRANARY_LAMMPS), starting from the native\n"
    "engine's bed (granary-engine start-frame, beside this program or $GRANARY_ENGINE), and writes\n"
    "events.csv, frames.dump, progress.json, summary.json and DONE into DIR, like granary-engine.\n"
    "Its own log: DIR/log.discharge[.<step>].\n"
    "  --threads N          MPI ranks (mpirun -np N); default 1\n"
    "  --silence-limit S    LAMMPS printing nothing for S seconds is hung: end it, fail the run\n"
    "                       (default 1800)\n"
    "SIGTERM / SIGINT: LAMMPS writes a checkpoint at the end of its chunk (0.5 time units) and the\n"
    "run ends by that signal.\n"
    "Exit 0: DONE written; 1: the run failed (the message ends with LAMMPS' output and log tail);\n"
    "2: usage or spec error; 75: another engine holds DIR (DIR/engine.lock).\n";
constexpr char kInputsHelp[] =
    "usage: granary-lammps inputs DIR\n"
    "Obtains the native bed of DIR/run.json and writes the LAMMPS data file and input script\n"
    "generated from it into DIR, without running LAMMPS, and lists them.\n";

bool WantsHelp(const std::vector<std::string>& args) {
  for (const auto& a : args)
    if (a == "--help" || a == "-h") return true;
  return false;
}

int ParsePositive(const std::string& flag, const std::string& value) {
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

extern "C" void LammpsOnStopSignal(int signal) { RequestStop(signal); }

int Run(const std::vector<std::string>& args) {
  if (WantsHelp(args)) {
    std::cout << kRunHelp;
    return 0;
  }
  BackendOptions options;
  std::string dir;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a == "--threads" && i + 1 < args.size()) options.threads = ParsePositive(a, args[++i]);
    else if (a == "--silence-limit" && i + 1 < args.size()) options.silence_limit = ParsePositive(a, args[++i]);
    else if (!a.empty() && a[0] == '-') throw std::invalid_argument("run: unknown option \"" + a + "\"\n" + kRunHelp);
    else if (dir.empty()) dir = a;
    else throw std::invalid_argument("run: more than one directory (\"" + dir + "\", \"" + a + "\")");
  }
  if (dir.empty()) throw std::invalid_argument(std::string("run: missing DIR\n") + kRunHelp);
  struct sigaction sa {};
  sa.sa_handler = LammpsOnStopSignal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGTERM, &sa, nullptr);
  sigaction(SIGINT, &sa, nullptr);
  BackendResult r;
  try {
    r = RunDirectory(dir, options);
  } catch (const Stopped& e) {
    std::cerr << "granary-lammps run: " << e.what() << "\n";
    std::cerr.flush();
    signal(e.signal(), SIG_DFL);
    raise(e.signal());
    return 128 + e.signal();
  }
  std::cout << "done end_reason=" << r.end_reason << " exited=" << r.exited << " steps=" << r.steps
            << (r.continued ? " (continued from checkpoint)" : "") << "\n";
  return 0;
}

// `exec-helper DIR PROGRAM ARGS...`: how the backend starts each LAMMPS process (directly or
// as an MPI rank): it holds DIR's helper lock, dies with its parent, and becomes PROGRAM.
int ExecHelper(const std::vector<std::string>& args) {
  if (args.size() < 2) throw std::invalid_argument("exec-helper: expected DIR PROGRAM [ARGS...]");
  HoldRunDirectoryAsHelper(args[0]);
  const pid_t parent = getppid();
  prctl(PR_SET_PDEATHSIG, SIGKILL);
  if (getppid() != parent) return 1;
  std::vector<char*> argv;
  for (std::size_t i = 1; i < args.size(); ++i) argv.push_back(const_cast<char*>(args[i].c_str()));
  argv.push_back(nullptr);
  execv(argv[0], argv.data());
  std::cerr << "granary-lammps exec-helper: cannot run " << args[1] << ": " << std::strerror(errno) << "\n";
  return 127;
}

int Inputs(const std::vector<std::string>& args) {
  if (WantsHelp(args)) {
    std::cout << kInputsHelp;
    return 0;
  }
  if (args.size() != 1 || args[0].empty() || args[0][0] == '-')
    throw std::invalid_argument(std::string("inputs: expected exactly one DIR\n") + kInputsHelp);
  for (const std::string& f : WriteInputs(args[0], BackendOptions{})) std::cout << args[0] << "/" << f << "\n";
  return 0;
}

}  // namespace

int LammpsMain(const std::vector<std::string>& args) {
  if (args.empty() || args[0] == "help" || args[0] == "--help" || args[0] == "-h") {
    std::cout << kUsage;
    return args.empty() ? 2 : 0;
  }
  if (args[0] == "--version") {
    std::cout << "granary-lammps " << GRANARY_VERSION << " (" << granary::GitCommit() << ")\n";
    return 0;
  }
  const std::vector<std::string> rest(args.begin() + 1, args.end());
  try {
    if (args[0] == "run") return Run(rest);
    if (args[0] == "exec-helper") return ExecHelper(rest);
    if (args[0] == "inputs") return Inputs(rest);
    std::cerr << "granary-lammps: unknown verb \"" << args[0] << "\"\n" << kUsage;
    return 2;
  } catch (const RunDirectoryBusy& e) {
    std::cerr << "granary-lammps " << args[0] << ": " << e.what() << "\n";
    return kExitRunDirectoryBusy;
  } catch (const SpecError& e) {
    std::cerr << "granary-lammps " << args[0] << ": spec error: " << e.what() << "\n";
    return 2;
  } catch (const std::invalid_argument& e) {
    std::cerr << "granary-lammps " << args[0] << ": error: " << e.what() << "\n";
    return 2;
  } catch (const rundir::ReadError& e) {
    std::cerr << "granary-lammps " << args[0] << ": error: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "granary-lammps " << args[0] << ": error: " << e.what() << "\n";
    return 1;
  }
}

}  // namespace granary::lammps
