// Shape templates from the shape table's disc layouts (shapes.h).
#include "silo/shapes.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "rundir/shape_table.h"

namespace granary::silo {

ShapeTemplate MakeTemplate(const Species& s, double density, int index) {
  ShapeTemplate t;
  t.name = s.name;
  t.species = index;
  const DiscLayout layout = DiscsOf(s);
  const std::vector<double>& x = layout.x;
  const std::vector<double>& r = layout.r;
  double m = 0.0, mx = 0.0;
  for (std::size_t k = 0; k < x.size(); ++k) {
    const double mk = density * std::numbers::pi * r[k] * r[k];
    m += mk;
    mx += mk * x[k];
    t.disc_mass.push_back(mk);
  }
  const double xc = mx / m;
  t.mass = m;
  for (std::size_t k = 0; k < x.size(); ++k) {
    const double ox = x[k] - xc;
    t.ox.push_back(ox);
    t.oy.push_back(0.0);
    t.r.push_back(r[k]);
    t.inertia += t.disc_mass[k] * (ox * ox + 0.4 * r[k] * r[k]);
    t.bound_radius = std::max(t.bound_radius, std::fabs(ox) + r[k]);
    t.area += std::numbers::pi * r[k] * r[k];
  }
  return t;
}

std::vector<int> SpeciesCounts(const Bodies& bodies) {
  std::vector<int> counts;
  double cum = 0.0;
  long prev = 0;
  for (std::size_t k = 0; k < bodies.species.size(); ++k) {
    cum += bodies.species[k].fraction;
    long upto = (k + 1 == bodies.species.size()) ? bodies.count : std::lround(cum * static_cast<double>(bodies.count));
    upto = std::clamp<long>(upto, prev, bodies.count);
    counts.push_back(static_cast<int>(upto - prev));
    prev = upto;
  }
  return counts;
}

}  // namespace granary::silo
