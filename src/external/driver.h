// The external-engine driver: what the LIGGGHTS and LAMMPS backends share to run their engine
// as a subprocess (docs/architecture.md "External engines"): the launch line (one process or
// MPI ranks, each through the backend's `exec-helper`), reading its screen output line by line,
// a stop request turned into a checkpoint through a control file, silence (a hung engine)
// ended, the failure message with the log tail, the `checkpoint.<step>.restart` files and the
// text-dump blocks both engines write. No engine-specific knowledge: each backend says its
// engine's name.
#pragma once

#include <csignal>
#include <deque>
#include <filesystem>
#include <functional>
#include <istream>
#include <string>
#include <vector>

namespace granary::external {

// For a signal handler (async-signal-safe): asks the running engine to stop.
void RequestStop(int signal);
// The signal of a stop request, or 0.
int StopSignal();

// How a subprocess ended and what it said.
struct ChildRun {
  int exit_code = 0;
  int signal = 0;                   // the signal that ended it (or mpirun), or 0
  bool stopped = false;             // it printed GRANARY_STOPPED: checkpointed and ended on a stop request
  std::string stop_reason;          // why the driver ended it: a stop request without control file, or silence
  std::vector<std::string> errors;  // up to five lines with "ERROR" (not the GRANARY_ ones)
  std::deque<std::string> screen;   // the last kLogTailLines lines of its screen output
  // "<what> exit status N", "<what> killed by SIGKILL (Killed)" or the stop reason.
  std::string How(const std::string& what) const;
};

inline constexpr int kLogTailLines = 25;

struct ChildOptions {
  std::filesystem::path dir;  // working directory
  // A stop request writes "variable stop_requested equal 1" here (the engine's script reads
  // it after every chunk, checkpoints and ends); "" = the child is ended at once.
  std::filesystem::path control;
  double silence_limit = 1800;  // seconds without output: hung, killed; <= 0: no limit
  std::string what;             // the engine's name in messages: "LAMMPS", "LIGGGHTS"
  std::string tag;              // the backend's name on stderr: "granary-lammps"
  std::filesystem::path log;    // the child's log, whose tail a stop request prints; may be ""
};

// Runs `program args` with stdout and stderr read line by line (on_line for each). The child
// leads its own process group and gets SIGKILL when this process dies, so that a killed backend
// never leaves it (or what it started: MPI ranks, a `shell` command) writing into a directory
// the runner will start again. Throws std::runtime_error when it cannot be started.
ChildRun RunChild(const std::string& program, const std::vector<std::string>& args, const ChildOptions& options,
                  const std::function<void(const std::string&)>& on_line);

// The program and arguments that run `engine_command` (executable first) on `threads` MPI
// ranks (> 1: $GRANARY_MPI_LAUNCHER, e.g. "srun --mpi=pmix", else mpirun -np N), each rank
// through `helper exec-helper DIR` when `helper` is not "" (it holds the directory's helper
// lock, docs/liggghts.md "One writer"). Throws std::runtime_error when the launcher is missing.
struct Command {
  std::string program;
  std::vector<std::string> args;
};
Command LaunchCommand(const std::vector<std::string>& engine_command, int threads, const std::filesystem::path& dir,
                      const std::string& helper);

// The running program when its file name is `name` (a backend runs its engine through its
// own `exec-helper`), else "" (the library linked into a test or a bench: run it directly).
std::string HelperExe(const std::string& name);

// For a failure message: the ERROR lines, the last screen lines and the last lines of `log`
// (skipped when `log` is "").
std::string Diagnostics(const ChildRun& r, const std::filesystem::path& log, const std::string& what);

// The directory's `checkpoint.<step>.restart` files (both engines' restart files).
struct Checkpoint {
  std::filesystem::path file;
  long long step = -1;
};
Checkpoint NewestCheckpoint(const std::filesystem::path& dir);
// Keeps the newest `keep` checkpoints.
void PruneCheckpoints(const std::filesystem::path& dir, std::size_t keep);

// The words of a line.
std::vector<std::string> Tokens(const std::string& line);

// The next block of a LAMMPS/LIGGGHTS text dump (custom or local, no TIME item): its step and
// row count, leaving `in` at its first row; false at the end of the file.
bool NextDumpBlock(std::istream& in, long long& step, long long& rows);

// Cuts a text dump back to the blocks at or before `step` (a continue writes the later ones
// again).
void TruncateDump(const std::filesystem::path& file, long long step);

// The periodic image of height y (box height `height`) nearest to `near`.
double NearestImage(double y, double near, double height);

}  // namespace granary::external
