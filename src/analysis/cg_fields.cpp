// See cg_fields.h. The hot loops: every disc adds itself to the grid nodes within the cutoff
// (pass 1: phi, momentum, Omega, Omega^2, |v|^2), then every disc near the window adds its
// velocity fluctuation about the frame's velocity field at its own position (pass 2: T_g and
// the kinetic stress), and every contact adds its force (x) branch vector times the kernel's
// line integral along each half of the branch (with pass 1). The Gaussian is separable, so a
// disc needs two exp() per axis: the factors along a row follow by a recurrence.
//
// Threads share the grid by bands of rows at least as tall as a disc's reach: a band takes the
// discs and contacts whose first row is in it, in input order, and adds them to all their
// rows, which lie in it and the band above. The even bands go first, then (after a barrier)
// the odd ones, then on one thread the rare contacts that reach further than a band. So every
// node sums its terms in the same order whatever the number of threads, and each disc and
// contact computes its kernel factors once: the same bits at any thread count.
#include "analysis/cg_fields.h"

#include <omp.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <cstring>
#include <cmath>
#include <limits>
#include <numbers>
#include <span>
#include <stdexcept>
#include <string>

namespace granary::analysis {
namespace {

constexpr int kMinBandRows = 8;
constexpr std::size_t kMaxQuadrature = 16;
constexpr double kMaxBranch =
    10.0;  // a body centre further than this from its contact point is not that contact's (a periodic image): the disc centre is used

// Gauss-Legendre nodes and weights on [0, 1] for n points (weights sum to 1).
struct Quadrature {
  int n = 0;
  std::array<double, kMaxQuadrature> s{}, c{};
};

const std::array<Quadrature, kMaxQuadrature + 1> kGaussLegendre = [] {
  std::array<Quadrature, kMaxQuadrature + 1> t{};
  for (int n = 1; n <= static_cast<int>(kMaxQuadrature); ++n) {
    Quadrature& q = t[static_cast<std::size_t>(n)];
    q.n = n;
    for (int i = 1; i <= n; ++i) {
      double x = std::cos(std::numbers::pi * (i - 0.25) / (n + 0.5));
      double dp = 1.0;
      for (int it = 0; it < 100; ++it) {
        double p0 = 1.0, p1 = x;
        for (int k = 2; k <= n; ++k) {
          const double p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
          p0 = p1;
          p1 = p2;
        }
        dp = n * (x * p1 - p0) / (x * x - 1.0);
        const double step = p1 / dp;
        x -= step;
        if (std::abs(step) < 1e-16) break;
      }
      q.s[static_cast<std::size_t>(i - 1)] = 0.5 * (x + 1.0);
      q.c[static_cast<std::size_t>(i - 1)] = 1.0 / ((1.0 - x * x) * dp * dp);  // 2/((1-x^2)p'^2) on [-1,1], halved
    }
  }
  return t;
}();

const Quadrature& GaussLegendre(int points) {
  return kGaussLegendre[static_cast<std::size_t>(std::clamp(points, 1, static_cast<int>(kMaxQuadrature)))];
}

// Points for a segment of length L: the rule's error on exp(-(t - sL)^2/w^2) stays below
// `tolerance` of the peak up to these L/w (measured against the erf closed form), for branches
// up to 6 w -- more than any body's centre-to-contact distance. The tolerance is kept well
// below the kernel's own cut, exp(-cutoff^2) of the peak (1.2e-4 at 3 w): 1e-6 for cutoffs up
// to 3.2 w, 3e-8 beyond.
int QuadraturePoints(double length_over_w, double cutoff) {
  static constexpr double kLimit6[] = {0.508, 1.022, 1.603, 2.214, 2.839,
                                       3.47,  4.1,   4.7,   5.3,   6.0};  // 1e-6, from 3 points
  static constexpr double kLimit8[] = {0.28, 0.65, 1.11, 1.62, 2.15, 2.69, 3.25, 3.80, 4.36, 4.92, 5.47, 6.0};  // 3e-8
  int n = 3;
  for (double limit : cutoff <= 3.2 ? std::span<const double>(kLimit6) : std::span<const double>(kLimit8)) {
    if (length_over_w <= limit) return n;
    ++n;
  }
  return static_cast<int>(kMaxQuadrature);
}

struct Kernel {
  double inv_w2 = 0, rc = 0, rc2 = 0, norm = 0;
  explicit Kernel(const CgOptions& o) {
    inv_w2 = 1.0 / (o.width * o.width);
    rc = o.cutoff * o.width;
    rc2 = rc * rc;
    // Normalised over the cut disc (as MercuryCG's Gauss), so a uniform packing has its phi:
    // the thesis' eq. 4.1 without the cut differs by 1 / (1 - exp(-cutoff^2)) (1.000123 at 3w).
    norm = 1.0 / (std::numbers::pi * o.width * o.width * (1.0 - std::exp(-o.cutoff * o.cutoff)));
  }
};

// exp(-(x0 + k h - p)^2 / w^2) for k = 0..n-1 by the recurrence e_{k+1} = e_k r_k,
// r_{k+1} = r_k exp(-2 h^2 / w^2); d2[k] = (x0 + k h - p)^2.
inline void AxisFactors(double first_node, double h, double p, int n, double inv_w2, double q2, double* e, double* d2) {
  const double d0 = first_node - p;
  double ek = std::exp(-d0 * d0 * inv_w2);
  double rk = std::exp(-(2.0 * d0 * h + h * h) * inv_w2);
  for (int k = 0; k < n; ++k) {
    const double d = d0 + k * h;
    d2[k] = d * d;
    e[k] = ek;
    ek *= rk;
    rk *= q2;
  }
}

// The same factors without the squared distances (the contacts' quadrature points).
inline void AxisExp(double first_node, double h, double p, int n, double inv_w2, double q2, double* e) {
  const double d0 = first_node - p;
  double ek = std::exp(-d0 * d0 * inv_w2);
  double rk = std::exp(-(2.0 * d0 * h + h * h) * inv_w2);
  for (int k = 0; k < n; ++k) {
    e[k] = ek;
    ek *= rk;
    rk *= q2;
  }
}

// Four doubles in a vector register (GCC's vector extension: AVX in the avx2 clones of the
// kernels, two SSE2 registers otherwise). Each lane is one node: the same additions in the same
// order as the scalar loop, so the same bits in either clone.
// (-Wpsabi: passing 32-byte vectors by value differs with and without AVX; these never cross a
// compiled call, they are always inlined.)
#pragma GCC diagnostic ignored "-Wpsabi"
typedef double Lanes __attribute__((vector_size(32)));
constexpr int kLanes = 4;
[[gnu::always_inline]] inline Lanes LoadLanes(const double* p) {
  Lanes v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
[[gnu::always_inline]] inline void StoreLanes(double* p, Lanes v) { std::memcpy(p, &v, sizeof v); }

// A contact's branch: one or two segments from a common start a -- the contact point to each
// body's centre, or from one round body's centre through the contact point to the other's.
struct Branch {
  double ax, ay;
  int halves;           // 1 or 2
  double bx[2], by[2];  // the segments' ends
  double t[2][4];       // -F (x) (b - a), F the force on the body at b: xx, xy, yx, yy
};

}  // namespace

CgGrid GridOver(const Rect& window, double spacing) {
  CgGrid g;
  g.x0 = window.x0;
  g.y0 = window.y0;
  g.spacing = spacing;
  if (!(spacing > 0.0) || !(window.x1 >= window.x0) || !(window.y1 >= window.y0)) return g;
  g.nx = static_cast<int>(std::floor((window.x1 - window.x0) / spacing + 1e-9)) + 1;
  g.ny = static_cast<int>(std::floor((window.y1 - window.y0) / spacing + 1e-9)) + 1;
  return g;
}

Rect CgDefaultWindow(double silo_width, double bed_top) {
  constexpr double kInset = 1.5, kTop = 148.5;
  Rect r;
  r.x0 = -0.5 * silo_width + kInset;
  r.x1 = 0.5 * silo_width - kInset;
  r.y0 = kInset;
  r.y1 = std::max(r.y0, std::min(kTop, bed_top));
  return r;
}

std::span<const CgFieldInfo> CgFieldTable() {
  static const CgFieldInfo kTable[] = {
      {CgField::kPhi, "phi", "area fraction phi", "", false},
      {CgField::kVx, "vx", "velocity v_x", "sqrt(g d)", false},
      {CgField::kVy, "vy", "velocity v_y", "sqrt(g d)", false},
      {CgField::kSpeed, "speed", "speed |v|", "sqrt(g d)", false},
      {CgField::kOmega, "omega", "rotational velocity Omega", "sqrt(g/d)", false},
      {CgField::kOmegaFl2, "omega_fl2", "rotational fluctuation Omega_fl^2", "g/d", false},
      {CgField::kTg, "tg", "granular temperature T_g", "g d", false},
      {CgField::kTgEq46, "tg_eq46", "T_g as eq. 4.6 (with the mean shear)", "g d", false},
      {CgField::kSigmaXX, "sigma_xx", "contact stress sigma_xx", "rho g d", true},
      {CgField::kSigmaXY, "sigma_xy", "contact stress sigma_xy", "rho g d", true},
      {CgField::kSigmaYY, "sigma_yy", "contact stress sigma_yy", "rho g d", true},
      {CgField::kPressure, "pressure", "pressure P (contact)", "rho g d", true},
      {CgField::kShear, "shear", "shear stress |tau| (contact)", "rho g d", true},
      {CgField::kFriction, "friction", "dynamic friction |tau|/P (contact)", "", true},
      {CgField::kKineticPressure, "kinetic_pressure", "kinetic pressure", "rho g d", false},
      {CgField::kKineticShear, "kinetic_shear", "kinetic shear stress", "rho g d", false},
      {CgField::kTotalPressure, "total_pressure", "pressure P (contact + kinetic)", "rho g d", true},
      {CgField::kTotalShear, "total_shear", "shear stress |tau| (contact + kinetic)", "rho g d", true},
      {CgField::kTotalFriction, "total_friction", "dynamic friction |tau|/P (contact + kinetic)", "", true},
  };
  return kTable;
}

const CgFieldInfo& CgFieldInfoFor(CgField field) {
  for (const CgFieldInfo& f : CgFieldTable())
    if (f.field == field) return f;
  throw std::logic_error("cg_field_info: unknown field");
}

bool CgFieldByName(std::string_view name, CgField& field) {
  for (const CgFieldInfo& f : CgFieldTable())
    if (name == f.name) {
      field = f.field;
      return true;
    }
  return false;
}

// ---- sums and maps -----------------------------------------------------------------------

void CgSums::Resize(const CgGrid& g) {
  grid = g;
  const std::size_t n = g.size();
  for (auto* v : {&phi, &vx, &vy, &omega, &omega_fl2, &tg, &tg_eq46, &sxx, &sxy, &syx, &syy, &kxx, &kxy, &kyy})
    v->assign(n, 0.0);
  n_defined.assign(n, 0);
}

void CgSums::Add(const CgSums& o) {
  if (!(o.grid == grid)) throw std::invalid_argument("CgSums::add: the grids differ");
  frames += o.frames;
  contact_frames += o.contact_frames;
  auto add = [](std::vector<double>& a, const std::vector<double>& b) {
    for (std::size_t i = 0; i < a.size(); ++i) a[i] += b[i];
  };
  add(phi, o.phi);
  add(vx, o.vx);
  add(vy, o.vy);
  add(omega, o.omega);
  add(omega_fl2, o.omega_fl2);
  add(tg, o.tg);
  add(tg_eq46, o.tg_eq46);
  add(sxx, o.sxx);
  add(sxy, o.sxy);
  add(syx, o.syx);
  add(syy, o.syy);
  add(kxx, o.kxx);
  add(kxy, o.kxy);
  add(kyy, o.kyy);
  for (std::size_t i = 0; i < n_defined.size(); ++i) n_defined[i] += o.n_defined[i];
}

namespace {

// Pressure, |tau| and |tau|/P of a 2-D stress tensor (tension positive); its symmetric part.
struct Invariants {
  double pressure, shear;
};
inline Invariants StressInvariants(double sxx, double sxy, double syx, double syy) {
  const double s = 0.5 * (sxy + syx), d = 0.5 * (sxx - syy);
  return {-0.5 * (sxx + syy), std::sqrt(d * d + s * s)};
}

}  // namespace

double CgMaps::Value(CgField f, std::size_t n) const {
  const CgSums& s = sums_;
  const double frames = s.frames, defined = s.n_defined[n], cframes = s.contact_frames;
  auto per_defined = [&](const std::vector<double>& v) { return defined > 0 ? v[n] / defined : kNaN; };
  auto contact = [&]() {
    return cframes > 0
               ? StressInvariants(s.sxx[n] / cframes, s.sxy[n] / cframes, s.syx[n] / cframes, s.syy[n] / cframes)
               : Invariants{kNaN, kNaN};
  };
  auto kinetic = [&]() {
    return frames > 0 ? StressInvariants(s.kxx[n] / frames, s.kxy[n] / frames, s.kxy[n] / frames, s.kyy[n] / frames)
                      : Invariants{kNaN, kNaN};
  };
  auto total = [&]() {
    if (cframes <= 0 || frames <= 0) return Invariants{kNaN, kNaN};
    return StressInvariants(s.sxx[n] / cframes + s.kxx[n] / frames, s.sxy[n] / cframes + s.kxy[n] / frames,
                            s.syx[n] / cframes + s.kxy[n] / frames, s.syy[n] / cframes + s.kyy[n] / frames);
  };
  switch (f) {
    case CgField::kPhi: return frames > 0 ? s.phi[n] / frames : kNaN;
    case CgField::kVx: return per_defined(s.vx);
    case CgField::kVy: return per_defined(s.vy);
    case CgField::kSpeed: return defined > 0 ? std::hypot(s.vx[n], s.vy[n]) / defined : kNaN;
    case CgField::kOmega: return per_defined(s.omega);
    case CgField::kOmegaFl2: return per_defined(s.omega_fl2);
    case CgField::kTg: return per_defined(s.tg);
    case CgField::kTgEq46: return per_defined(s.tg_eq46);
    case CgField::kSigmaXX: return cframes > 0 ? s.sxx[n] / cframes : kNaN;
    case CgField::kSigmaXY: return cframes > 0 ? 0.5 * (s.sxy[n] + s.syx[n]) / cframes : kNaN;
    case CgField::kSigmaYY: return cframes > 0 ? s.syy[n] / cframes : kNaN;
    case CgField::kPressure: return contact().pressure;
    case CgField::kShear: return contact().shear;
    case CgField::kFriction: {
      const Invariants c = contact();
      return c.pressure > 0.0 ? c.shear / c.pressure : kNaN;
    }
    case CgField::kKineticPressure: return kinetic().pressure;
    case CgField::kKineticShear: return kinetic().shear;
    case CgField::kTotalPressure: return total().pressure;
    case CgField::kTotalShear: return total().shear;
    case CgField::kTotalFriction: {
      const Invariants t = total();
      return t.pressure > 0.0 ? t.shear / t.pressure : kNaN;
    }
  }
  return kNaN;
}

int CgMaps::NFrames(CgField f, std::size_t n) const {
  switch (f) {
    case CgField::kPhi:
    case CgField::kKineticPressure:
    case CgField::kKineticShear: return sums_.frames;
    case CgField::kVx:
    case CgField::kVy:
    case CgField::kSpeed:
    case CgField::kOmega:
    case CgField::kOmegaFl2:
    case CgField::kTg:
    case CgField::kTgEq46: return sums_.n_defined[n];
    default: return sums_.contact_frames;
  }
}

std::vector<double> CgMaps::Values(CgField f) const {
  std::vector<double> v(Grid().size());
  for (std::size_t n = 0; n < v.size(); ++n) v[n] = Value(f, n);
  return v;
}

std::string CgMapCsv(const CgMaps& maps, CgField field) {
  std::string out = std::string("x,y,") + CgFieldInfoFor(field).name + ",n_frames\n";
  const CgGrid& g = maps.Grid();
  char line[128];
  for (int j = 0; j < g.ny; ++j)
    for (int i = 0; i < g.nx; ++i) {
      const std::size_t n = static_cast<std::size_t>(j) * g.nx + i;
      const double v = maps.Value(field, n);
      const int len =
          std::isnan(v)
              ? std::snprintf(line, sizeof line, "%.10g,%.10g,nan,%d\n", g.X(i), g.Y(j), maps.NFrames(field, n))
              : std::snprintf(line, sizeof line, "%.10g,%.10g,%.10g,%d\n", g.X(i), g.Y(j), v, maps.NFrames(field, n));
      out.append(line, static_cast<std::size_t>(len));
    }
  return out;
}

CgRegionMean MeanOverRegion(const CgMaps& maps, CgField field, const Rect& region) {
  auto mean_of = [&](CgField f) {
    CgRegionMean r;
    double sum = 0.0;
    const CgGrid& g = maps.Grid();
    for (int j = 0; j < g.ny; ++j)
      for (int i = 0; i < g.nx; ++i) {
        if (!region.Contains(g.X(i), g.Y(j))) continue;
        const double v = maps.Value(f, static_cast<std::size_t>(j) * g.nx + i);
        if (std::isnan(v)) continue;
        sum += v;
        ++r.nodes;
      }
    if (r.nodes > 0) r.value = sum / r.nodes;
    return r;
  };
  if (field == CgField::kFriction || field == CgField::kTotalFriction) {
    const bool total = field == CgField::kTotalFriction;
    const CgRegionMean tau = mean_of(total ? CgField::kTotalShear : CgField::kShear);
    const CgRegionMean p = mean_of(total ? CgField::kTotalPressure : CgField::kPressure);
    CgRegionMean r;
    r.nodes = std::min(tau.nodes, p.nodes);
    if (p.value > 0.0) r.value = tau.value / p.value;
    return r;
  }
  return mean_of(field);
}

double CgLineIntegral(double rx, double ry, double ax, double ay, double bx, double by, const CgOptions& options) {
  const Kernel k(options);
  const double ux = bx - ax, uy = by - ay, length2 = ux * ux + uy * uy;
  // Zero beyond the cutoff from the segment's line or beyond its ends (as MercuryCG cuts its
  // line integrals).
  const double length = std::sqrt(length2);
  if (!(length > 0.0)) return 0.0;
  const double along = ((rx - ax) * ux + (ry - ay) * uy) / length, perp = ((rx - ax) * uy - (ry - ay) * ux) / length;
  if (!(along > -k.rc && along < length + k.rc && perp * perp < k.rc2)) return 0.0;
  const Quadrature& q = GaussLegendre(QuadraturePoints(std::sqrt(length2) / options.width, options.cutoff));
  double sum = 0.0;
  for (int p = 0; p < q.n; ++p) {
    const double dx = rx - ax - q.s[p] * ux, dy = ry - ay - q.s[p] * uy;
    sum += q.c[p] * std::exp(-(dx * dx + dy * dy) * k.inv_w2);
  }
  return sum * k.norm;
}

// ---- the accumulator ---------------------------------------------------------------------

struct CgAccumulator::Impl {
  CgOptions opt;
  Kernel kernel;
  CgGrid grid;  // the window's nodes
  CgGrid ext;   // the window and a margin of `margin` nodes on every side (pass 2 reads the velocity field there)
  int margin = 0;
  double q2 = 0;  // exp(-2 h^2 / w^2): ratio of the recurrence ratios
  CgSums sums;
  std::vector<CgSeries> series;

  // The frame on the extended grid.
  std::vector<double> phi, px, py, om, om2, v2;  // pass 1
  std::vector<double> ta, kxx, kxy, kyy;         // pass 2: sum a |dv|^2 W, sum m dv dv W
  std::vector<double> sxx, sxy, syx, syy;        // contacts
  // The frame's discs that reach the extended grid.
  std::vector<double> dx, dy, da, dm, dvx, dvy, dom;
  std::vector<unsigned char> near_window;  // within the cutoff of a window node: pass 2
  std::vector<Branch> segments;
  int band_rows = kMinBandRows;                                      // >= the rows a disc reaches
  std::vector<std::vector<std::int32_t>> band_discs, band_segments;  // by the band of their first row
  std::vector<std::int32_t> tall_segments;                           // contacts reaching more rows than a band has
  std::vector<double> body_m, body_x, body_y;                        // centres of mass by body id

  explicit Impl(const CgOptions& o) : opt(o), kernel(o) {}

  int Bands() const { return (ext.ny + band_rows - 1) / band_rows; }
  int Threads() const { return opt.threads > 0 ? opt.threads : omp_get_max_threads(); }

  void Select(std::span<const rundir::Disc> discs);
  void BodyCentres(std::span<const rundir::Disc> discs);
  void BuildSegments(const rundir::ContactFrame& contacts);
  void ClearBand(int band);
  void Pass1(std::span<const std::int32_t> discs, std::span<const std::int32_t> contacts);
  void Pass2(std::span<const std::int32_t> discs);
  void FinishFrame(double time, bool with_contacts);
  double FrameValue(CgField f, std::size_t n_ext) const;
};

CgAccumulator::CgAccumulator(const CgOptions& options, std::vector<CgSeriesRequest> series)
    : impl_(std::make_unique<Impl>(options)) {
  Impl& m = *impl_;
  const CgOptions& o = options;
  if (!(o.width > 0.0))
    throw std::invalid_argument("coarse-graining width must be > 0 (got " + std::to_string(o.width) + ")");
  if (!(o.cutoff >= 1.0))
    throw std::invalid_argument("coarse-graining cutoff must be >= 1 width (got " + std::to_string(o.cutoff) + ")");
  if (!(o.spacing > 0.0) || !(o.spacing <= 0.5 * o.cutoff * o.width))
    throw std::invalid_argument("grid spacing must be > 0 and <= half the cutoff radius " +
                                std::to_string(0.5 * o.cutoff * o.width) + " (got " + std::to_string(o.spacing) + ")");
  if (!(o.window.x1 > o.window.x0) || !(o.window.y1 >= o.window.y0))
    throw std::invalid_argument("coarse-graining window is empty");
  if (!(o.min_phi > 0.0)) throw std::invalid_argument("min_phi must be > 0 (got " + std::to_string(o.min_phi) + ")");
  m.grid = GridOver(o.window, o.spacing);
  if (m.grid.size() > 50'000'000) throw std::invalid_argument("coarse-graining grid has more than 5e7 nodes");
  m.margin = static_cast<int>(std::ceil(m.kernel.rc / o.spacing)) + 1;
  m.ext = m.grid;
  m.ext.x0 -= m.margin * o.spacing;
  m.ext.y0 -= m.margin * o.spacing;
  m.ext.nx += 2 * m.margin;
  m.ext.ny += 2 * m.margin;
  m.q2 = std::exp(-2.0 * o.spacing * o.spacing * m.kernel.inv_w2);
  // A disc reaches the rows within rc of it: at most floor(2 rc / h) + 1.
  m.band_rows = std::max(kMinBandRows, static_cast<int>(std::floor(2.0 * m.kernel.rc / o.spacing)) + 1);
  m.sums.Resize(m.grid);
  for (auto* v :
       {&m.phi, &m.px, &m.py, &m.om, &m.om2, &m.v2, &m.ta, &m.kxx, &m.kxy, &m.kyy, &m.sxx, &m.sxy, &m.syx, &m.syy})
    v->assign(m.ext.size(), 0.0);
  m.band_discs.resize(static_cast<std::size_t>(m.Bands()));
  m.band_segments.resize(static_cast<std::size_t>(m.Bands()));
  for (CgSeriesRequest& r : series) m.series.push_back(CgSeries{std::move(r), {}, {}});
}

CgAccumulator::~CgAccumulator() = default;
CgAccumulator::CgAccumulator(CgAccumulator&&) noexcept = default;
CgAccumulator& CgAccumulator::operator=(CgAccumulator&&) noexcept = default;

const CgSums& CgAccumulator::Sums() const { return impl_->sums; }
const std::vector<CgSeries>& CgAccumulator::Series() const { return impl_->series; }
const CgOptions& CgAccumulator::Options() const { return impl_->opt; }
const CgGrid& CgAccumulator::Grid() const { return impl_->grid; }

void CgAccumulator::Impl::Select(std::span<const rundir::Disc> discs) {
  for (auto* v : {&dx, &dy, &da, &dm, &dvx, &dvy, &dom}) v->clear();
  near_window.clear();
  for (auto& b : band_discs) b.clear();
  const double rc = kernel.rc, h = opt.spacing;
  const double ex0 = ext.x0 - rc, ex1 = ext.X(ext.nx - 1) + rc, ey0 = ext.y0 - rc, ey1 = ext.Y(ext.ny - 1) + rc;
  const double wx0 = grid.x0 - rc, wx1 = grid.X(grid.nx - 1) + rc, wy0 = grid.y0 - rc, wy1 = grid.Y(grid.ny - 1) + rc;
  for (const rundir::Disc& d : discs) {
    if (!(d.x > ex0 && d.x < ex1 && d.y > ey0 && d.y < ey1)) continue;  // also drops NaN
    const auto k = static_cast<std::int32_t>(dx.size());
    dx.push_back(d.x);
    dy.push_back(d.y);
    da.push_back(std::numbers::pi * d.radius * d.radius);
    dm.push_back(d.mass);
    dvx.push_back(d.vx);
    dvy.push_back(d.vy);
    dom.push_back(d.omega);
    near_window.push_back(d.x > wx0 && d.x < wx1 && d.y > wy0 && d.y < wy1);
    const int j_lo = std::max(0, static_cast<int>(std::ceil((d.y - rc - ext.y0) / h)));
    const int j_hi = std::min(ext.ny - 1, static_cast<int>(std::floor((d.y + rc - ext.y0) / h)));
    if (j_lo <= j_hi) band_discs[static_cast<std::size_t>(j_lo / band_rows)].push_back(k);
  }
}

void CgAccumulator::Impl::BodyCentres(std::span<const rundir::Disc> discs) {
  std::int64_t max_id = -1;
  for (const rundir::Disc& d : discs) max_id = std::max(max_id, d.mol);
  // Body ids are dense (0-based, docs/run-directory.md); a sparse numbering gets no centres
  // and the contacts fall back to disc centres.
  const std::int64_t limit = 16 * static_cast<std::int64_t>(discs.size()) + 1024;
  const std::size_t n = max_id >= 0 && max_id < limit ? static_cast<std::size_t>(max_id + 1) : 0;
  body_m.assign(n, 0.0);
  body_x.assign(n, 0.0);
  body_y.assign(n, 0.0);
  if (n == 0) return;
  for (const rundir::Disc& d : discs) {
    if (d.mol < 0) continue;
    const auto b = static_cast<std::size_t>(d.mol);
    body_m[b] += d.mass;
    body_x[b] += d.mass * d.x;
    body_y[b] += d.mass * d.y;
  }
  for (std::size_t b = 0; b < n; ++b)
    if (body_m[b] > 0.0) {
      body_x[b] /= body_m[b];
      body_y[b] /= body_m[b];
    }
}

void CgAccumulator::Impl::BuildSegments(const rundir::ContactFrame& contacts) {
  segments.clear();
  for (auto& b : band_segments) b.clear();
  tall_segments.clear();
  const double rc = kernel.rc, h = opt.spacing;
  const double wx0 = grid.x0 - rc, wx1 = grid.X(grid.nx - 1) + rc, wy0 = grid.y0 - rc, wy1 = grid.Y(grid.ny - 1) + rc;
  auto centre = [&](std::int64_t body, double disc_x, double disc_y, double cx, double cy, double& x, double& y) {
    x = disc_x;
    y = disc_y;
    if (body < 0 || static_cast<std::size_t>(body) >= body_m.size() || !(body_m[static_cast<std::size_t>(body)] > 0.0))
      return;
    const double bx = body_x[static_cast<std::size_t>(body)], by = body_y[static_cast<std::size_t>(body)];
    if ((bx - cx) * (bx - cx) + (by - cy) * (by - cy) <= kMaxBranch * kMaxBranch) {
      x = bx;
      y = by;
    }
  };
  // One branch from a through the ends b[k] (k < halves) with forces f[k] on those bodies.
  auto add = [&](double ax, double ay, int halves, const double* bx, const double* by, const double* fx,
                 const double* fy) {
    Branch br{ax, ay, 0, {0, 0}, {0, 0}, {}};
    double lo_x = ax, hi_x = ax, lo_y = ay, hi_y = ay;
    for (int k = 0; k < halves; ++k) {
      const double ux = bx[k] - ax, uy = by[k] - ay;
      if (!(std::isfinite(ux) && std::isfinite(uy) && std::isfinite(fx[k]) && std::isfinite(fy[k]))) continue;
      if (ux == 0.0 && uy == 0.0) continue;
      const int h2 = br.halves++;
      br.bx[h2] = bx[k];
      br.by[h2] = by[k];
      br.t[h2][0] = -fx[k] * ux;
      br.t[h2][1] = -fx[k] * uy;
      br.t[h2][2] = -fy[k] * ux;
      br.t[h2][3] = -fy[k] * uy;
      lo_x = std::min(lo_x, bx[k]);
      hi_x = std::max(hi_x, bx[k]);
      lo_y = std::min(lo_y, by[k]);
      hi_y = std::max(hi_y, by[k]);
    }
    if (br.halves == 0 || !std::isfinite(ax) || !std::isfinite(ay)) return;
    if (hi_x < wx0 || lo_x > wx1 || hi_y < wy0 || lo_y > wy1) return;
    const auto k = static_cast<std::int32_t>(segments.size());
    segments.push_back(br);
    const int j_lo = std::max(margin, static_cast<int>(std::ceil((lo_y - rc - ext.y0) / h)));
    const int j_hi = std::min(margin + grid.ny - 1, static_cast<int>(std::floor((hi_y + rc - ext.y0) / h)));
    if (j_lo > j_hi) return;
    if (j_hi - j_lo < band_rows)
      band_segments[static_cast<std::size_t>(j_lo / band_rows)].push_back(k);
    else
      tall_segments.push_back(k);
  };
  for (const rundir::ContactRow& c : contacts.contacts) {
    double ix, iy;
    centre(c.body_i, c.xi, c.yi, c.cx, c.cy, ix, iy);
    if (c.body_j < 0) {  // a wall or an obstacle: the body's half of the branch
      add(c.cx, c.cy, 1, &ix, &iy, &c.fx, &c.fy);
      continue;
    }
    double jx, jy;
    centre(c.body_j, c.xj, c.yj, c.cx, c.cy, jx, jy);
    // Centres on either side of the contact point on one line (two round bodies; the dump's 10
    // digits leave them 1e-8 d off it): the two halves are one segment from J to I, with half
    // the quadrature work.
    const double ax = ix - c.cx, ay = iy - c.cy, bx = jx - c.cx, by = jy - c.cy;
    const double cross = ax * by - ay * bx, dot = ax * bx + ay * by;
    if (dot < 0.0 && std::abs(cross) <= 1e-8 * (ax * ax + ay * ay + bx * bx + by * by)) {
      add(jx, jy, 1, &ix, &iy, &c.fx, &c.fy);
    } else {
      const double ends_x[2] = {ix, jx}, ends_y[2] = {iy, jy}, fx[2] = {c.fx, -c.fx}, fy[2] = {c.fy, -c.fy};
      add(c.cx, c.cy, 2, ends_x, ends_y, fx, fy);
    }
  }
}

void CgAccumulator::Impl::ClearBand(int band) {
  const int j0 = band * band_rows, j1 = std::min(ext.ny, j0 + band_rows);  // rows [j0, j1)
  const std::size_t n0 = static_cast<std::size_t>(j0) * ext.nx, n1 = static_cast<std::size_t>(j1) * ext.nx;
  for (auto* v : {&phi, &px, &py, &om, &om2, &v2, &ta, &kxx, &kxy, &kyy, &sxx, &sxy, &syx, &syy})
    std::fill(v->begin() + static_cast<std::ptrdiff_t>(n0), v->begin() + static_cast<std::ptrdiff_t>(n1), 0.0);
}

// Discs and contacts onto all the rows they reach (the caller keeps threads apart).
__attribute__((target_clones("avx2", "default"))) void CgAccumulator::Impl::Pass1(
    std::span<const std::int32_t> disc_list, std::span<const std::int32_t> contact_list) {
  const double h = opt.spacing, rc = kernel.rc, rc2 = kernel.rc2, inv_w2 = kernel.inv_w2, norm = kernel.norm;
  // Row and column ranges are clamped to the grid, so its dimensions bound the scratch.
  const std::size_t cols = static_cast<std::size_t>(ext.nx), rows = static_cast<std::size_t>(ext.ny);
  thread_local std::vector<double> scratch;
  scratch.resize(2 * cols + 2 * rows + 2 * kMaxQuadrature * (cols + rows));
  double* const ex = scratch.data();
  double* const dx2 = ex + cols;
  double* const ey = dx2 + cols;
  double* const dy2 = ey + rows;
  double* const qx = dy2 + rows;  // the quadrature points' factors: per half, kMaxQuadrature rows of cols
  double* const qy = qx + 2 * kMaxQuadrature * cols;
  for (const std::int32_t k : disc_list) {
    const double x = dx[k], y = dy[k];
    const int i_lo = std::max(0, static_cast<int>(std::ceil((x - rc - ext.x0) / h)));
    const int i_hi = std::min(ext.nx - 1, static_cast<int>(std::floor((x + rc - ext.x0) / h)));
    const int r_lo = std::max(0, static_cast<int>(std::ceil((y - rc - ext.y0) / h)));
    const int r_hi = std::min(ext.ny - 1, static_cast<int>(std::floor((y + rc - ext.y0) / h)));
    const int ni = i_hi - i_lo + 1, nj = r_hi - r_lo + 1;
    if (ni <= 0 || nj <= 0) continue;
    AxisFactors(ext.X(i_lo), h, x, ni, inv_w2, q2, ex, dx2);
    AxisFactors(ext.Y(r_lo), h, y, nj, inv_w2, q2, ey, dy2);
    const double a = da[k], avx = a * dvx[k], avy = a * dvy[k], aom = a * dom[k], aom2 = aom * dom[k];
    const double av2 = a * (dvx[k] * dvx[k] + dvy[k] * dvy[k]);
    for (int r = 0; r < nj; ++r) {
      const double room = rc2 - dy2[r], c = norm * ey[r];
      const std::size_t base = static_cast<std::size_t>(r_lo + r) * ext.nx + i_lo;
      double* __restrict o_phi = phi.data() + base;
      double* __restrict o_px = px.data() + base;
      double* __restrict o_py = py.data() + base;
      double* __restrict o_om = om.data() + base;
      double* __restrict o_om2 = om2.data() + base;
      double* __restrict o_v2 = v2.data() + base;
#pragma omp simd
      for (int i = 0; i < ni; ++i) {
        const double w = dx2[i] < room ? c * ex[i] : 0.0;
        o_phi[i] += a * w;
        o_px[i] += avx * w;
        o_py[i] += avy * w;
        o_om[i] += aom * w;
        o_om2[i] += aom2 * w;
        o_v2[i] += av2 * w;
      }
    }
  }
  // Contacts, on the window's nodes only.
  const int wi0 = margin, wi1 = margin + grid.nx - 1;
  const int wj0 = margin, wj1 = margin + grid.ny - 1;
  for (const std::int32_t k : contact_list) {
    const Branch& br = segments[static_cast<std::size_t>(k)];
    double lo_x = br.ax, hi_x = br.ax, lo_y = br.ay, hi_y = br.ay;
    for (int half = 0; half < br.halves; ++half) {
      lo_x = std::min(lo_x, br.bx[half]);
      hi_x = std::max(hi_x, br.bx[half]);
      lo_y = std::min(lo_y, br.by[half]);
      hi_y = std::max(hi_y, br.by[half]);
    }
    const int i_first = std::max(wi0, static_cast<int>(std::ceil((lo_x - rc - ext.x0) / h)));
    const int i_last = std::min(wi1, static_cast<int>(std::floor((hi_x + rc - ext.x0) / h)));
    const int r_lo = std::max(wj0, static_cast<int>(std::ceil((lo_y - rc - ext.y0) / h)));
    const int r_hi = std::min(wj1, static_cast<int>(std::floor((hi_y + rc - ext.y0) / h)));
    const int nj = r_hi - r_lo + 1;
    if (i_last < i_first || nj <= 0) continue;
    // Whole vectors of columns: the range grows to a multiple of kLanes (left if the row ends),
    // and the columns outside [i_first, i_last] get nothing.
    const int ni = (i_last - i_first + kLanes) / kLanes * kLanes;
    const int i_lo = std::max(0, std::min(i_first, ext.nx - ni));
    if (i_lo + ni > ext.nx) continue;  // a grid narrower than one vector of columns: never at spacing <= rc/2
    const double col_lo = i_first - i_lo - 0.5, col_hi = i_last - i_lo + 0.5;
    // Per half: the quadrature points' axis factors and the cut -- nodes within the cutoff of
    // the segment's line and no further than the cutoff beyond its ends (MercuryCG's cut of
    // its line integrals), with along = (r - a).e and perp = (r - a) x e.
    int nq[2] = {0, 0};
    const Quadrature* rule[2] = {nullptr, nullptr};
    double e_x[2] = {0, 0}, e_y[2] = {0, 0}, along_hi[2] = {0, 0};
    for (int half = 0; half < br.halves; ++half) {
      const double ux = br.bx[half] - br.ax, uy = br.by[half] - br.ay, length = std::sqrt(ux * ux + uy * uy);
      rule[half] = &GaussLegendre(QuadraturePoints(length / opt.width, opt.cutoff));
      nq[half] = rule[half]->n;
      e_x[half] = ux / length;
      e_y[half] = uy / length;
      along_hi[half] = length + rc;
      for (int p = 0; p < nq[half]; ++p) {
        const std::size_t block = static_cast<std::size_t>(half) * kMaxQuadrature + static_cast<std::size_t>(p);
        AxisExp(ext.X(i_lo), h, br.ax + rule[half]->s[p] * ux, ni, inv_w2, q2, qx + block * cols);
        AxisExp(ext.Y(r_lo), h, br.ay + rule[half]->s[p] * uy, nj, inv_w2, q2, qy + block * rows);
      }
    }
    const double x_first = ext.X(i_lo) - br.ax;
    const int halves = br.halves;
    for (int r = 0; r < nj; ++r) {
      const double ry = ext.Y(r_lo + r) - br.ay;
      double cq[2][kMaxQuadrature];
      for (int half = 0; half < halves; ++half) {
        const double* const fy = qy + static_cast<std::size_t>(half) * kMaxQuadrature * rows + r;
        for (int p = 0; p < nq[half]; ++p)
          cq[half][p] = norm * rule[half]->c[p] * fy[static_cast<std::size_t>(p) * rows];
      }
      double* const out[4] = {sxx.data(), sxy.data(), syx.data(), syy.data()};
      const std::size_t base = static_cast<std::size_t>(r_lo + r) * ext.nx + i_lo;
      for (int i0 = 0; i0 < ni; i0 += kLanes) {
        const Lanes col = Lanes{0, 1, 2, 3} + i0;
        const Lanes rx = x_first + col * h;
        Lanes acc[4] = {};
        for (int half = 0; half < halves; ++half) {
          // The kernel's line integral: the quadrature points' Gaussians, at nodes within the
          // cut (and inside the branch's columns).
          const double* const fx = qx + static_cast<std::size_t>(half) * kMaxQuadrature * cols + i0;
          Lanes line = {};
          for (int p = 0; p < nq[half]; ++p) line += cq[half][p] * LoadLanes(fx + static_cast<std::size_t>(p) * cols);
          const Lanes along = rx * e_x[half] + ry * e_y[half], perp = rx * e_y[half] - ry * e_x[half];
          const auto inside =
              (along > -rc) & (along < along_hi[half]) & (perp * perp < rc2) & (col > col_lo) & (col < col_hi);
          line = inside ? line : Lanes{};
          for (int c = 0; c < 4; ++c) acc[c] += br.t[half][c] * line;
        }
        for (int c = 0; c < 4; ++c) {
          double* const o = out[c] + base + i0;
          StoreLanes(o, LoadLanes(o) + acc[c]);
        }
      }
    }
  }
}

// The discs' velocity fluctuations onto the window's rows they reach.
__attribute__((target_clones("avx2", "default"))) void CgAccumulator::Impl::Pass2(
    std::span<const std::int32_t> disc_list) {
  const int j0 = margin, j1 = margin + grid.ny;  // the window's rows [j0, j1)
  const int wi0 = margin, wi1 = margin + grid.nx - 1;
  const double h = opt.spacing, rc = kernel.rc, rc2 = kernel.rc2, inv_w2 = kernel.inv_w2, norm = kernel.norm;
  const std::size_t cols = static_cast<std::size_t>(ext.nx), rows = static_cast<std::size_t>(ext.ny);
  thread_local std::vector<double> scratch;
  scratch.resize(2 * cols + 2 * rows);
  double* const ex = scratch.data();
  double* const dx2 = ex + cols;
  double* const ey = dx2 + cols;
  double* const dy2 = ey + rows;
  for (const std::int32_t k : disc_list) {
    if (!near_window[static_cast<std::size_t>(k)]) continue;
    const double x = dx[k], y = dy[k];
    const int i_lo = std::max(wi0, static_cast<int>(std::ceil((x - rc - ext.x0) / h)));
    const int i_hi = std::min(wi1, static_cast<int>(std::floor((x + rc - ext.x0) / h)));
    const int r_lo = std::max(j0, static_cast<int>(std::ceil((y - rc - ext.y0) / h)));
    const int r_hi = std::min(j1 - 1, static_cast<int>(std::floor((y + rc - ext.y0) / h)));
    const int ni = i_hi - i_lo + 1, nj = r_hi - r_lo + 1;
    if (ni <= 0 || nj <= 0) continue;
    // The frame's velocity field at the disc: bilinear momentum over bilinear phi.
    const double gx = (x - ext.x0) / h, gy = (y - ext.y0) / h;
    const int ci = std::clamp(static_cast<int>(std::floor(gx)), 0, ext.nx - 2);
    const int cj = std::clamp(static_cast<int>(std::floor(gy)), 0, ext.ny - 2);
    const double fx = gx - ci, fy = gy - cj;
    const std::size_t n00 = static_cast<std::size_t>(cj) * ext.nx + ci, n01 = n00 + ext.nx;
    const double b00 = (1 - fx) * (1 - fy), b10 = fx * (1 - fy), b01 = (1 - fx) * fy, b11 = fx * fy;
    const double phi_i = b00 * phi[n00] + b10 * phi[n00 + 1] + b01 * phi[n01] + b11 * phi[n01 + 1];
    const double px_i = b00 * px[n00] + b10 * px[n00 + 1] + b01 * px[n01] + b11 * px[n01 + 1];
    const double py_i = b00 * py[n00] + b10 * py[n00 + 1] + b01 * py[n01] + b11 * py[n01 + 1];
    if (!(phi_i > 0.0)) continue;
    const double dvx_i = dvx[k] - px_i / phi_i, dvy_i = dvy[k] - py_i / phi_i;
    const double m = dm[k];
    const double qa = da[k] * (dvx_i * dvx_i + dvy_i * dvy_i), qxx = m * dvx_i * dvx_i, qxy = m * dvx_i * dvy_i,
                 qyy = m * dvy_i * dvy_i;
    AxisFactors(ext.X(i_lo), h, x, ni, inv_w2, q2, ex, dx2);
    AxisFactors(ext.Y(r_lo), h, y, nj, inv_w2, q2, ey, dy2);
    for (int r = 0; r < nj; ++r) {
      const double room = rc2 - dy2[r], c = norm * ey[r];
      const std::size_t base = static_cast<std::size_t>(r_lo + r) * ext.nx + i_lo;
      double* __restrict o_ta = ta.data() + base;
      double* __restrict o_xx = kxx.data() + base;
      double* __restrict o_xy = kxy.data() + base;
      double* __restrict o_yy = kyy.data() + base;
#pragma omp simd
      for (int i = 0; i < ni; ++i) {
        const double w = dx2[i] < room ? c * ex[i] : 0.0;
        o_ta[i] += qa * w;
        o_xx[i] += qxx * w;
        o_xy[i] += qxy * w;
        o_yy[i] += qyy * w;
      }
    }
  }
}

double CgAccumulator::Impl::FrameValue(CgField f, std::size_t n) const {
  const double p = phi[n];
  const bool defined = p >= opt.min_phi;
  switch (f) {
    case CgField::kPhi: return p;
    case CgField::kVx: return defined ? px[n] / p : kNaN;
    case CgField::kVy: return defined ? py[n] / p : kNaN;
    case CgField::kSpeed: return defined ? std::hypot(px[n], py[n]) / p : kNaN;
    case CgField::kOmega: return defined ? om[n] / p : kNaN;
    case CgField::kOmegaFl2: {
      if (!defined) return kNaN;
      const double o = om[n] / p;
      return std::max(0.0, om2[n] / p - o * o);
    }
    case CgField::kTg: return defined ? ta[n] / (2.0 * p) : kNaN;
    case CgField::kTgEq46: {
      if (!defined) return kNaN;
      const double vx = px[n] / p, vy = py[n] / p;
      return std::max(0.0, 0.5 * (v2[n] / p - vx * vx - vy * vy));
    }
    case CgField::kSigmaXX: return sxx[n];
    case CgField::kSigmaXY: return 0.5 * (sxy[n] + syx[n]);
    case CgField::kSigmaYY: return syy[n];
    case CgField::kPressure: return StressInvariants(sxx[n], sxy[n], syx[n], syy[n]).pressure;
    case CgField::kShear: return StressInvariants(sxx[n], sxy[n], syx[n], syy[n]).shear;
    case CgField::kFriction: {
      const Invariants c = StressInvariants(sxx[n], sxy[n], syx[n], syy[n]);
      return c.pressure > 0.0 ? c.shear / c.pressure : kNaN;
    }
    case CgField::kKineticPressure: return StressInvariants(-kxx[n], -kxy[n], -kxy[n], -kyy[n]).pressure;
    case CgField::kKineticShear: return StressInvariants(-kxx[n], -kxy[n], -kxy[n], -kyy[n]).shear;
    case CgField::kTotalPressure:
      return StressInvariants(sxx[n] - kxx[n], sxy[n] - kxy[n], syx[n] - kxy[n], syy[n] - kyy[n]).pressure;
    case CgField::kTotalShear:
      return StressInvariants(sxx[n] - kxx[n], sxy[n] - kxy[n], syx[n] - kxy[n], syy[n] - kyy[n]).shear;
    case CgField::kTotalFriction: {
      const Invariants t = StressInvariants(sxx[n] - kxx[n], sxy[n] - kxy[n], syx[n] - kxy[n], syy[n] - kyy[n]);
      return t.pressure > 0.0 ? t.shear / t.pressure : kNaN;
    }
  }
  return kNaN;
}

void CgAccumulator::Impl::FinishFrame(double time, bool with_contacts) {
  const int nt = Threads();
#pragma omp parallel for schedule(static) num_threads(nt)
  for (int j = 0; j < grid.ny; ++j) {
    for (int i = 0; i < grid.nx; ++i) {
      const std::size_t n = static_cast<std::size_t>(j + margin) * ext.nx + (i + margin);
      const std::size_t w = static_cast<std::size_t>(j) * grid.nx + i;
      const double p = phi[n];
      sums.phi[w] += p;
      sums.kxx[w] -= kxx[n];
      sums.kxy[w] -= kxy[n];
      sums.kyy[w] -= kyy[n];
      if (with_contacts) {
        sums.sxx[w] += sxx[n];
        sums.sxy[w] += sxy[n];
        sums.syx[w] += syx[n];
        sums.syy[w] += syy[n];
      }
      if (p < opt.min_phi) continue;
      ++sums.n_defined[w];
      sums.vx[w] += px[n] / p;
      sums.vy[w] += py[n] / p;
      sums.omega[w] += om[n] / p;
      sums.omega_fl2[w] += FrameValue(CgField::kOmegaFl2, n);
      sums.tg[w] += ta[n] / (2.0 * p);
      sums.tg_eq46[w] += FrameValue(CgField::kTgEq46, n);
    }
  }
  ++sums.frames;
  if (with_contacts) ++sums.contact_frames;
  for (CgSeries& s : series) {
    double sum = 0.0;
    int count = 0;
    for (int j = 0; j < grid.ny; ++j)
      for (int i = 0; i < grid.nx; ++i) {
        if (!s.request.region.Contains(grid.X(i), grid.Y(j))) continue;
        const double v = FrameValue(s.request.field, static_cast<std::size_t>(j + margin) * ext.nx + (i + margin));
        if (std::isnan(v)) continue;
        sum += v;
        ++count;
      }
    const bool stress = CgFieldInfoFor(s.request.field).needs_contacts;
    s.time.push_back(time);
    s.value.push_back(count > 0 && (with_contacts || !stress) ? sum / count : kNaN);
  }
}

void CgAccumulator::AddFrame(double time, std::span<const rundir::Disc> discs, const rundir::ContactFrame* contacts) {
  Impl& m = *impl_;
  m.Select(discs);
  const bool with_contacts = contacts != nullptr;
  if (with_contacts) {
    m.BodyCentres(discs);
    m.BuildSegments(*contacts);
  }
  const int nb = m.Bands(), nt = m.Threads();
  const std::span<const std::int32_t> none;
  auto contacts_of = [&](int b) {
    return with_contacts ? std::span<const std::int32_t>(m.band_segments[static_cast<std::size_t>(b)]) : none;
  };
  // Each omp for ends in a barrier: a band writes its own rows and the band above's, so the
  // even bands go first, then the odd ones; pass 2 reads pass 1's velocity field.
#pragma omp parallel num_threads(nt)
  {
#pragma omp for schedule(static)
    for (int b = 0; b < nb; ++b) m.ClearBand(b);
    for (int parity = 0; parity < 2; ++parity) {
#pragma omp for schedule(dynamic, 1)
      for (int b = parity; b < nb; b += 2) m.Pass1(m.band_discs[static_cast<std::size_t>(b)], contacts_of(b));
    }
#pragma omp single
    if (with_contacts) m.Pass1(none, m.tall_segments);
    for (int parity = 0; parity < 2; ++parity) {
#pragma omp for schedule(dynamic, 1)
      for (int b = parity; b < nb; b += 2) m.Pass2(m.band_discs[static_cast<std::size_t>(b)]);
    }
  }
  m.FinishFrame(time, with_contacts);
}

}  // namespace granary::analysis
