// Shape templates: every body is a rigid clump of discs (docs/model.md "Bodies"). A template
// holds the disc offsets in the body frame (centre of mass at the origin, axis along x),
// radii, disc masses, the body mass and moment of inertia; it is stored once per species.
#pragma once

#include <string>
#include <vector>

#include "rundir/run_spec.h"

namespace granary::silo {

struct ShapeTemplate {
  std::string name;
  int species = 0;
  std::vector<double> ox, oy, r, disc_mass;  // per disc, body frame
  double mass = 0.0;
  double inertia = 0.0;       // I = sum m_i |r_i - R|^2 + 0.4 m_i r_i^2 (docs/model.md)
  double bound_radius = 0.0;  // max |offset| + r: a circle around the centre containing the body
  double area = 0.0;
};

// Builds the template of one species with areal density rho (disc mass rho pi r^2).
ShapeTemplate MakeTemplate(const Species& species, double density, int index);

// Number of bodies of each species: cumulative rounding of fraction * count, so the counts
// sum to `count` exactly and do not depend on anything else.
std::vector<int> SpeciesCounts(const Bodies& bodies);

}  // namespace granary::silo
