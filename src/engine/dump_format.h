// The block headers of frames.dump and contacts.dump as LAMMPS writes them (dump custom and
// dump local with `dump_modify time yes`): ITEM: TIME before ITEM: TIMESTEP, the count, the
// box, then the column names. LAMMPS' read_dump expects this order (reader_native.cpp skips
// UNITS and TIME, then requires TIMESTEP). The box is fixed for the whole run, so LAMMPS and
// OVITO see one simulation cell (docs/run-directory.md). Both engines write through here.
#pragma once

#include <cstdint>
#include <string>

#include "engine/run_spec.h"

namespace granary::engine {

// x and y bounds of the dump box; z is always [-0.5, 0.5], periodic (a 2-D system).
struct DumpBox {
  double x_lo = 0, x_hi = 0, y_lo = 0, y_hi = 0;
};

// Column names: LAMMPS' names for per-atom values (dump custom), in this order.
inline constexpr char kFrameColumns[] = "id mol type x y z radius mass vx vy vz omegaz";
inline constexpr char kContactColumns[] = "body_i body_j xi yi xj yj cx cy fx fy";

// The box of a native run: every place a disc can be from t = 0 to the end. `bed_top` is the
// highest disc edge of the bed at t = 0, `bound_radius` the largest bounding radius of a body.
DumpBox NativeDumpBox(const RunSpec& spec, double bed_top, double bound_radius);

// "ITEM: TIME ... ITEM: ATOMS <kFrameColumns>\n" for a frame of `atoms` discs.
std::string FrameHeader(std::int64_t step, double time, std::int64_t atoms, const DumpBox& box);
// "ITEM: TIME ... ITEM: ENTRIES <kContactColumns>\n" for a contact frame of `entries` rows.
std::string ContactHeader(std::int64_t step, double time, std::int64_t entries, const DumpBox& box);

}  // namespace granary::engine
