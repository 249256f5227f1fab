// The LIGGGHTS 3.8 backend: runs a run directory (docs/run-directory.md) on LIGGGHTS as a
// subprocess and converts its output into the common format, so every analysis reads it
// through the same reader as the native engine's. Details: docs/liggghts.md.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

namespace granary::liggghts {

struct BackendOptions {
  int threads = 1;              // > 1: mpirun -np N liggghts
  bool quiet = false;
  std::string liggghts;         // executable; "" = $GRANARY_LIGGGHTS or `liggghts` on PATH
};

struct BackendResult {
  std::string end_reason;       // "discharged", "clogged", "time_limit"
  int exited = 0;
  long long steps = 0;
  bool continued = false;
};

// A LIGGGHTS run that failed: the message says why and ends with the tail of its log.
class LiggghtsError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Runs DIR/run.json; continues from the newest DIR/checkpoint.<step>.restart if present.
BackendResult RunDirectory(const std::string& dir, const BackendOptions& options);

// Writes the inputs (bed.in, discharge.in, meshes) into DIR without running anything.
std::vector<std::string> WriteInputs(const std::string& dir);

// The LIGGGHTS executable that would be used, or throws LiggghtsError saying how to install it.
std::string FindLiggghts(const std::string& preferred);

}  // namespace granary::liggghts
