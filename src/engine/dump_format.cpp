#include "engine/dump_format.h"

#include <algorithm>

namespace granary::engine {

void NativeDumpBox(const RunSpec& spec, double bed_top, double bound_radius, double (&box)[3][2]) {
  const double hw = spec.silo.width / 2, ed = spec.discharge.exit_distance, b2 = 2 * bound_radius;
  // Sideways a body is gone once its centre is exit_distance past a side wall; downwards once
  // it is exit_distance below the base, or, falling through the periodic box, kPeriodicFall
  // further down.
  box[0][0] = -(hw + ed + b2);
  box[0][1] = hw + ed + b2;
  box[1][0] = -(ed + kPeriodicFall + b2);
  // Upwards: the bed dilates while it flows, and reinjected bodies land on top of it or come
  // back periodic_headroom + 2 bounding radii above it; 20 % of the bed's height covers the
  // dilation.
  box[1][1] = 1.2 * std::max(bed_top, 0.0) + b2 + spec.discharge.periodic_headroom + 1.0;
  // Random reinjection puts a body just above whatever is in its column, bodies still in the
  // air included, so returns pile up in the air over a fast-flowing bed: the demo's W = 9 runs
  // reached 2.2 times the bed's height. Room for 3 times (a frame that still outruns it says so
  // on stderr: Discharge::WriteFrame).
  if (spec.discharge.mode == DischargeMode::kReinject && spec.discharge.reinject_position == ReinjectPosition::kRandom)
    box[1][1] = 3.0 * std::max(bed_top, 0.0) + b2 + 1.0;
  box[2][0] = -0.5;
  box[2][1] = 0.5;
}

}  // namespace granary::engine
