// LIGGGHTS 3.8 input generation from a resolved RunSpec (docs/liggghts.md).
//
// Everything here is pure: a RunSpec in, text out (input scripts and STL meshes). The
// scripts reference only fixed file names relative to the run directory, and every value
// in them is a number formatted here, so no string from a spec ever reaches LIGGGHTS (it
// has `shell` and `$`/`v_` substitution).
#pragma once

#include <array>
#include <string>
#include <vector>

#include "rundir/run_spec.h"

namespace granary::liggghts {

// The file the discharge script includes after every chunk: the backend writes
// "variable stop_requested equal 0" into it before LIGGGHTS starts, and "... 1" on a stop
// request, which makes LIGGGHTS write a checkpoint and end.
inline constexpr char kControlFile[] = "granary_control.in";

// A planar rectangle for an STL mesh: the segment (x0,y0)-(x1,y1) in the silo plane,
// extruded over z in [-half_z, half_z].
struct MeshFile {
  std::string name;  // file name in the run directory, e.g. "mesh_base_0.stl"
  double x0, y0, x1, y1;
  std::vector<std::array<double, 2>> then = {};  // a polyline goes on through these points
};

// A counting plane (fix massflow/mesh) behind an outlet. Outlets are numbered base outlets
// first, then side outlets; a side outlet has two planes: one outside the wall and one
// below the base level, for bodies that drop down the outside of the wall.
struct Counter {
  MeshFile mesh;
  double side_x, side_y;  // direction in which a body leaves (massflow vec_side)
  int outlet;
  std::string file;  // the crossings LIGGGHTS writes (per MPI rank: file.<rank>)
};

// The quasi-2-D set-up shared by the bed and discharge scripts.
struct SiloSetup {
  int species = 0;                // atom types 1..species are the bodies' spheres
  int wall_type = 0;              // = species + 1
  bool multisphere = false;       // any clump: clumps are multisphere bodies (fix multisphere)
  std::vector<int> single_types;  // atom types of single-disc species, integrated by nve/sphere
  double half_width = 0;          // side walls at +-half_width
  double x_lo = 0, x_hi = 0;      // box
  double y_lo = 0, y_hi = 0;      // box (periodic in y)
  double half_z = 0;              // box z extent [-half_z, half_z]
  double bound_radius = 0;        // largest body's bounding radius
  double insert_y_lo = 0, insert_y_hi = 0;
  double insert_x_half = 0;
  double mean_body_mass = 0;
  std::vector<MeshFile> fill_meshes;       // closed base
  std::vector<MeshFile> discharge_meshes;  // base between outlets, side-wall pieces around side outlets
  bool wall_lo_primitive = true, wall_hi_primitive = true;  // false when that side wall has an outlet
  // With output.contact_forces every wall of the discharge is a mesh of one fix, the only kind
  // LIGGGHTS' compute wall/gran/local reports: full side walls and faceted obstacles too.
  bool obstacles_as_meshes = false;
  std::vector<Counter> counters;
  int outlets = 0;
  std::vector<std::string> template_lines;  // particletemplate + particledistribution commands
  int template_count = 0;
};

// Throws SpecError for what the backend cannot express (e.g. reinject with a side outlet).
// `box_top`: the top of the settled bed's box (the bed script shrinks the box to just above
// the bed); side-wall meshes must end inside it. 0 = before the bed exists.
SiloSetup MakeSetup(const RunSpec& spec, double box_top = 0.0);

// Bed script: insert, settle until the kinetic energy per body is negligible, write
// bed.restart and bed.dump. Prints "GRANARY_BED t=... ke=..." every chunk.
std::string BedScript(const RunSpec& spec, const SiloSetup& setup);

// Discharge script from bed.restart (fresh) or from `restart_file` (continue, with
// `last_exit_step` the step of the last exit before the checkpoint). Prints
// "GRANARY_PROGRESS step exited atoms" every chunk and "GRANARY_END reason" at the end.
struct DischargeStart {
  bool continue_run = false;
  std::string restart_file;  // fixed-form name chosen by the backend (checkpoint.<step>.restart)
  long long last_exit_step = 0;
  bool in_clog = false;  // a clog was counted at or after last_exit_step: wait for an exit before the next
};
std::string DischargeScript(const RunSpec& spec, const SiloSetup& setup, const DischargeStart& start);

// The discharge script keeps each stall's configuration and contact forces in
// <prefix><step>.atoms (custom dump: id mol-or-id type x y radius vx vy omegaz),
// <prefix><step>.pairs (as contacts_pairs.liggghts) and, with output.contact_forces,
// <prefix><step>.walls (as contacts_walls.liggghts).
inline constexpr char kClogFilePrefix[] = "clog.";

// ASCII STL of one rectangle.
std::string Stl(const MeshFile& mesh, double half_z);

// The exact numbers formatting used in scripts (17 significant digits, C locale).
std::string Num(double v);

// Smallest prime > 10000 derived from a seed and a salt (LIGGGHTS wants prime seeds > 10000).
long long PrimeSeed(std::uint64_t seed, int salt);

}  // namespace granary::liggghts
