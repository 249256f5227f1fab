// The LIGGGHTS 3.8 backend: runs a run directory (docs/run-directory.md) on LIGGGHTS as a
// subprocess and converts its output into the common format, so every analysis reads it
// through the same reader as the native engine's. Details: docs/liggghts.md.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

#include "rundir/stop.h"

namespace granary::liggghts {

struct BackendOptions {
  int threads = 1;  // > 1: mpirun -np N liggghts
  bool quiet = false;
  std::string liggghts;  // executable; "" = $GRANARY_LIGGGHTS or `liggghts` on PATH
  // LIGGGHTS printing nothing for this long (seconds) is hung: it is ended and the run fails
  // with its screen output and log tail. Its progress lines come every 0.5 time units.
  double silence_limit = 1800;
};

struct BackendResult {
  std::string end_reason;  // "discharged", "clogged", "time_limit"
  int exited = 0;
  long long steps = 0;
  bool continued = false;
};

// A LIGGGHTS run that failed: the message says why and ends with the tail of its log.
class LiggghtsError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A run ended by a stop request (RequestStop) throws granary::Stopped (engine/stop.h):
// during the discharge LIGGGHTS wrote a checkpoint at the end of its chunk first; during the
// bed preparation nothing is kept.
using granary::Stopped;

// For a signal handler (async-signal-safe): asks the running RunDirectory to stop.
void RequestStop(int signal);

// Runs DIR/run.json under the directory's lock (engine/files.h; throws RunDirectoryBusy);
// continues from the newest DIR/checkpoint.<step>.restart if present.
BackendResult RunDirectory(const std::string& dir, const BackendOptions& options);

// Writes the inputs (bed.in, discharge.in, meshes) into DIR without running anything.
std::vector<std::string> WriteInputs(const std::string& dir);

// The LIGGGHTS executable that would be used, or throws LiggghtsError saying how to install it.
std::string FindLiggghts(const std::string& preferred);

}  // namespace granary::liggghts
