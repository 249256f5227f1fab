// Coarse-grained flow fields on a grid over the silo (thesis ch. 4.3.1.1, eqs. 4.1-4.8; ch.
// 5.3.1.1, 6.3.1), after Goldhirsch and MercuryCG: each frame's discs and contacts are smeared
// with a Gaussian kernel onto grid nodes, the per-frame fields are formed at every node, and
// the fields are averaged over frames in streaming form (sums per node: memory independent
// of the number of frames). Pure: frames in, sums and maps out; docs/analyses.md
// "Coarse-grained fields" gives every definition and the choices made where the thesis is
// silent.
//
// The three axes of MercuryCG's CG<Coordinates, Function, Fields> are fixed here to what the
// thesis uses -- a 2-D grid, the Gaussian cut at `cutoff` widths, the standard fields -- and
// the options below are its run-time parameters.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "analysis/region.h"
#include "rundir/contacts.h"
#include "rundir/frames.h"

namespace granary::analysis {

// Grid nodes (x0 + i h, y0 + j h), i < nx, j < ny; node index j * nx + i (rows in y).
struct CgGrid {
  double x0 = 0.0, y0 = 0.0;
  double spacing = 1.0;
  int nx = 0, ny = 0;
  double X(int i) const { return x0 + i * spacing; }
  double Y(int j) const { return y0 + j * spacing; }
  std::size_t size() const { return static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny); }
  bool operator==(const CgGrid&) const = default;
};
// The nodes of a window: the first at its low corner, every `spacing`, as many as fit in it.
CgGrid GridOver(const Rect& window, double spacing);

struct CgOptions {
  double width = 1.414;   // w of W(r) = exp(-r^2/w^2) / (pi w^2), eq. 4.1 (d)
  double cutoff = 3.0;    // W = 0 beyond cutoff * w (thesis: 3w)
  double spacing = 1.0;   // grid spacing (d)
  Rect window;            // the mapped part of the silo; empty (x1 <= x0): cg_default_window
  double min_phi = 0.05;  // v, Omega, Omega_fl^2, T_g of a frame are defined at a node with phi(t) >= min_phi
  int threads = 0;        // 0: OpenMP's default; any count gives the same bits
};

// The default window of a silo `width` wide whose bed reaches `bed_top`: 1.5 d inside the
// side walls, from 1.5 d above the base up to min(148.5 d, bed_top) (the thesis' maps span
// 1.5 <= y <= 148.5, ch. 5-6).
Rect CgDefaultWindow(double silo_width, double bed_top);

// The fields a map can show. Contact stress follows eq. 4.7 (see docs/analyses.md for its
// sign: tension positive, so P = -tr(sigma)/2 > 0 in compression), kinetic stress is
// -sum m dv (x) dv W, total = contact + kinetic.
enum class CgField {
  kPhi,  // area fraction, eq. 4.2
  kVx,
  kVy,        // velocity, eq. 4.5
  kSpeed,     // |v| of the time-averaged velocity
  kOmega,     // rotational velocity, eq. 4.3
  kOmegaFl2,  // its fluctuation Omega_fl^2, eq. 4.4
  kTg,        // granular temperature: eq. 4.6 about the velocity field at each disc (no mean-shear part)
  kTgEq46,    // eq. 4.6 as written: about the velocity at the node (includes the mean shear within w)
  kSigmaXX,
  kSigmaXY,
  kSigmaYY,   // contact stress tensor (symmetric part), eq. 4.7
  kPressure,  // contact pressure -tr(sigma)/2, eq. 4.8
  kShear,     // contact shear stress |tau| = sqrt(((sxx - syy)/2)^2 + sxy^2)
  kFriction,  // contact |tau| / P
  kKineticPressure,
  kKineticShear,
  kTotalPressure,
  kTotalShear,
  kTotalFriction,
};

struct CgFieldInfo {
  CgField field;
  const char* name;     // CSV and option name, e.g. "phi", "pressure"
  const char* title;    // e.g. "area fraction phi"
  const char* unit;     // "" (dimensionless), "sqrt(g d)", ...
  bool needs_contacts;  // contact or total stress
};
std::span<const CgFieldInfo> CgFieldTable();
const CgFieldInfo& CgFieldInfoFor(CgField field);
// The field named `name`; false if there is none.
bool CgFieldByName(std::string_view name, CgField& field);

// Time sums per window node; sums of runs on the same grid add (replicas of a sweep point).
struct CgSums {
  CgGrid grid;
  int frames = 0;                                             // frames added
  int contact_frames = 0;                                     // of them with contact forces
  std::vector<double> phi;                                    // over all frames
  std::vector<std::int32_t> n_defined;                        // frames with phi(t) >= min_phi
  std::vector<double> vx, vy, omega, omega_fl2, tg, tg_eq46;  // over the defined frames
  std::vector<double> sxx, sxy, syx, syy;                     // contact stress, over the contact frames
  std::vector<double> kxx, kxy, kyy;                          // kinetic stress, over all frames
  void Resize(const CgGrid& g);
  // Adds `other` (same grid; throws std::invalid_argument otherwise).
  void Add(const CgSums& other);
};

// Time-averaged fields: the value of any field at a node and the frames behind it.
class CgMaps {
 public:
  CgMaps() = default;
  explicit CgMaps(CgSums sums) : sums_(std::move(sums)) {}
  const CgGrid& Grid() const { return sums_.grid; }
  const CgSums& Sums() const { return sums_; }
  int Frames() const { return sums_.frames; }
  int ContactFrames() const { return sums_.contact_frames; }
  bool Has(CgField f) const { return !CgFieldInfoFor(f).needs_contacts || sums_.contact_frames > 0; }
  // NaN where the field is not defined (no frame with phi >= min_phi; stress without contacts).
  double Value(CgField f, std::size_t node) const;
  int NFrames(CgField f, std::size_t node) const;
  // The whole map, node order.
  std::vector<double> Values(CgField f) const;

 private:
  CgSums sums_;
};

// The map as CSV: a header "x,y,<name>,n_frames" and one row per node (rows in y, then x);
// an undefined value is "nan".
std::string CgMapCsv(const CgMaps& maps, CgField field);

// Mean of a field over the window nodes inside `region` (NaN where none is defined). The
// friction fields are the ratio of the region means of |tau| and P (thesis fig. 5.3: shear
// stress and pressure from the time-averaged fields), not the mean of the ratio.
struct CgRegionMean {
  double value = kNaN;
  int nodes = 0;  // nodes inside the region with a defined value
};
CgRegionMean MeanOverRegion(const CgMaps& maps, CgField field, const Rect& region);

// A time series of a region mean of a per-frame field (thesis fig. 7.2: the speed above the
// small outlet against time).
struct CgSeriesRequest {
  std::string name;
  Rect region;
  CgField field = CgField::kSpeed;
};
struct CgSeries {
  CgSeriesRequest request;
  std::vector<double> time, value;  // value NaN in frames where no node inside is defined
};

// One frame at a time: add_frame smears the discs (and the contacts, if given) of one frame
// onto the grid, forms the frame's fields and adds them to the sums.
class CgAccumulator {
 public:
  // `options.window` must not be empty; throws std::invalid_argument on bad options.
  explicit CgAccumulator(const CgOptions& options, std::vector<CgSeriesRequest> series = {});
  ~CgAccumulator();
  CgAccumulator(CgAccumulator&&) noexcept;
  CgAccumulator& operator=(CgAccumulator&&) noexcept;

  // `contacts` = nullptr: a frame without contact forces (stress sums unchanged). Contact
  // branch vectors run from the contact point to each body's centre of mass, which the
  // discs give; a wall or obstacle contact contributes its half from the contact point.
  void AddFrame(double time, std::span<const rundir::Disc> discs, const rundir::ContactFrame* contacts);

  const CgSums& Sums() const;
  CgMaps Maps() const { return CgMaps(Sums()); }
  const std::vector<CgSeries>& Series() const;
  const CgOptions& Options() const;
  const CgGrid& Grid() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// The line integral of the kernel along a segment, int_0^1 W(r - a - s (b - a)) ds, at a node
// within the cutoff of the segment's line and of its ends (zero elsewhere, as MercuryCG cuts
// it), by Gauss-Legendre quadrature with enough points for an error below 1e-6 of W's peak
// (cutoff <= 3.2 w) or 3e-8 (larger cutoffs) -- what add_frame uses; exposed for tests.
double CgLineIntegral(double rx, double ry, double ax, double ay, double bx, double by, const CgOptions& options);

}  // namespace granary::analysis
