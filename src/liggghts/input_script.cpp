// LIGGGHTS 3.8 input generation (input_script.h). The set-up follows the verified
// quasi-2-D recipe of docs/liggghts.md: a 3-D box, every sphere centre in the
// plane z = 0, multisphere bodies with fflag/tflag locking out-of-plane motion, walls as
// primitives or STL meshes, the base closed by a mesh while the bed settles.
#include "liggghts/input_script.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <sstream>

#include "rundir/shape_table.h"
#include "silo/shapes.h"

namespace granary::liggghts {

using silo::ShapeTemplate;

namespace {

constexpr double kInsertAreaFraction = 0.25;  // dilute enough for insert/pack to place every body
constexpr double kChunkTime = 0.5;            // simulated time between script-level checks
constexpr int kObstacleFacets = 64;           // with output.contact_forces, obstacles are polygon meshes

constexpr char kModel[] = "model hertz/stiffness tangential history";
// limitForce on clips an attractive normal force, the spec's clip_normal. Pair styles take
// these settings after the model, wall fixes after the wall geometry.
std::string ModelSettings(const RunSpec& spec) {
  return std::string("tangential_damping on limitForce ") + (spec.contact.clip_normal ? "on" : "off");
}

// A matrix of per-type-pair values: `value` between body types, `wall_value` with the wall type.
std::string PairMatrix(const std::string& fix_id, const std::string& property, int types, double value,
                       double wall_value) {
  std::string s = "fix " + fix_id + " all property/global " + property + " peratomtypepair " + std::to_string(types);
  for (int i = 1; i <= types; ++i)
    for (int j = 1; j <= types; ++j) s += " " + Num(i == types || j == types ? wall_value : value);
  return s + "\n";
}

std::string Material(const RunSpec& spec, const SiloSetup& setup) {
  const Contact& c = spec.contact;
  const int n = setup.wall_type;
  std::string s = "# contact law (docs/liggghts.md): Hertz with tangential history, body masses in m_eff\n";
  s += PairMatrix("m_kn", "kn", n, c.kn, c.kn);
  s += PairMatrix("m_kt", "kt", n, c.kt, c.kt);
  s += PairMatrix("m_gamman", "gamman", n, c.gamma_n, c.gamma_n);
  s += PairMatrix("m_gammat", "gammat", n, c.gamma_t, c.gamma_t);
  s += PairMatrix("m_mu", "coefficientFriction", n, c.mu, c.mu_wall);
  s += std::string("pair_style gran ") + kModel + " " + ModelSettings(spec) + "\npair_coeff * *\n";
  s += "fix grav all gravity " + Num(spec.gravity) + " vector 0 -1 0\n";
  return s;
}

std::string WallFix(const RunSpec& spec, const std::string& id, const std::string& geometry) {
  return "fix " + id + " all wall/gran " + kModel + " " + geometry + " " + ModelSettings(spec) + "\n";
}

std::string MeshWalls(const RunSpec& spec, const SiloSetup& setup, const std::vector<MeshFile>& meshes,
                      const std::string& walls_id) {
  if (meshes.empty()) return "";
  std::string s, ids;
  for (const MeshFile& m : meshes) {
    const std::string id = m.name.substr(0, m.name.size() - 4);  // "mesh_base_0.stl" -> "mesh_base_0"
    s += "fix " + id + " all mesh/surface file " + m.name + " type " + std::to_string(setup.wall_type) + "\n";
    ids += " " + id;
  }
  s += WallFix(spec, walls_id, "mesh n_meshes " + std::to_string(meshes.size()) + " meshes" + ids);
  return s;
}

// Side walls as planes (both while the bed settles: the silo is closed then) and obstacles.
std::string PrimitiveWalls(const RunSpec& spec, const SiloSetup& setup, bool closed) {
  const std::string type = "primitive type " + std::to_string(setup.wall_type);
  std::string s;
  if (closed || setup.wall_lo_primitive) s += WallFix(spec, "wall_lo", type + " xplane " + Num(-setup.half_width));
  if (closed || setup.wall_hi_primitive) s += WallFix(spec, "wall_hi", type + " xplane " + Num(setup.half_width));
  for (std::size_t k = 0; k < spec.silo.obstacles.size() && !setup.obstacles_as_meshes; ++k) {
    const Obstacle& o = spec.silo.obstacles[k];
    s += WallFix(spec, "obstacle_" + std::to_string(k),
                 type + " zcylinder " + Num(o.diameter / 2) + " " + Num(o.x) + " " + Num(o.y));
  }
  return s;
}

// Both must precede read_restart, which does not restore them (notes §4.3); `processors`
// splits in x only, since the bed fills the bottom of a tall box (notes §3).
constexpr char kHeader[] = "atom_modify map array\nprocessors * 1 1\n";

// Clumps move with fix multisphere (fflag/tflag keep them planar); single discs with
// nve/sphere, planeforce dropping f_z so that their centres stay in z = 0. fix multisphere
// integrates bodies only, so with a mixture the discs are the group `singles` (by atom type),
// made after insertion: a static group holds the atoms that exist when it is defined.
std::string ClumpIntegration(const SiloSetup& setup) {
  // allow_group_and_set: the groups below and Count(all,region) in the discharge.
  return setup.multisphere ? "fix ms all multisphere allow_group_and_set yes\n" : "";
}
std::string SingleIntegration(const SiloSetup& setup, bool define_group) {
  if (setup.single_types.empty()) return "";
  if (!setup.multisphere) return "fix integrate all nve/sphere\nfix planar all planeforce 0 0 1\n";
  std::string s;
  if (define_group) {
    s = "group singles type";
    for (int t : setup.single_types) s += " " + std::to_string(t);
    s += "\n";
  }
  return s + "fix integrate singles nve/sphere\nfix planar singles planeforce 0 0 1\n";
}

// The body of a sphere in dumps: the multisphere body (`mol`; 0 for a single sphere), or,
// without clumps, the sphere itself (`mol` is not allocated then).
std::string BodyColumn(const SiloSetup& setup) { return setup.multisphere ? "mol" : "id"; }

long long StepsOf(double time, double dt) { return std::max<long long>(1, std::llround(time / dt)); }

bool IsPrime(long long n) {
  if (n < 2) return false;
  for (long long d = 2; d * d <= n; ++d)
    if (n % d == 0) return false;
  return true;
}

}  // namespace

std::string Num(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

long long PrimeSeed(std::uint64_t seed, int salt) {
  // SplitMix64 step: well-spread, reproducible.
  std::uint64_t z = seed + 0x9E3779B97F4A7C15ULL * static_cast<std::uint64_t>(salt + 1);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  z ^= z >> 31;
  long long n = 10007 + static_cast<long long>(z % 900000000ULL);
  while (!IsPrime(n)) ++n;
  return n;
}

std::string Stl(const MeshFile& m, double half_z) {
  std::vector<std::array<double, 2>> points = {{m.x0, m.y0}, {m.x1, m.y1}};
  points.insert(points.end(), m.then.begin(), m.then.end());
  std::string s = "solid granary\n";
  for (std::size_t p = 0; p + 1 < points.size(); ++p) {
    // Each segment: normal in the plane, perpendicular to it; two triangles.
    const auto [x0, y0] = points[p];
    const auto [x1, y1] = points[p + 1];
    const double dx = x1 - x0, dy = y1 - y0, len = std::hypot(dx, dy);
    const double nx = -dy / len, ny = dx / len;
    const double v[4][3] = {{x0, y0, -half_z}, {x1, y1, -half_z}, {x1, y1, half_z}, {x0, y0, half_z}};
    const int tris[2][3] = {{0, 1, 2}, {0, 2, 3}};
    for (const auto& t : tris) {
      s += "  facet normal " + Num(nx) + " " + Num(ny) + " 0\n    outer loop\n";
      for (int k : t) s += "      vertex " + Num(v[k][0]) + " " + Num(v[k][1]) + " " + Num(v[k][2]) + "\n";
      s += "    endloop\n  endfacet\n";
    }
  }
  return s + "endsolid granary\n";
}

SiloSetup MakeSetup(const RunSpec& spec, double box_top) {
  Validate(spec);
  ValidateForLiggghts(spec);
  SiloSetup s;
  const Silo& silo = spec.silo;
  const double ed = spec.discharge.exit_distance;

  std::vector<ShapeTemplate> templates;
  for (std::size_t k = 0; k < spec.bodies.species.size(); ++k)
    templates.push_back(silo::MakeTemplate(spec.bodies.species[k], spec.bodies.density, static_cast<int>(k)));
  const std::vector<int> counts = silo::SpeciesCounts(spec.bodies);
  s.species = static_cast<int>(templates.size());
  s.wall_type = s.species + 1;
  double bound = 0, area = 0, mass = 0;
  for (std::size_t k = 0; k < templates.size(); ++k) {
    s.multisphere = s.multisphere || templates[k].r.size() > 1;
    if (templates[k].r.size() == 1) s.single_types.push_back(static_cast<int>(k) + 1);
    bound = std::max(bound, templates[k].bound_radius);
    area += counts[k] * templates[k].area;
    mass += counts[k] * templates[k].mass;
  }
  s.mean_body_mass = mass / spec.bodies.count;

  s.half_width = silo.width / 2;
  const double x_margin = silo.side_outlets.empty() ? 1.0 : ed + 3.0;
  s.x_lo = -s.half_width - x_margin;
  s.x_hi = s.half_width + x_margin;
  s.bound_radius = bound;
  s.half_z = std::max(2.0, bound + 1.0);  // more than the bounding radius, or nothing is inserted (notes §4.6)
  s.y_lo = -(ed + kPeriodicFall);         // the native engine's periodic reinjection uses the same box
  double floor = 1.0 + bound;
  for (const Obstacle& o : silo.obstacles) floor = std::max(floor, o.y + o.diameter / 2 + bound + 0.5);
  s.insert_x_half = s.half_width - bound - 0.05;
  s.insert_y_lo = floor;
  s.insert_y_hi = floor + area / (kInsertAreaFraction * 2 * s.insert_x_half) + 2 * bound;
  s.y_hi = s.insert_y_hi + bound + 2.0;
  if (silo.height > 0) s.y_hi = std::max(s.y_hi, silo.height);

  s.fill_meshes.push_back({"mesh_fill_base.stl", -s.half_width, 0.0, s.half_width, 0.0});

  // Base pieces between the outlets, left to right.
  std::vector<std::pair<double, double>> gaps;
  for (const BaseOutlet& o : silo.base_outlets) gaps.emplace_back(o.center - o.width / 2, o.center + o.width / 2);
  std::sort(gaps.begin(), gaps.end());
  double x = -s.half_width;
  int piece = 0;
  for (const auto& [g0, g1] : gaps) {
    if (g0 > x + 1e-9) s.discharge_meshes.push_back({"mesh_base_" + std::to_string(piece++) + ".stl", x, 0.0, g0, 0.0});
    x = std::max(x, g1);
  }
  if (x < s.half_width - 1e-9)
    s.discharge_meshes.push_back({"mesh_base_" + std::to_string(piece++) + ".stl", x, 0.0, s.half_width, 0.0});

  // Side walls with outlets become mesh pieces; the others stay primitive planes.
  for (Wall wall : {Wall::kLeft, Wall::kRight}) {
    std::vector<std::pair<double, double>> holes;
    for (const SideOutlet& o : silo.side_outlets)
      if (o.wall == wall) holes.emplace_back(o.bottom, o.bottom + o.width);
    if (holes.empty()) continue;
    (wall == Wall::kLeft ? s.wall_lo_primitive : s.wall_hi_primitive) = false;
    std::sort(holes.begin(), holes.end());
    const double wx = wall == Wall::kLeft ? -s.half_width : s.half_width;
    const std::string side = wall == Wall::kLeft ? "left" : "right";
    // A mesh must lie inside the box, which ends just above the bed: pieces above it are dropped.
    const double top = box_top > 0 ? box_top - 0.01 : s.y_hi;
    double y = 0.0;
    int k = 0;
    for (const auto& [h0, h1] : holes) {
      if (h0 > y + 1e-9 && y < top)
        s.discharge_meshes.push_back(
            {"mesh_" + side + "_" + std::to_string(k++) + ".stl", wx, y, wx, std::min(h0, top)});
      y = std::max(y, h1);
    }
    if (y < top) s.discharge_meshes.push_back({"mesh_" + side + "_" + std::to_string(k++) + ".stl", wx, y, wx, top});
  }

  if (spec.output.contact_forces) {
    const double top = box_top > 0 ? box_top - 0.01 : s.y_hi;
    if (s.wall_lo_primitive) s.discharge_meshes.push_back({"mesh_left_0.stl", -s.half_width, 0.0, -s.half_width, top});
    if (s.wall_hi_primitive) s.discharge_meshes.push_back({"mesh_right_0.stl", s.half_width, 0.0, s.half_width, top});
    s.wall_lo_primitive = s.wall_hi_primitive = false;
    // Obstacles: polygons whose facets touch the circle (at most 0.12 % of the radius outside it),
    // in the bed too, which must rest on the same surfaces as the discharge.
    for (std::size_t k = 0; k < silo.obstacles.size(); ++k) {
      const Obstacle& o = silo.obstacles[k];
      const double corner = o.diameter / 2 / std::cos(std::numbers::pi / kObstacleFacets);
      MeshFile m{"mesh_obstacle_" + std::to_string(k) + ".stl", o.x + corner, o.y, 0, 0};
      for (int f = 1; f <= kObstacleFacets; ++f) {
        const double a = 2 * std::numbers::pi * f / kObstacleFacets;
        const std::array<double, 2> p = {o.x + corner * std::cos(a), o.y + corner * std::sin(a)};
        if (f == 1) {
          m.x1 = p[0];
          m.y1 = p[1];
        } else {
          m.then.push_back(p);
        }
      }
      s.fill_meshes.push_back(m);
      s.discharge_meshes.push_back(m);
    }
    s.obstacles_as_meshes = true;
  }

  // Counting planes: below each base outlet (a little wider, but never reaching the next
  // outlet's plane), and outside each side outlet down to the bottom of the box.
  for (std::size_t k = 0; k < silo.base_outlets.size(); ++k) {
    const BaseOutlet& o = silo.base_outlets[k];
    double lo = o.center - o.width / 2 - 1.0, hi = o.center + o.width / 2 + 1.0;
    for (std::size_t j = 0; j < silo.base_outlets.size(); ++j) {
      if (j == k) continue;
      const BaseOutlet& p = silo.base_outlets[j];
      if (p.center > o.center)
        hi = std::min(hi, 0.5 * (o.center + o.width / 2 + p.center - p.width / 2));
      else
        lo = std::max(lo, 0.5 * (p.center + p.width / 2 + o.center - o.width / 2));
    }
    lo = std::max(lo, s.x_lo + 0.01);
    hi = std::min(hi, s.x_hi - 0.01);
    s.counters.push_back({{"mesh_exit_" + std::to_string(k) + ".stl", lo, -ed, hi, -ed},
                          0.0,
                          -1.0,
                          static_cast<int>(k),
                          "exits_" + std::to_string(k) + ".txt"});
  }
  for (std::size_t k = 0; k < silo.side_outlets.size(); ++k) {
    const SideOutlet& o = silo.side_outlets[k];
    const double sign = o.wall == Wall::kLeft ? -1.0 : 1.0;
    const double cx = sign * (s.half_width + ed);
    const int outlet = static_cast<int>(silo.base_outlets.size() + k);
    const std::string name = std::to_string(outlet);
    s.counters.push_back({{"mesh_exit_" + name + ".stl", cx, -ed, cx, o.bottom + o.width + 1.0},
                          sign,
                          0.0,
                          outlet,
                          "exits_" + name + ".txt"});
    const double inner = sign * (s.half_width + 0.01), outer = sign > 0 ? s.x_hi - 0.01 : s.x_lo + 0.01;
    s.counters.push_back(
        {{"mesh_exit_" + name + "_below.stl", std::min(inner, outer), -ed, std::max(inner, outer), -ed},
         0.0,
         -1.0,
         outlet,
         "exits_" + name + "_below.txt"});
  }
  s.outlets = static_cast<int>(silo.base_outlets.size() + silo.side_outlets.size());

  // One template per species and orientation: insert/pack has no random in-plane
  // orientation, so rotated copies are mixed (6 over 180 degrees for symmetric bodies,
  // 12 over 360 for snowmen). Weights are mass-based in LIGGGHTS: fraction x mass.
  int t = 0, clump_type = 0;  // clump template types must run 1, 2, ... (sphere templates have none)
  std::string dist;
  for (std::size_t k = 0; k < templates.size(); ++k) {
    const ShapeTemplate& tp = templates[k];
    const bool half_turn = ShapeRowOf(spec.bodies.species[k].shape).half_turn_symmetric;
    const int angles = tp.r.size() == 1 ? 1 : (half_turn ? 6 : 12);
    const double span = half_turn ? std::numbers::pi : 2 * std::numbers::pi;
    double sphere_volume = 0;
    for (double r : tp.r) sphere_volume += 4.0 / 3.0 * std::numbers::pi * r * r * r;
    const double density3d = tp.mass / sphere_volume;  // nominal: the mass is given explicitly
    for (int a = 0; a < angles; ++a, ++t) {
      const double th = span * a / angles, c = std::cos(th), sn = std::sin(th);
      const std::string id = "tmpl_" + std::to_string(t);
      const long long seed = PrimeSeed(spec.seed, 100 + t);
      std::string line;
      if (tp.r.size() == 1) {
        line = "fix " + id + " all particletemplate/sphere " + std::to_string(seed) + " atom_type " +
               std::to_string(k + 1) + " density constant " + Num(density3d) + " radius constant " + Num(tp.r[0]);
      } else {
        double ixx = 0, iyy = 0, ixy = 0;
        std::string spheres;
        for (std::size_t i = 0; i < tp.r.size(); ++i) {
          const double px = c * tp.ox[i] - sn * tp.oy[i], py = sn * tp.ox[i] + c * tp.oy[i];
          const double own = 0.4 * tp.disc_mass[i] * tp.r[i] * tp.r[i];
          ixx += own + tp.disc_mass[i] * py * py;
          iyy += own + tp.disc_mass[i] * px * px;
          ixy -= tp.disc_mass[i] * px * py;
          spheres += " " + Num(px) + " " + Num(py) + " 0 " + Num(tp.r[i]);
        }
        line = "fix " + id + " all particletemplate/multisphere " + std::to_string(seed) + " atom_type " +
               std::to_string(k + 1) + " density constant " + Num(density3d) + " nspheres " +
               std::to_string(tp.r.size()) + " ntry 1000000 spheres" + spheres + " type " +
               std::to_string(++clump_type) + " mass " + Num(tp.mass) + " use_density inertia_tensor " + Num(ixx) +
               " " + Num(ixy) + " 0 " + Num(iyy) + " 0 " + Num(tp.inertia) + " fflag on on off tflag off off on";
      }
      s.template_lines.push_back(line + "\n");
      dist += " " + id + " " + Num(spec.bodies.species[k].fraction / angles * tp.mass);
    }
  }
  s.template_count = t;
  s.template_lines.push_back("fix bodies all particledistribution/discrete " + std::to_string(PrimeSeed(spec.seed, 1)) +
                             " " + std::to_string(t) + dist + "\n");
  return s;
}

std::string BedScript(const RunSpec& spec, const SiloSetup& s) {
  const double dt = spec.time_step;
  const long long chunk = StepsOf(kChunkTime, dt);
  const long long chunks = StepsOf(spec.bed.max_settle_time, dt) / chunk + 1;
  std::ostringstream o;
  o << "# Bed preparation, generated by granary-liggghts from run.json (docs/liggghts.md)\n"
    << "atom_style sphere\n"
    << kHeader << "boundary f p f\nnewton off\ncommunicate single vel yes\nunits lj\n"
    << "region box block " << Num(s.x_lo) << " " << Num(s.x_hi) << " " << Num(s.y_lo) << " " << Num(s.y_hi) << " "
    << Num(-s.half_z) << " " << Num(s.half_z) << " units box\n"
    << "create_box " << s.wall_type << " box\n"
    << "neighbor 0.2 bin\nneigh_modify delay 0\n"
    << Material(spec, s) << MeshWalls(spec, s, s.fill_meshes, "walls_fill") << PrimitiveWalls(spec, s, true);
  for (const std::string& l : s.template_lines) o << l;
  o << "region insert_region block " << Num(-s.insert_x_half) << " " << Num(s.insert_x_half) << " "
    << Num(s.insert_y_lo) << " " << Num(s.insert_y_hi) << " -1e-6 1e-6 units box\n"
    << "fix insert all insert/pack seed " << PrimeSeed(spec.seed, 2)
    << " distributiontemplate bodies insert_every once overlapcheck yes all_in no orientation constant 1 0 0 0"
    << " vel constant 0 -1 0 region insert_region particles_in_region " << spec.bodies.count << "\n"
    << ClumpIntegration(s) << "variable ke_atom atom 0.5*mass*(vx*vx+vy*vy)\n"
    << "compute ke_body all reduce ave v_ke_atom\n"  // a body's mass sits on each of its spheres
    << "compute y_max all reduce max y\n"
    << "variable ke_body equal c_ke_body\nvariable y_max equal c_y_max\nvariable t_now equal time\n"
    << "variable atoms_now equal atoms\n"
    << "thermo_style custom step time atoms c_ke_body c_y_max cpu\nthermo " << chunk << "\n"
    << "thermo_modify lost ignore norm no\n"
    << "timestep " << Num(dt) << "\n"
    << "run 1\nunfix insert\n"
    << "print \"GRANARY_INSERTED ${atoms_now}\"\n"
    << SingleIntegration(s, true);
  if (!s.single_types.empty()) o << "set group " << (s.multisphere ? "singles" : "all") << " z 0.0\n";
  o << "variable settle_chunk loop " << chunks << "\n"
    << "label settle\n"
    << "run " << chunk << " post no\n"
    << "print \"GRANARY_BED ${t_now} ${ke_body}\"\n"
    << "if \"${ke_body} < " << Num(spec.bed.settle_ke_per_body * s.mean_body_mass * spec.gravity)
    << "\" then \"jump SELF settled\"\n"
    << "next settle_chunk\njump SELF settle\nlabel settled\n"
    << "print \"GRANARY_BED_DONE ${t_now} ${ke_body}\"\n"  // before anything re-initialises the computes
    // The box top right above the bed: in reinject mode (y-periodic) a body leaving at the
    // bottom re-enters just above the bed surface. change_box is refused after read_restart.
    << "variable box_top equal ${y_max}+" << Num(2 * s.bound_radius + spec.discharge.periodic_headroom) << "\n"
    << "change_box all y final " << Num(s.y_lo) << " ${box_top} units box\n"
    << "write_restart bed.restart\n"
    << "write_dump all custom bed.dump id " << BodyColumn(s) << " type x y radius z\n";
  return o.str();
}

// The commands (each quoted, for an `if ... then`) that keep the configuration at a stall and
// its contact forces in clog.<step>.atoms, clog.<step>.pairs and, with mesh walls,
// clog.<step>.walls (the backend converts them into the run directory's clog files).
std::string ClogDumps(const SiloSetup& s, bool wall_contacts) {
  std::string c = " \"write_dump all custom " + std::string(kClogFilePrefix) + "${step_now}.atoms id " + BodyColumn(s) +
                  " type x y radius vx vy omegaz modify format '%d %d %d %.10g %.10g %.10g %.10g %.10g %.10g'\"" +
                  " \"write_dump all local " + kClogFilePrefix +
                  "${step_now}.pairs c_pair_contacts[1] c_pair_contacts[2] "
                  "c_pair_contacts[4] c_pair_contacts[5] c_pair_contacts[7] c_pair_contacts[8] c_pair_contacts[10] "
                  "c_pair_contacts[11] modify format '%.10g %.10g %.10g %.10g %.0f %.0f %.10g %.10g'\"";
  if (wall_contacts)
    c += " \"write_dump all local " + std::string(kClogFilePrefix) +
         "${step_now}.walls c_wall_contacts[1] c_wall_contacts[2] "
         "c_wall_contacts[4] c_wall_contacts[5] c_wall_contacts[9] c_wall_contacts[10] c_wall_contacts[11] "
         "modify format '%.10g %.10g %.10g %.10g %.0f %.10g %.10g'\"";
  return c;
}

std::string DischargeScript(const RunSpec& spec, const SiloSetup& s, const DischargeStart& start) {
  const double dt = spec.time_step;
  const long long chunk = StepsOf(std::min(kChunkTime, spec.discharge.clog_window / 4), dt);
  const long long total = StepsOf(spec.discharge.max_time, dt);
  const long long clog_steps = StepsOf(spec.discharge.clog_window, dt);
  const bool remove = spec.discharge.mode == DischargeMode::kRemove;
  std::ostringstream o;
  o << "# Discharge, generated by granary-liggghts from run.json (docs/liggghts.md)\n"
    << kHeader << "read_restart " << (start.continue_run ? start.restart_file : std::string("bed.restart")) << "\n"
    << "newton off\nneighbor 0.2 bin\nneigh_modify delay 0\ncommunicate single vel yes\n";
  o << Material(spec, s) << MeshWalls(spec, s, s.discharge_meshes, "walls_discharge") << PrimitiveWalls(spec, s, false);
  // Contact forces: LIGGGHTS refuses these computes after the first run unless fix data from a
  // restart are still waiting, as they are right after read_restart (fresh and continued alike).
  // Pair contacts always (every clog keeps its contact forces); wall contacts only where every
  // wall is a mesh (output.contact_forces), the only walls LIGGGHTS reports.
  const bool contacts = spec.output.contact_forces && spec.output.frame_interval > 0;
  const bool wall_contacts = spec.output.contact_forces;
  o << "compute pair_contacts all pair/gran/local pos id force\n";
  if (wall_contacts) o << "compute wall_contacts all wall/gran/local pos id force\n";
  std::string exited;
  for (std::size_t k = 0; k < s.counters.size(); ++k) {
    const Counter& c = s.counters[k];
    const std::string id = "counter_" + std::to_string(k);
    o << "fix " << id << " all mesh/surface file " << c.mesh.name << " type " << s.wall_type << "\n"
      << "fix exit_" << k << " all massflow/mesh mesh " << id << " vec_side " << Num(c.side_x) << " " << Num(c.side_y)
      << " 0 " << (remove ? "count once delete_atoms yes" : "count multiple") << " "
      << (start.continue_run ? "append " : "file ") << c.file << " writeTime\n";
    exited += (k ? "+f_exit_" : "f_exit_") + std::to_string(k) + "[2]";
  }
  o << ClumpIntegration(s) << SingleIntegration(s, false);
  const std::string script = o.str();
  std::ostringstream p;
  // The box height to 15 digits (dumps print it to 6): the backend puts clumps that straddle
  // the periodic boundary back together with it.
  p << "variable box_height equal yhi-ylo\nprint \"GRANARY_BOX ${box_height}\"\n"
    << "variable exited equal " << exited << "\n"
    << "variable atoms_now equal atoms\nvariable step_now equal step\n"
    << "variable next_stop equal step+" << chunk << "\n"
    << "thermo_style custom step time atoms v_exited cpu\nthermo " << chunk << "\n"
    << "thermo_modify lost ignore norm no\n"
    << "timestep " << Num(dt) << "\n";
  if (spec.output.frame_interval > 0) {
    p << "dump frames all custom " << StepsOf(spec.output.frame_interval, dt) << " frames.liggghts id " << BodyColumn(s)
      << " type x y radius vx vy omegaz\n"
      << "dump_modify frames format \"%d %d %d %.10g %.10g %.10g %.10g %.10g %.10g\"\n";
    if (start.continue_run) p << "dump_modify frames append yes\n";
  }
  if (contacts) {
    // Pairs: x1 y1 (z1) x2 y2 (z2) id1 id2 (periodic) fx fy (fz), force on the first sphere.
    // Walls: contact point (3), sphere centre (3), mesh id, facet, sphere id, force on the sphere.
    const long long every = StepsOf(spec.output.frame_interval, dt);
    p << "dump pair_contacts all local " << every << " contacts_pairs.liggghts c_pair_contacts[1] c_pair_contacts[2] "
      << "c_pair_contacts[4] c_pair_contacts[5] c_pair_contacts[7] c_pair_contacts[8] c_pair_contacts[10] c_pair_contacts[11]\n"
      << "dump_modify pair_contacts format \"%.10g %.10g %.10g %.10g %.0f %.0f %.10g %.10g\"\n"
      << "dump wall_contacts all local " << every << " contacts_walls.liggghts c_wall_contacts[1] c_wall_contacts[2] "
      << "c_wall_contacts[4] c_wall_contacts[5] c_wall_contacts[9] c_wall_contacts[10] c_wall_contacts[11]\n"
      << "dump_modify wall_contacts format \"%.10g %.10g %.10g %.10g %.0f %.10g %.10g\"\n";
    if (start.continue_run) p << "dump_modify pair_contacts append yes\ndump_modify wall_contacts append yes\n";
  }
  if (spec.output.checkpoint_interval > 0)
    p << "restart " << StepsOf(spec.output.checkpoint_interval, dt) << " checkpoint.*.restart\n";
  // Time counts from the opening of the outlets (reset_timestep must come right before a run).
  if (!start.continue_run) p << "reset_timestep 0\n";
  p << "run 0 post no\n"
    << "variable exited_last equal ${exited}\n"
    << "variable last_exit_step equal " << start.last_exit_step << "\n"
    << "variable clog_counted equal " << (start.in_clog ? 1 : 0) << "\n"
    << "variable chunk loop " << total / chunk + 2 << "\n"
    << "label discharge\n"
    << "if \"${step_now} >= " << total << "\" then \"print 'GRANARY_END time_limit'\" \"jump SELF finished\"\n"
    << "if \"${next_stop} > " << total << "\" then \"variable next_stop equal " << total << "\"\n"
    << "run ${next_stop} upto post no\n"
    << "print \"GRANARY_PROGRESS ${step_now} ${exited} ${atoms_now}\"\n"
    // A stop request (the backend got SIGTERM): checkpoint here and end (docs/liggghts.md).
    << "include " << kControlFile << "\n"
    << "if \"${stop_requested} == 1\" then \"write_restart checkpoint.*.restart\" "
       "\"print 'GRANARY_STOPPED ${step_now}'\" \"jump SELF stopped\"\n"
    << "if \"${exited} > ${exited_last}\" then \"variable exited_last equal ${exited}\" "
       "\"variable last_exit_step equal ${step_now}\" \"variable clog_counted equal 0\"\n";
  if (remove) p << "if \"${atoms_now} == 0\" then \"print 'GRANARY_END discharged'\" \"jump SELF finished\"\n";
  p << "variable since_exit equal step-v_last_exit_step\n";  // `if` compares numbers, it does no arithmetic
  // A stall: no exit for clog_window, counted once until the next exit. In remove mode the
  // backend decides from the final dump whether an arch seals an outlet (a clog) or the silo has
  // discharged what can flow (silo::SealedOutlets, as the native engine); the restart written
  // here lets it go on through a clog when the spec asks for that.
  // Every stall also keeps its configuration and contact forces (ClogDumps): a clog's, or in
  // remove mode one the backend may judge a discharge and drop.
  const std::string stalled = "\"${since_exit} >= " + std::to_string(clog_steps) + " && ${clog_counted} == 0\"";
  const std::string keep = ClogDumps(s, wall_contacts);
  if (remove)
    p << "if " << stalled << " then \"write_restart checkpoint.*.restart\"" << keep
      << " \"print 'GRANARY_END stalled'\" "
      << "\"jump SELF finished\"\n";
  else if (spec.discharge.StopOnClog())
    p << "if " << stalled << " then" << keep << " \"print 'GRANARY_END clogged'\" \"jump SELF finished\"\n";
  else
    p << "if " << stalled << " then" << keep
      << " \"print 'GRANARY_CLOG ${step_now}'\" \"variable clog_counted equal 1\"\n";
  p << "next chunk\njump SELF discharge\nlabel finished\n"
    << "write_dump all custom final.dump id " << BodyColumn(s) << " type x y radius z\n"
    << "print \"GRANARY_FINAL ${step_now}\"\n"
    << "label stopped\n";
  return script + p.str();
}

}  // namespace granary::liggghts
