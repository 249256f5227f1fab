// Arches of clogged configurations (thesis ch. 3 fig. 3.4 and table 3.1, ch. 4 figs. 4.28-4.30,
// ch. 6 figs. 6.3-6.9; docs/analyses.md "Arches"). Pure: a clog (rundir/clogs.h) and the silo's
// geometry in, the arch over every sealed outlet and the clogged system's contact statistics out.
//
// The arch of an outlet is read off the edge of the free space under it (silo::CavityUnder,
// the stall judgement's flood fill): the objects along that edge from the s < 0 side of the
// outlet round to the s > 0 side, bodies merged from their discs, with every dead-end excursion
// (a body, or a branch of bodies, touching the rest of the edge at one body only: A B A) cut
// out and kept as a defect. What is left runs from the walls on one side over the bodies to the
// walls on the other; the arch is the stretch between the last support on the s < 0 side and the
// first on the s > 0 side. A stretch passing an obstacle is an obstacle arch (fig. 3.4's first
// type: base - obstacle - base), else a particle arch. Consecutive arch bodies are checked
// against the contact network: a pair that does not touch (the probe could not pass between
// them, but they are not in contact) is a gap.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "analysis/stats.h"
#include "silo/geometry.h"
#include "rundir/clogs.h"

namespace granary::analysis {

struct ArchBody {
  std::int64_t id = -1;
  int type = 1;  // species index + 1
  int discs = 1;
  double x = 0, y = 0;     // centre of mass
  double s = 0, h = 0;     // in the outlet's frame (s along it from its centre, h into the silo)
  double theta = kNaN;     // angular position around the outlet's centre, [0, pi] (orientation.h)
  double axis = kNaN;      // long axis with the horizontal, [0, pi); NaN for a disc
  double pressure = kNaN;  // eq. 6.1 over the body (body_pressures)
};

struct Arch {
  int outlet = 0;
  bool obstacle = false;                // passes an obstacle (fig. 3.4, first type)
  std::vector<int> obstacles;           // which (spec order)
  std::vector<ArchBody> bodies;         // in chain order from the s < 0 support to the s > 0 support
  std::vector<std::int64_t> dead_ends;  // bodies hanging off the arch at one body only (defects)
  int gaps = 0;                         // consecutive arch bodies not in contact
  bool supported = true;                // both end bodies touch a wall or an obstacle (a contact row)
  // Metrics (docs/analyses.md): N_t, w, h, p, c, c/p, species and the largest angle at a body.
  int n = 0;
  double width = kNaN;      // |s_last - s_first| of the end bodies' centres
  double height = kNaN;     // highest body's h minus the end bodies' mean h
  double perimeter = kNaN;  // sum of centre-to-centre distances along the chain
  double arc = kNaN;        // the circular arc through the end bodies and the highest one
  double c_over_p = kNaN;
  double elongated_fraction = kNaN;  // bodies of two discs or more (dumbbells, snowmen, rods)
  std::vector<int> per_type;         // bodies by species index (type - 1)
  double mean_pressure = kNaN;
  double max_angle = kNaN;  // largest angle phi at an inner body, radians (> pi: a concavity)
  int concave = 0;          // inner bodies with phi > pi (Garcimartin et al.'s defects)
};

// Contacts between the discs of different bodies in the whole clogged system (fig. 6.8), by the
// size class of the two discs: in a body of two discs the smaller is small and the larger large
// (equal discs: the lower disc id counts as small, the thesis' random choice made repeatable);
// a contact that involves a disc alone or a rod's disc counts as `other`.
struct ContactTypes {
  int small_small = 0, large_small = 0, large_large = 0, other = 0;
  int Total() const { return small_small + large_small + large_large + other; }
};

struct ClogArches {
  std::int64_t timestep = 0;
  double time = 0;
  std::vector<Arch> arches;  // one per sealed outlet, in outlet order
  std::vector<int> sealed_outlets;
  ContactTypes contact_types;
  int bodies = 0;  // in the silo at the clog
};

// The silo of a resolved run spec (run.json) with side walls up to `top`; throws
// std::invalid_argument naming what is wrong with the spec.
silo::SiloGeometry SiloOf(const nlohmann::json& spec, double top);

// Per-body pressure from the per-disc stress of eq. 6.1 over pair contacts only (as the thesis),
// with the sign of LAMMPS' compute stress/atom so that compression is positive:
// P = sum over the body's pair contacts of (r_i - r_j) . F_i / (4 A), r_i and r_j the touching
// discs' centres, F_i the force on this body's disc, A the body's area (sum pi r^2 of its discs).
// In the order of rundir::BodiesOf(frame.discs) (by body id).
std::vector<double> BodyPressures(const rundir::Frame& frame, const rundir::ContactFrame& contacts);

ContactTypes CountContactTypes(const rundir::Frame& frame, const rundir::ContactFrame& contacts);

// Everything above for one clog, in `silo`; or in the silo of the run's spec (silo_of, with
// side walls above the clog's highest disc).
ClogArches AnalyseClog(const rundir::ClogState& clog, const silo::SiloGeometry& silo);
ClogArches AnalyseClog(const rundir::ClogState& clog, const nlohmann::json& spec);

// The clogs of a run as JSON (what an analysis caches per run) and back: every number, the
// arch bodies with their id, type, discs, s, h, theta, axis and pressure (positions x, y too).
nlohmann::json to_json(const ClogArches& clog);
ClogArches ClogArchesFromJson(const nlohmann::json& j);

// Arches pooled over clogs (a run's, or every replica's of a sweep point): the thesis averages
// over clogged states (ch. 4: at least 100, ch. 6: 100), so means are over arches, n = arches.
struct ArchSummaryOptions {
  int theta_bins = 9;           // angular positions [0, pi] (figs. 6.6, 6.7)
  int axis_bins = 12;           // axis angles [0, pi) for the mode (fig. 6.6)
  bool obstacle_arches = true;  // include obstacle arches in the means (both types are counted apart)
};
struct ThetaBin {
  double theta = kNaN;      // bin centre
  MeanSe pressure;          // of the arch bodies whose angular position falls in it
  double axis_mode = kNaN;  // the most frequent axis angle there (elongated bodies), bin centre
  int elongated = 0;        // how many axes the mode is of
};
struct ArchSummary {
  int clogs = 0;   // clogged configurations
  int sealed = 0;  // outlets they seal
  int arches = 0, particle_arches = 0, obstacle_arches = 0;
  int with_gaps = 0, with_defects = 0, unsupported = 0;
  MeanSe n, width, height, perimeter, c_over_p, elongated_fraction, mean_pressure, max_angle;
  double width_sd = kNaN, height_sd = kNaN;  // table 3.1's sigma_w, sigma_h
  MeanSe concave, dead_ends;                 // per arch
  std::vector<double> n_values;              // N_t of every arch (its distribution)
  std::vector<ThetaBin> theta;               // figs. 6.6, 6.7
  struct ByN {
    int n = 0;
    MeanSe pressure;  // mean arch pressure of the arches of N_t = n (fig. 6.9)
  };
  std::vector<ByN> pressure_by_n;
  // Contact types over the clogged systems (fig. 6.8): each clog's fractions, mean +- se over clogs.
  MeanSe small_small, large_small, large_large, other;
};
ArchSummary SummarizeArches(const std::vector<const ClogArches*>& clogs, const ArchSummaryOptions& options = {});

}  // namespace granary::analysis
