// The LAMMPS backend: runs a run directory (docs/run-directory.md) on Debian's LAMMPS (`lmp`)
// as a subprocess, starting from the native engine's bed, and converts its output into the
// common format, so every analysis reads it through the same reader. Details: docs/lammps.md.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

#include "rundir/stop.h"

namespace granary::lammps {

struct BackendOptions {
  int threads = 1;  // > 1: mpirun -np N lmp
  bool quiet = false;
  std::string lammps;  // executable; "" = $GRANARY_LAMMPS or `lmp` on PATH
  std::string engine;  // granary-engine (the bed); "" = beside this program, $GRANARY_ENGINE or PATH
  // LAMMPS printing nothing for this long (seconds) is hung: it is ended and the run fails
  // with its screen output and log tail. Its progress lines come every 0.5 time units.
  double silence_limit = 1800;
};

struct BackendResult {
  std::string end_reason;  // "discharged", "clogged", "time_limit"
  int exited = 0;
  long long steps = 0;
  bool continued = false;
};

// A LAMMPS run that failed: the message says why and ends with the tail of its log.
class LammpsError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

using granary::Stopped;

// For a signal handler (async-signal-safe): asks the running RunDirectory to stop.
void RequestStop(int signal);

// Runs DIR/run.json under the directory's lock (throws RunDirectoryBusy); continues from the
// newest DIR/checkpoint.<step>.restart if present.
BackendResult RunDirectory(const std::string& dir, const BackendOptions& options);

// Writes the inputs (bed.data, discharge.in) into DIR without running LAMMPS (the bed is
// obtained from the native engine).
std::vector<std::string> WriteInputs(const std::string& dir, const BackendOptions& options);

// The LAMMPS executable that would be used, or throws LammpsError saying how to install it.
std::string FindLammps(const std::string& preferred);

}  // namespace granary::lammps
