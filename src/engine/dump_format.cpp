#include "engine/dump_format.h"

#include <algorithm>
#include <cstdio>

namespace granary::engine {

DumpBox NativeDumpBox(const RunSpec& spec, double bed_top, double bound_radius) {
  const double hw = spec.silo.width / 2, ed = spec.discharge.exit_distance, b2 = 2 * bound_radius;
  DumpBox box;
  // Sideways a body is gone once its centre is exit_distance past a side wall; downwards once
  // it is exit_distance below the base, or, falling through the periodic box, kPeriodicFall
  // further down.
  box.x_lo = -(hw + ed + b2);
  box.x_hi = hw + ed + b2;
  box.y_lo = -(ed + kPeriodicFall + b2);
  // Upwards: the bed dilates while it flows, and reinjected bodies land on top of it or come
  // back periodic_headroom + 2 bounding radii above it; 20 % of the bed's height covers the
  // dilation.
  box.y_hi = 1.2 * std::max(bed_top, 0.0) + b2 + spec.discharge.periodic_headroom + 1.0;
  return box;
}

namespace {
std::string Header(const char* item, const char* columns, std::int64_t step, double time,
                   std::int64_t count, const DumpBox& box) {
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "ITEM: TIME\n%.16g\nITEM: TIMESTEP\n%lld\nITEM: NUMBER OF %s\n%lld\nITEM: BOX BOUNDS ff ff pp\n"
                "%.16g %.16g\n%.16g %.16g\n-0.5 0.5\nITEM: %s %s\n",
                time, static_cast<long long>(step), item, static_cast<long long>(count), box.x_lo, box.x_hi,
                box.y_lo, box.y_hi, item, columns);
  return buf;
}
}  // namespace

std::string FrameHeader(std::int64_t step, double time, std::int64_t atoms, const DumpBox& box) {
  return Header("ATOMS", kFrameColumns, step, time, atoms, box);
}

std::string ContactHeader(std::int64_t step, double time, std::int64_t entries, const DumpBox& box) {
  return Header("ENTRIES", kContactColumns, step, time, entries, box);
}

}  // namespace granary::engine
