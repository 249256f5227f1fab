// Rates of engine benchmarks that both the native engine's bench (granary-engine bench, its
// LAMMPS side by side) and granary-liggghts' bench report: the atom-steps per second of a
// LAMMPS or LIGGGHTS log, and the median of a bench's rounds.
#pragma once

#include <string>
#include <vector>

namespace granary::external {

// The median of repeated bench rates (the mean of the middle two for an even count).
double BenchMedian(std::vector<double> rates);

// Atom (disc, sphere) steps per second of a LAMMPS or LIGGGHTS log: atoms x steps / time
// summed over its "Loop time of T on P procs for S steps with A atoms" lines (setup
// excluded); 0 if there are none.
double LoopTimeRate(const std::string& log_file);

}  // namespace granary::external
