// The engine issue's standard benchmark on LIGGGHTS, beside the native engine (docs/benchmarks.md).
#pragma once

#include <string>

namespace granary::liggghts {

struct BenchOptions {
  int bodies = 8000;
  int steps = 2000;
  bool native = true;   // also run `granary-engine bench` (next to this executable) and print the ratio
  std::string bed_dir;  // where LIGGGHTS' settled bed is cached ("" = the temp directory)
  int repeat = 1;       // rounds of (LIGGGHTS, native), interleaved, for a shared machine
};

// Prints one line per engine: sphere (disc) steps per second from LIGGGHTS' own "Loop time"
// (setup excluded), and the native/LIGGGHTS ratio; with repeat > 1 one set per round, then
// the best and median of each engine and the ratios of the bests and of the medians.
void RunBench(const BenchOptions& options);

}  // namespace granary::liggghts
