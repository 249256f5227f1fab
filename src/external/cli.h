// The command line both external-engine backends share (granary-liggghts, granary-lammps:
// docs/liggghts.md, docs/lammps.md): the verbs' dispatch with the exit codes of every engine
// (docs/run-directory.md "Command line of an engine"), `run DIR [--threads N]
// [--silence-limit S]` with its stop-signal handling, and `exec-helper`.
#pragma once

#include <functional>
#include <map>
#include <string>
#include <vector>

namespace granary::external {

struct RunArgs {
  std::string dir;
  int threads = 1;
  double silence_limit = 1800;
};

// A positive integer option value, or std::invalid_argument naming the flag.
int ParsePositive(const std::string& flag, const std::string& value);

// `--help`/`-h` among the arguments.
bool WantsHelp(const std::vector<std::string>& args);

// The verb `run`: parses DIR and the options (throws std::invalid_argument with `help`),
// routes SIGTERM/SIGINT to RequestStop, calls `run` and prints its result line. A run that
// ended on a stop request (granary::Stopped) ends this process by that signal, as the runner
// expects of an interrupted engine.
int RunVerb(const std::string& tag, const std::vector<std::string>& args, const std::string& help,
            const std::function<std::string(const RunArgs&)>& run);

// `exec-helper DIR PROGRAM ARGS...`: how a backend starts each engine process (directly or as
// an MPI rank): it holds DIR's helper lock, dies with its parent (mpirun), and becomes
// PROGRAM. Open MPI closes inherited descriptors in its ranks, so this is what keeps the
// directory locked until every rank is gone.
int ExecHelper(const std::string& tag, const std::vector<std::string>& args);

// The program's main: `help`, `--version`, then the verb from `verbs` (plus exec-helper), with
// errors mapped to the exit codes: 2 usage, spec or run.json error; 75 directory busy; 1 the
// rest (the run failed).
using Verbs = std::map<std::string, std::function<int(const std::vector<std::string>&)>>;
int Main(const std::string& tag, const std::vector<std::string>& args, const std::string& usage, const Verbs& verbs);

}  // namespace granary::external
