// Verbs of granary-lammps (docs/lammps.md, docs/run-directory.md).
#include "lammps/cli.h"

#include <iostream>
#include <string>

#include "external/cli.h"
#include "lammps/backend.h"

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

int Run(const std::vector<std::string>& args) {
  return external::RunVerb("granary-lammps", args, kRunHelp, [](const external::RunArgs& a) {
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
  for (const std::string& f : WriteInputs(args[0], BackendOptions{})) std::cout << args[0] << "/" << f << "\n";
  return 0;
}

}  // namespace

int LammpsMain(const std::vector<std::string>& args) {
  return external::Main("granary-lammps", args, kUsage, {{"run", Run}, {"inputs", Inputs}});
}

}  // namespace granary::lammps
