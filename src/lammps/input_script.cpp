// LAMMPS input generation (input_script.h). True 2-D (dimension 2, enforce2d), discs as
// spheres of areal mass rho pi r^2 and inertia 0.4 m r^2 (as the native engine), clumps as
// rigid bodies (fix rigid/small over molecule ids), walls as wall/gran planes and regions.
#include "lammps/input_script.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>

#include "rundir/shape_table.h"

namespace granary::lammps {

namespace {

constexpr double kChunkTime = 0.5;       // simulated time between script-level checks
constexpr double kEventInterval = 0.01;  // simulated time between looks at the exit lines
constexpr double kBaseThickness = 0.1;   // base and wall pieces: thin blocks, as the native segments
constexpr double kSettleCheck = 0.02;    // simulated time between looks at a settling bed's energy (engine/bed.cpp)

long long StepsOf(double time, double dt) { return std::max<long long>(1, std::llround(time / dt)); }

// The LAMMPS style of the spec's normal model (the native engine's laws are these two styles:
// engine/contact_law.h).
std::string Style(const Contact& c) {
  return c.normal_model == NormalModel::kHooke ? "hooke/history" : "hertz/history";
}

// pair_style / wall arguments: gran/<style> Kn Kt gamma_n gamma_t mu dampflag 1.
std::string Law(const Contact& c, double mu) {
  return Style(c) + " " + Num(c.kn) + " " + Num(c.kt) + " " + Num(c.gamma_n) + " " + Num(c.gamma_t) + " " + Num(mu) +
         " 1";
}

std::string Types(const std::vector<int>& types) {
  std::string s;
  for (int t : types) s += " " + std::to_string(t);
  return s;
}

// The model both scripts share: the box's boundaries, the atoms (from kDataFile, or a restart
// when `restart_line` is not ""), groups, contact law, integrators, gravity, 2-D.
void Model(std::ostringstream& o, const RunSpec& spec, const Setup& s, const std::string& restart_line,
           const char* data_file = kDataFile) {
  const Contact& c = spec.contact;
  const bool clumps = !s.clump_types.empty();
  o << "units lj\ndimension 2\natom_style sphere\natom_modify map array\n"
    << "boundary f " << (s.periodic ? "p" : "f") << " p\n"
    << "processors * 1 1\n"
    // Ghost atoms far enough for rigid bodies split between ranks.
    << "comm_modify vel yes cutoff " << Num(2 * s.bound_radius + 1.0) << "\n";
  if (!restart_line.empty()) {
    o << restart_line << "\n"
      << "fix mol all property/atom mol ghost yes\n";  // restores the molecule ids kept in the restart
  } else {
    o << "fix mol all property/atom mol ghost yes\n"
      << "read_data " << data_file << " fix mol NULL Molecules\n"
      << "set group all density/disc " << Num(spec.bodies.density) << "   # disc mass rho pi r^2\n";
  }
  if (!s.disc_types.empty()) o << "group discs type" << Types(s.disc_types) << "\n";
  if (clumps) o << "group clumps type" << Types(s.clump_types) << "\n";
  o << "# contact law: gran/" << Style(c) << " with body masses in m_eff, as the native engine (docs/lammps.md)\n"
    << "pair_style gran/" << Law(c, c.mu) << "\npair_coeff * *\n"
    << "neighbor 0.2 bin\nneigh_modify delay 0 every 1 check yes" << (clumps ? " exclude molecule/intra clumps" : "")
    << "\n"
    << "timestep " << Num(spec.time_step) << "\n";
  if (!s.disc_types.empty()) o << "fix integrate_discs discs nve/sphere   # sphere inertia 0.4 m r^2, as the engine\n";
  if (clumps) o << "fix integrate_clumps clumps rigid/small molecule\n";
  o << "fix gravity all gravity " << Num(spec.gravity) << " vector 0 -1 0\n"
    << "fix plane all enforce2d\n";
}

// Obstacles: wall/gran/region on cylinders. `contacts`: each fix keeps, per disc, the force
// it applied and the contact point (the contact frames and the clogs' contacts).
void Obstacles(std::vector<std::pair<std::string, std::string>>& fixes, const RunSpec& spec, bool contacts) {
  const std::string wall_region = "wall/gran/region " + Law(spec.contact, spec.contact.mu_wall);
  for (std::size_t k = 0; k < spec.silo.obstacles.size(); ++k) {
    const Obstacle& ob = spec.silo.obstacles[k];
    const std::string id = "obstacle_" + std::to_string(k);
    fixes.emplace_back(id, "region " + id + " cylinder z " + Num(ob.x) + " " + Num(ob.y) + " " + Num(ob.diameter / 2) +
                               " -0.5 0.5 side out units box\nfix " + id + " all " + wall_region + " region " + id +
                               (contacts ? " contacts" : "") + "\n");
  }
}

// The discharge's walls, base and obstacles: (fix id, its input lines). Side walls without an
// outlet are planes; the base between outlets and side walls with outlets are thin blocks
// (their corners are the outlet edges).
std::vector<std::pair<std::string, std::string>> DischargeWalls(const RunSpec& spec, const Setup& s) {
  const Contact& c = spec.contact;
  const Silo& silo = spec.silo;
  const double hw = s.half_width;
  const std::string wall = "wall/gran " + Law(c, c.mu_wall);
  const std::string wall_region = "wall/gran/region " + Law(c, c.mu_wall);
  std::vector<std::pair<std::string, std::string>> fixes;
  bool left_open = false, right_open = false;
  for (const SideOutlet& so : silo.side_outlets) (so.wall == Wall::kLeft ? left_open : right_open) = true;
  auto plane = [&](const std::string& id, const std::string& lo, const std::string& hi) {
    fixes.emplace_back(id, "fix " + id + " all " + wall + " xplane " + lo + " " + hi + " contacts\n");
  };
  if (!left_open && !right_open) {
    plane("side_walls", Num(-hw), Num(hw));
  } else {
    if (!left_open) plane("left_wall", Num(-hw), "NULL");
    if (!right_open) plane("right_wall", "NULL", Num(hw));
  }
  int piece = 0;
  auto block = [&](double x0, double x1, double y0, double y1) {
    const std::string id = "wall_piece_" + std::to_string(piece++);
    fixes.emplace_back(id, "region " + id + " block " + Num(x0) + " " + Num(x1) + " " + Num(y0) + " " + Num(y1) +
                               " -0.5 0.5 side out units box\nfix " + id + " all " + wall_region + " region " + id +
                               " contacts\n");
  };
  std::vector<std::pair<double, double>> gaps;
  for (const BaseOutlet& bo : silo.base_outlets) gaps.emplace_back(bo.center - bo.width / 2, bo.center + bo.width / 2);
  std::sort(gaps.begin(), gaps.end());
  // The base reaches under the side walls' blocks, so no gap opens at the corners.
  double x = -hw - kBaseThickness;
  for (const auto& [g0, g1] : gaps) {
    if (g0 > x + 1e-9) block(x, g0, -kBaseThickness, 0.0);
    x = std::max(x, g1);
  }
  if (x < hw + kBaseThickness - 1e-9) block(x, hw + kBaseThickness, -kBaseThickness, 0.0);
  const double wall_top = s.y_hi + 10;
  for (Wall side : {Wall::kLeft, Wall::kRight}) {
    if (!(side == Wall::kLeft ? left_open : right_open)) continue;
    std::vector<std::pair<double, double>> holes;
    for (const SideOutlet& so : silo.side_outlets)
      if (so.wall == side) holes.emplace_back(so.bottom, so.bottom + so.width);
    std::sort(holes.begin(), holes.end());
    const double x0 = side == Wall::kLeft ? -hw - kBaseThickness : hw, x1 = x0 + kBaseThickness;
    double y = -kBaseThickness;
    for (const auto& [h0, h1] : holes) {
      if (h0 > y + 1e-9) block(x0, x1, y, h0);
      y = std::max(y, h1);
    }
    block(x0, x1, y, wall_top);
  }
  Obstacles(fixes, spec, true);
  return fixes;
}

// The columns of the contact dumps (input_script.h kPairsDump, kWallsDump), and the per-atom
// variable that picks the discs touching a wall.
std::string PairColumns() {
  return "c_contact_atoms[1] c_contact_atoms[2] c_contact_forces[1] c_contact_forces[2] c_contact_forces[3] "
         "c_contact_forces[4]";
}
std::string WallColumns(const Setup& s) {
  std::string cols = "id x y";
  for (const std::string& f : s.wall_fixes) cols += " f_" + f + "[2] f_" + f + "[3] f_" + f + "[5] f_" + f + "[6]";
  return cols;
}

}  // namespace

std::string Num(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

Setup MakeSetup(const RunSpec& spec, const rundir::Frame& start) {
  Validate(spec);
  ValidateForLammps(spec);
  Setup s;
  s.species = static_cast<int>(spec.bodies.species.size());
  // Which species are clumps, and the bounding radius of every body, from the bed itself.
  std::map<std::int64_t, std::vector<const rundir::Disc*>> bodies;
  for (const rundir::Disc& d : start.discs) {
    if (d.type < 1 || d.type > s.species)
      throw std::runtime_error("the start frame has a disc of type " + std::to_string(d.type) + " for " +
                               std::to_string(s.species) + " species");
    bodies[d.mol].push_back(&d);
  }
  std::vector<int> discs_of(static_cast<std::size_t>(s.species), 0);
  for (const auto& [mol, discs] : bodies) {
    double m = 0, x = 0, y = 0;
    for (const rundir::Disc* d : discs) {
      m += d->mass;
      x += d->mass * d->x;
      y += d->mass * d->y;
    }
    x /= m;
    y /= m;
    for (const rundir::Disc* d : discs)
      s.bound_radius = std::max(s.bound_radius, std::hypot(d->x - x, d->y - y) + d->radius);
    discs_of[static_cast<std::size_t>(discs.front()->type - 1)] = static_cast<int>(discs.size());
  }
  for (std::size_t k = 0; k < spec.bodies.species.size(); ++k) {
    const bool clump = DiscsOf(spec.bodies.species[k]).r.size() > 1;  // LAMMPS moves one disc as an atom
    (clump ? s.clump_types : s.disc_types).push_back(static_cast<int>(k) + 1);
  }
  s.bodies = static_cast<int>(bodies.size());
  const double ed = spec.discharge.exit_distance, b = s.bound_radius;
  s.half_width = spec.silo.width / 2;
  const double x_margin = spec.silo.side_outlets.empty() ? 1.0 : ed + 2 * b + 2.0;
  s.x_lo = -s.half_width - x_margin;
  s.x_hi = s.half_width + x_margin;
  double top = 0, bed_top = 0;
  for (const rundir::Disc& d : start.discs) {
    top = std::max(top, d.y);
    bed_top = std::max(bed_top, d.y + d.radius);
  }
  s.periodic = spec.discharge.mode == DischargeMode::kReinject;
  if (s.periodic) {
    // The native engine's periodic box (run_spec.h kPeriodicFall): a body passing its bottom
    // comes back at its top, at the same x with its velocity.
    s.y_lo = -(ed + kPeriodicFall);
    s.y_hi = top + 2 * b + spec.discharge.periodic_headroom;
  } else {
    // Bodies are deleted b + 1 past the exit line; the top leaves room for the bed to dilate
    // (a disc leaving the box stops LAMMPS with "Lost atoms": never silently).
    s.y_lo = -(ed + 2 * b + 3.0);
    s.y_hi = std::max(1.5 * bed_top + 2 * b + 2.0, spec.silo.height);
  }
  s.event_every = StepsOf(kEventInterval, spec.time_step);
  for (const auto& [id, lines] : DischargeWalls(spec, s)) s.wall_fixes.push_back(id);
  return s;
}

std::string DataFile(const Setup& s, const rundir::Frame& start) {
  std::ostringstream o;
  o << "LAMMPS data file: a Granary bed (granary-lammps, docs/lammps.md), " << start.discs.size() << " discs\n\n"
    << start.discs.size() << " atoms\n"
    << s.species << " atom types\n\n"
    << Num(s.x_lo) << " " << Num(s.x_hi) << " xlo xhi\n"
    << Num(s.y_lo) << " " << Num(s.y_hi) << " ylo yhi\n"
    << "-0.5 0.5 zlo zhi\n\nAtoms # sphere\n\n";
  // atom-ID atom-type diameter density x y z: the density is set again by `set density/disc`.
  for (const rundir::Disc& d : start.discs)
    o << d.id << " " << d.type << " " << Num(2 * d.radius) << " 1 " << Num(d.x) << " " << Num(d.y) << " 0\n";
  o << "\nVelocities\n\n";
  for (const rundir::Disc& d : start.discs)
    o << d.id << " " << Num(d.vx) << " " << Num(d.vy) << " 0 0 0 " << Num(d.omega) << "\n";
  o << "\nMolecules\n\n";
  for (const rundir::Disc& d : start.discs) o << d.id << " " << d.mol + 1 << "\n";
  return o.str();
}

std::string DischargeScript(const RunSpec& spec, const Setup& s, const DischargeStart& start) {
  const double dt = spec.time_step;
  const Silo& silo = spec.silo;
  const double hw = s.half_width, ed = spec.discharge.exit_distance, b = s.bound_radius;
  const long long chunk = StepsOf(std::min(kChunkTime, spec.discharge.clog_window / 4), dt);
  const long long total = StepsOf(spec.discharge.max_time, dt);
  const long long clog_steps = StepsOf(spec.discharge.clog_window, dt);
  const bool remove = spec.discharge.mode == DischargeMode::kRemove;
  std::ostringstream o;
  o << "# Discharge, generated by granary-lammps from run.json (docs/lammps.md)\n";
  Model(o, spec, s, start.continue_run ? "read_restart " + start.restart_file : std::string());
  for (const auto& [id, lines] : DischargeWalls(spec, s)) o << lines;
  // Contacts: the touching pairs (`cutoff radius`; the same neighbour list order in both
  // computes, so their rows are the same pairs; pairs inside a clump are excluded from the
  // lists), and the discs touching a wall fix.
  o << "compute contact_atoms all property/local patom1 patom2 cutoff radius\n"
    << "compute contact_forces all pair/local fx fy p1 p2 cutoff radius\n"
    << "variable wall_contacts atom 0";
  for (const std::string& f : s.wall_fixes) o << "+f_" << f << "[1]";
  o << "\n";

  // Each body's centre of mass on each of its discs (unwrapped: in the periodic box its y
  // keeps falling by the box height at every pass), and 1 / its disc count.
  const double ly = s.y_hi - s.y_lo;
  o << "compute body all chunk/atom molecule compress no\n"
    << "compute body_com all com/chunk body\n"
    << "compute com all chunk/spread/atom body c_body_com[*]\n"
    << "compute body_discs all property/chunk body count\n"
    << "compute discs_of all chunk/spread/atom body c_body_discs\n"
    << "variable per_body atom 1.0/c_discs_of\n"
    << "compute bodies_now all reduce sum v_per_body\n";
  if (remove) {
    // A body has left when its centre of mass is exit_distance past an outlet's plane (the
    // native engine's exit lines); it is deleted once it is b + 0.5 further.
    o << "variable past atom (c_com[2]<" << Num(-ed) << ")||(abs(c_com[1])>" << Num(hw + ed) << ")\n"
      << "variable past_body atom v_past*v_per_body\n"
      << "compute past_now all reduce sum v_past_body\n"
      << "variable exited equal round(" << s.bodies << "-c_bodies_now+c_past_now)\n"
      << "region gone_below block INF INF INF " << Num(-(ed + b + 0.5)) << " INF INF units box\n"
      << "fix delete_below all evaporate " << s.event_every << " 1000000000 gone_below " << 4201 << " molecule yes\n";
    if (!silo.side_outlets.empty())
      o << "region gone_left block INF " << Num(-(hw + ed + b + 0.5)) << " INF INF INF INF units box\n"
        << "region gone_right block " << Num(hw + ed + b + 0.5) << " INF INF INF INF INF units box\n"
        << "fix delete_left all evaporate " << s.event_every << " 1000000000 gone_left 4203 molecule yes\n"
        << "fix delete_right all evaporate " << s.event_every << " 1000000000 gone_right 4205 molecule yes\n";
  } else {
    // Passes through the exit line: the unwrapped centre of mass below -ed - k Ly is k + 1 of them.
    o << "variable passes atom (c_com[2]<" << Num(-ed) << ")*(floor((" << Num(-ed) << "-c_com[2])/" << Num(ly)
      << ")+1)*v_per_body\n"
      << "compute passes_now all reduce sum v_passes\n"
      << "variable exited equal round(c_passes_now)\n"
      << "variable wrapped_y atom c_com[2]-" << Num(ly) << "*floor((c_com[2]-(" << Num(s.y_lo) << "))/" << Num(ly)
      << ")\n"
      << "variable past atom v_wrapped_y<" << Num(-ed) << "\n";
  }
  o << "dump exits all custom " << s.event_every << " " << kExitsDump << " id mol c_com[1] c_com[2]\n"
    << "dump_modify exits thresh v_past == 1 format line \"%d %d %.10g %.10g\""
    << (start.continue_run ? " append yes" : "") << "\n";
  if (spec.output.frame_interval > 0) {
    o << "dump frames all custom " << StepsOf(spec.output.frame_interval, dt) << " " << kFramesDump
      << " id mol type x y radius vx vy omegaz\n"
      << "dump_modify frames format line \"%d %d %d %.10g %.10g %.10g %.10g %.10g %.10g\""
      << (start.continue_run ? " append yes" : "") << "\n";
    if (spec.output.contact_forces) {
      const long long every = StepsOf(spec.output.frame_interval, dt);
      o << "dump contact_pairs all local " << every << " " << kPairsDump << " " << PairColumns() << "\n"
        << "dump_modify contact_pairs format float %.10g" << (start.continue_run ? " append yes" : "") << "\n"
        << "dump contact_walls all custom " << every << " " << kWallsDump << " " << WallColumns(s) << "\n"
        << "dump_modify contact_walls thresh v_wall_contacts > 0 format float %.10g"
        << (start.continue_run ? " append yes" : "") << "\n";
    }
  }
  if (spec.output.checkpoint_interval > 0)
    o << "restart " << StepsOf(spec.output.checkpoint_interval, dt) << " checkpoint.*.restart\n";
  o << "variable step_now equal step\nvariable atoms_now equal atoms\n"
    << "variable next_stop equal step+" << chunk << "\n"
    << "thermo_style custom step time atoms v_exited cpu\nthermo " << chunk << "\n"
    << "thermo_modify norm no\n"
    << "run 0 post no\n"
    << "variable exited_last equal ${exited}\n"
    << "variable last_exit_step equal " << start.last_exit_step << "\n"
    << "variable clog_counted equal " << (start.in_clog ? 1 : 0) << "\n"
    << "label discharge\n"
    << "if \"${step_now} >= " << total << "\" then \"print 'GRANARY_END time_limit'\" \"jump SELF finished\"\n"
    << "if \"${next_stop} > " << total << "\" then \"variable next_stop equal " << total << "\"\n"
    << "run ${next_stop} upto post no\n"
    << "print \"GRANARY_PROGRESS ${step_now} ${exited}\"\n"
    << "include " << kControlFile << "\n"
    << "if \"${stop_requested} == 1\" then \"write_restart checkpoint.*.restart\" "
       "\"print 'GRANARY_STOPPED ${step_now}'\" \"jump SELF stopped\"\n"
    << "if \"${exited} > ${exited_last}\" then \"variable exited_last equal ${exited}\" "
       "\"variable last_exit_step equal ${step_now}\" \"variable clog_counted equal 0\"\n";
  if (remove) o << "if \"${atoms_now} == 0\" then \"print 'GRANARY_END discharged'\" \"jump SELF finished\"\n";
  o << "variable since_exit equal step-v_last_exit_step\n";
  const std::string stalled = "\"${since_exit} >= " + std::to_string(clog_steps) + " && ${clog_counted} == 0\"";
  const std::string keep =
      std::string(" \"write_dump all custom ") + kClogFilePrefix +
      "${step_now}.atoms id mol type x y radius vx vy omegaz modify format line "
      "'%d %d %d %.10g %.10g %.10g %.10g %.10g %.10g'\"" +
      // The contacts through dumps and a `run 0`: write_dump refuses a local
      // compute between runs ("not current").
      " \"dump clog_pairs all local 1 " + kClogFilePrefix + "${step_now}.pairs " + PairColumns() +
      "\" \"dump_modify clog_pairs format float %.10g\" \"dump clog_walls all custom 1 " + kClogFilePrefix +
      "${step_now}.walls " + WallColumns(s) +
      "\" \"dump_modify clog_walls thresh v_wall_contacts > 0 format float %.10g\" \"run 0 post no\" "
      "\"undump clog_pairs\" \"undump clog_walls\"";
  if (remove)
    o << "if " << stalled << " then \"write_restart checkpoint.*.restart\"" << keep
      << " \"print 'GRANARY_END stalled'\" \"jump SELF finished\"\n";
  else if (spec.discharge.StopOnClog())
    o << "if " << stalled << " then" << keep << " \"print 'GRANARY_END clogged'\" \"jump SELF finished\"\n";
  else
    o << "if " << stalled << " then" << keep
      << " \"print 'GRANARY_CLOG ${step_now}'\" \"variable clog_counted equal 1\"\n";
  o << "jump SELF discharge\nlabel finished\n"
    << "write_dump all custom " << kFinalDump
    << " id mol type x y radius modify format line '%d %d %d %.10g %.10g %.10g'\n"
    << "print \"GRANARY_FINAL ${step_now}\"\n"
    << "label stopped\n";
  return o.str();
}

Setup SettleSetup(const RunSpec& spec, const rundir::Frame& loose) {
  Setup s = MakeSetup(spec, loose);
  double top = 0;
  for (const rundir::Disc& d : loose.discs) top = std::max(top, d.y + d.radius);
  s.periodic = false;
  s.x_lo = -s.half_width - 1.0;
  s.x_hi = s.half_width + 1.0;
  s.y_lo = -(2 * s.bound_radius + 3.0);
  s.y_hi = top + 2 * s.bound_radius + 2.0;
  return s;
}

std::string SettleScript(const RunSpec& spec, const Setup& s, double fall_time) {
  const double dt = spec.time_step;
  const Contact& c = spec.contact;
  const std::string wall = "wall/gran " + Law(c, c.mu_wall);
  // The native engine's criterion (engine/bed.cpp): kinetic energy per body below
  // settle_ke_per_body in units of the mean body's m g d, looked at every kSettleCheck; not
  // before the bodies have had time to fall through their region; at most max_settle_time.
  std::ostringstream o;
  o << "# Bed settling, generated by granary-lammps from run.json (bed/settled_by \"lammps\", docs/lammps.md)\n";
  Model(o, spec, s, std::string(), kLooseDataFile);
  o << "fix side_walls all " << wall << " xplane " << Num(-s.half_width) << " " << Num(s.half_width) << "\n"
    << "fix base all " << wall << " yplane 0 NULL\n";
  std::vector<std::pair<std::string, std::string>> obstacles;
  Obstacles(obstacles, spec, false);
  for (const auto& [id, lines] : obstacles) o << lines;
  // Atom velocities of a rigid body are its motion at each disc, and its discs' spins its
  // own: the two sums are the bodies' kinetic energy.
  o << "variable bodies equal " << s.bodies << "\n"
    << "compute translation all ke\ncompute rotation all erotate/sphere\n"
    << "variable mass_total equal mass(all)\n"
    << "variable ke_per_body equal (c_translation+c_rotation)/v_bodies/(v_mass_total/v_bodies*" << Num(spec.gravity)
    << ")\n"
    << "variable settled equal (v_ke_per_body<" << Num(spec.bed.settle_ke_per_body) << ")&&(time>" << Num(fall_time)
    << ")\n"
    << "fix settle all halt " << StepsOf(kSettleCheck, dt) << " v_settled == 1 error continue\n"
    << "thermo_style custom step time atoms v_ke_per_body cpu\nthermo " << StepsOf(kChunkTime, dt) << "\n"
    << "thermo_modify norm no\n"
    << "run " << StepsOf(spec.bed.max_settle_time, dt) << "\n"
    << "variable t_settled equal time\nvariable ke_now equal v_ke_per_body\n"
    << "write_dump all custom " << kSettledDump
    << " id mol type x y radius vx vy omegaz modify format line '%d %d %d %.17g %.17g %.17g %.17g %.17g %.17g'\n"
    << "print \"GRANARY_SETTLED ${t_settled} ${ke_now}\"\n";
  return o.str();
}

}  // namespace granary::lammps
