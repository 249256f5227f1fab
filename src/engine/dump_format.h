// The box of a native run's frames.dump and contacts.dump. It is fixed for the whole run, as
// in a LAMMPS simulation, so LAMMPS (read_dump, rerun) and OVITO see one simulation cell
// (docs/run-directory.md); the rundir writers print it.
#pragma once

#include "rundir/run_spec.h"

namespace granary::engine {

// Every place a disc can be from t = 0 to the end, as x, y, z bounds (z is [-0.5, 0.5]).
// `bed_top` is the highest disc edge of the bed at t = 0, `bound_radius` the largest bounding
// radius of a body. From the spec and the bed alone, so a continued run writes the same box.
void NativeDumpBox(const RunSpec& spec, double bed_top, double bound_radius, double (&box)[3][2]);

}  // namespace granary::engine
