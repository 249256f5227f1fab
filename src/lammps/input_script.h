// LAMMPS input generation from a resolved RunSpec and the bed it starts from (docs/lammps.md).
//
// Pure: a RunSpec and the start frame in, text out (the data file and the discharge script).
// Every value in a script is a number formatted here and every file name is fixed, so no
// string from a spec reaches LAMMPS (it has `shell` and `$`/`v_` substitution).
#pragma once

#include <string>
#include <vector>

#include "rundir/frames.h"
#include "rundir/run_spec.h"

namespace granary::lammps {

// The file the discharge script includes after every chunk: "variable stop_requested equal 0",
// or 1 on a stop request, which makes LAMMPS write a checkpoint and end.
inline constexpr char kControlFile[] = "granary_control.in";
// The bed as a LAMMPS data file (atom_style sphere, molecule ids through fix property/atom).
inline constexpr char kDataFile[] = "bed.data";
// What the script writes (read by the backend, converted into the run-directory files).
inline constexpr char kFramesDump[] = "frames.lammps";  // id mol type x y radius vx vy omegaz
inline constexpr char kExitsDump[] = "exits.lammps";    // id mol xcm ycm of bodies past an exit line
// output/contact_forces, at the frames' steps: the touching pairs of discs of different bodies
// (compute property/local + pair/local, local dump: id_i id_j fx fy ftx fty, the normal and the
// tangential force on i), and every disc touching a wall or obstacle (id x y, then fx fy cx cy
// of each wall fix in kWallFixes order: the force on the disc and the contact point on the wall).
inline constexpr char kPairsDump[] = "contacts_pairs.lammps";
inline constexpr char kWallsDump[] = "contacts_walls.lammps";
inline constexpr char kFinalDump[] = "final.lammps";  // id mol type x y radius at the end
// At a stall: clog.<step>.atoms (as kFramesDump), clog.<step>.pairs, clog.<step>.walls (as the
// two contact dumps).
inline constexpr char kClogFilePrefix[] = "clog.";
// bed/settled_by "lammps": the loose placement LAMMPS settles, and the settled bed.
inline constexpr char kLooseDataFile[] = "loose.data";
inline constexpr char kSettledDump[] = "settled.lammps";  // id mol type x y radius vx vy omegaz

// The box and the bodies as LAMMPS runs them.
struct Setup {
  int species = 0;               // atom types 1..species
  std::vector<int> clump_types;  // atom types of multi-disc species (fix rigid/small)
  std::vector<int> disc_types;   // atom types of one-disc species (fix nve/sphere)
  double half_width = 0;
  double x_lo = 0, x_hi = 0, y_lo = 0, y_hi = 0;
  bool periodic = false;      // reinject: y-periodic box (the native engine's "periodic" box)
  double bound_radius = 0;    // largest body's bounding radius
  int bodies = 0;             // in the bed at t = 0
  long long event_every = 1;  // steps between looks at the exit lines
  // The discharge's wall and obstacle fixes (fix wall/gran ... contacts), in the order of
  // their columns in kWallsDump.
  std::vector<std::string> wall_fixes;
};

// Throws SpecError for what LAMMPS cannot run (validate_for_lammps) and for a start frame
// that does not fit the spec. Names the discharge's wall fixes.
Setup MakeSetup(const RunSpec& spec, const rundir::Frame& start);

// The bed as a LAMMPS data file: atom ids = the native disc ids, molecule ids = body ids + 1,
// types = species + 1, velocities and spins.
std::string DataFile(const Setup& setup, const rundir::Frame& start);

struct DischargeStart {
  bool continue_run = false;
  std::string restart_file;  // checkpoint.<step>.restart (a fixed-form name)
  long long last_exit_step = 0;
  long long exited = 0;  // exits counted before the checkpoint (reinject: from the events)
  bool in_clog = false;  // a clog counted at or after last_exit_step
};

// The discharge: from the data file (fresh) or a restart (continue). Prints
// "GRANARY_PROGRESS step exited" every chunk, "GRANARY_CLOG step" (reinject, going on through
// clogs), "GRANARY_END reason" and "GRANARY_FINAL step" at the end, "GRANARY_STOPPED step" when
// stopped on request.
std::string DischargeScript(const RunSpec& spec, const Setup& setup, const DischargeStart& start);

// bed/settled_by "lammps": the box of the settling (the closed silo, room above the loose
// placement) and the script that settles the bodies of kLooseDataFile under gravity with the
// outlets closed until their kinetic energy per body is below bed/settle_ke_per_body (not
// before `fall_time`, at most bed/max_settle_time), then writes kSettledDump and prints
// "GRANARY_SETTLED time ke_per_body".
Setup SettleSetup(const RunSpec& spec, const rundir::Frame& loose);
std::string SettleScript(const RunSpec& spec, const Setup& setup, double fall_time);

// The exact number formatting used in the inputs (17 significant digits, C locale).
std::string Num(double v);

}  // namespace granary::lammps
