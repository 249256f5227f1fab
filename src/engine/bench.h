// The engine's standard benchmark (docs/benchmarks.md): discs, dumbbells or the ch. 4 mixture
// settled in the chapter-3 silo, a fixed number of reinject-mode discharge steps, timed;
// and the same disc case on LAMMPS (Debian's `lmp`, pair_style gran/hertz/history, true
// 2-D), side by side in interleaved rounds.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "engine/bed.h"
#include "rundir/run_spec.h"

namespace granary::engine {

struct BenchOptions {
  std::string shape = "dumbbell";  // "disc", "dumbbell" or "mixture" (BenchSpecies)
  int bodies = 8000;
  std::int64_t steps = 2000;
  std::vector<int> threads = {1, 2};
  std::string bed_file;  // where to cache the settled bed ("" = a file in the temp dir)
  int repeat = 1;        // rounds over the thread counts (interleaved, for a shared machine)
};

struct OutputCostResult {
  int round;  // 1..repeat
  int threads;
  double without;                   // disc-steps per second without output
  double with;                      // ... with frames and contact frames every interval
  double bytes;                     // bytes of frames.dump and contacts.dump written in the timed steps
  double core_round_trip_ns = 0.0;  // measured before the round when it has two threads or more (CoreRoundTripNs)
};

// What output costs: `repeat` rounds, each over the thread counts, each the bench case run
// without output and then with frames and contact frames every `interval` (the frame at
// t = 0 is written before the timing starts).
std::vector<OutputCostResult> RunOutputCost(const BenchOptions& options, double interval);

struct BenchResult {
  int round;  // 1..repeat
  int threads;
  double disc_steps_per_s;
  double wall_s;
  double core_round_trip_ns = 0.0;  // measured before the round when it has two threads or more
  // Disc-steps per second of the process' CPU time (all its threads): what a core-hour buys,
  // also when other work shares the machine (the runner's estimate calibrates with it).
  double cpu_disc_steps_per_s = 0.0;
};

// What a cache line costs between two cores now: two threads hand a counter back and forth
// (as the engine's threads hand stamps and the discs next to the other share), for about
// 50 ms; the mean round trip in ns, 0 if the second thread never ran (one free core). On a
// virtual machine this moves when the host moves the virtual CPUs (docs/benchmarks.md:
// 100 ns or 500 ns on the CI machine), and so do two-thread rates.
double CoreRoundTripNs();

// The bodies of the bench for `shape`: "disc" (discs of d = 1), "dumbbell", or "mixture"
// (the thesis' ch. 4: half dumbbells, half discs of diameter sqrt(2) d, by number); throws
// std::invalid_argument for another name.
nlohmann::json BenchSpecies(const std::string& shape);

// The run.json of the standard case: `options.bodies` bodies of `options.shape` settled in
// the chapter-3 silo (walls at +-50 d), outlet W = 14 d, reinject mode, `options.steps`
// steps; the bed cached in options.bed_file (or a file in the temp directory named by shape
// and count).
nlohmann::json BenchSpec(const BenchOptions& options);

// The standard case, a fixed number of steps per thread count; `repeat` rounds over the
// thread counts. The bed is prepared (or loaded) first and not timed.
std::vector<BenchResult> RunBenchmark(const BenchOptions& options);

// The LAMMPS input for the bench case on a settled bed of discs: a data file (the bed's
// positions and velocities; LAMMPS starts without the contact history) and an input script
// that reads it from `data_file`: `dimension 2`, pair_style gran/hertz/history with the
// spec's contact constants (dampflag 1), disc masses rho pi r^2 (`set density/disc`),
// sphere inertia (fix nve/sphere), side walls and the base on both sides of the outlet as
// wall/gran (the base as two blocks, so the outlet edges are their corners), Verlet skin
// 0.2, `steps` steps; the box is periodic in y (a disc that leaves falls back in at the
// top, LIGGGHTS' reinjection) from exit_distance + 3 below the base to 2 d + 1 d above the
// highest disc centre. Throws std::invalid_argument unless every body is a single disc.
struct LammpsInput {
  std::string data;    // contents of the data file
  std::string script;  // contents of the input script
};
LammpsInput LammpsBenchInput(const RunSpec& spec, const BedState& bed, const std::string& data_file,
                             std::int64_t steps);

struct VersusResult {
  int round;                        // 1..repeat
  int threads;                      // native threads and LAMMPS MPI ranks
  double native;                    // disc-steps per second
  double lammps;                    // atom-steps per second (external::LoopTimeRate)
  double core_round_trip_ns = 0.0;  // measured before the round when it has two threads or more (CoreRoundTripNs)
};

// One way of preparing the bed: its time step (in time steps) and when the next batch goes in.
struct BedProcedure {
  std::string name;    // "old", "new"
  double step_factor;  // bed time step / time step
  NextBatch next_batch;
  double skin;  // Verlet skin (speed only: the bed does not depend on it)
};

struct BedPrepResult {
  int seed;  // replica: the spec's seed
  BedProcedure procedure;
  double wall_s;       // wall time of PrepareBed
  double settle_time;  // simulated preparation time
  BedShape shape;
};

// Bed preparation side by side: `repeat` replicas (seeds 1..repeat), each prepared from
// scratch once per procedure (interleaved), on the largest thread count of the list; nothing
// cached.
std::vector<BedPrepResult> RunBedPrep(const BenchOptions& options, const std::vector<BedProcedure>& procedures);

// The disc case on LAMMPS and the native engine, side by side: the bed settled (or loaded)
// once, the LAMMPS input written into `dir`, then `repeat` rounds, each over the thread
// counts, each count LAMMPS (`lmp`, under `mpirun -np N` for N > 1) then the native
// engine. Throws with the tail of LAMMPS' log if it fails.
std::vector<VersusResult> RunBenchVersusLammps(const BenchOptions& options, const std::string& dir);

}  // namespace granary::engine
