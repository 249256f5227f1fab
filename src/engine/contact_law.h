// The contact kernel (docs/model.md "Contact law"): the geometry of a contact and the force
// law, written once and templated on the value type V, as LAMMPS' KOKKOS and INTEL kernel
// functions are. V is double for the portable pair loop (pair_entries.h) and the wall loop
// (force_pass.cpp), and the eight-lane AVX-512 type of avx512_kernels.cpp for the vector pair
// loop; both do the same IEEE operations in the same order, so their results are the same
// to the bit. A value type provides + - * / and unary -, comparisons giving its mask type
// (bool for double), mask &, and the free functions Sqrt, Abs, Select, NeedAny, Load<V>
// and Store below.
//
// The law: a normal-force model (NormalModels: Hertz, Hooke) with velocity damping and a
// tangential spring with history, capped by Coulomb friction. The convention is LAMMPS'
// pair gran/hertz/history and gran/hooke/history (dampflag 1) with BODY masses in m_eff;
// the LIGGGHTS 3.8 cap (only the spring part is capped) is selectable (docs/liggghts.md).
// Inputs in reduced units; no state.
#pragma once

#include <cmath>
#include <tuple>
#include <type_traits>

#include "rundir/run_spec.h"

namespace granary::engine {

struct ContactParams {
  double kn = 2.0e6;
  double kt = 2.45e6;
  double gamma_n = 1000.0;
  double gamma_t = 1000.0;
  double mu = 0.5;
  NormalModel normal_model = NormalModel::kHertz;
  bool liggghts_cap = false;  // false: LAMMPS caps spring + damping; true: LIGGGHTS caps the spring only
  bool clip_normal = false;   // clip an attractive normal force to zero
};

// Effective radius of two discs (docs/model.md): r_i r_j / (r_i + r_j). A wall is r_j = infinity.
inline double EffectiveRadius(double ri, double rj) { return ri * rj / (ri + rj); }
// Effective mass of two bodies: M_I M_J / (M_I + M_J). A wall or obstacle: M_I.
inline double EffectiveMass(double mi, double mj) { return mi * mj / (mi + mj); }

// The value-type operations of double.
inline double Sqrt(double a) { return std::sqrt(a); }
inline double Abs(double a) { return std::fabs(a); }
inline double Select(bool m, double if_true, double if_false) { return m ? if_true : if_false; }
// Whether work that only some entries need must be done. The scalar loop always does it and
// selects (it stays branch-free, so it vectorizes); a lane type skips it when no lane needs it.
inline bool NeedAny(bool) { return true; }
template <class V>
V Load(const double* p);
template <>
inline double Load<double>(const double* p) {
  return *p;
}
inline void Store(double* p, double v) { *p = v; }

// Normal-force models: F_n = s (K_n delta - m_eff gamma_n v_n) and F_t = -s (K_t xi +
// m_eff gamma_t v_t), s the model's Scale of the overlap delta. A new model is one struct
// here and one row in NormalModels (its name in the spec: run_spec.cpp kNormalModels).
struct HertzNormal {  // LAMMPS pair gran/hertz/history: s = sqrt(R_eff delta)
  static constexpr NormalModel kModel = NormalModel::kHertz;
  template <class V>
  [[gnu::always_inline]] static V Scale(V delta, V r_eff) {
    return Sqrt(r_eff * delta);
  }
};
struct HookeNormal {  // LAMMPS pair gran/hooke/history: s = 1 (a linear spring-dashpot)
  static constexpr NormalModel kModel = NormalModel::kHooke;
  template <class V>
  [[gnu::always_inline]] static V Scale(V, V) {
    return V(1.0);
  }
};
using NormalModels = std::tuple<HertzNormal, HookeNormal>;

// Calls f(Model{}, std::bool_constant<kLiggghtsCap>{}) with the normal model and the cap of p
// and returns its result: the one place a run's law is chosen. (Inlined, with an inlined f, so
// that the loops f runs are compiled for the caller's instruction set: force_pass.cpp's kernels.)
template <class F, std::size_t kIndex = 0>
[[gnu::always_inline]] inline decltype(auto) WithContactLaw(const ContactParams& p, F&& f) {
  using Model = std::tuple_element_t<kIndex, NormalModels>;
  if constexpr (kIndex + 1 < std::tuple_size_v<NormalModels>)
    if (p.normal_model != Model::kModel) return WithContactLaw<F, kIndex + 1>(p, static_cast<F&&>(f));
  return p.liggghts_cap ? f(Model{}, std::true_type{}) : f(Model{}, std::false_type{});
}

// The law's constants as values of V (for a lane type: broadcast once per loop).
template <class V>
struct LawConstants {
  V kn, kt, gamma_n, gamma_t, mu, dt;
  bool clip_normal;
  [[gnu::always_inline]] LawConstants(const ContactParams& p, double step)
      : kn(p.kn), kt(p.kt), gamma_n(p.gamma_n), gamma_t(p.gamma_t), mu(p.mu), dt(step), clip_normal(p.clip_normal) {}
};

// A contact's geometry and relative motion: unit normal n from j (or the wall point) to i,
// overlap delta, normal speed v_n = (v_i - v_j).n and the tangential relative velocity at
// the contact point.
template <class V>
struct ContactGeometry {
  V nx, ny, delta, vn, vtx, vty;
};

// From the centre difference (ddx, ddy) with rsq = |dd|^2 > 0, the contact distance `reach`
// (sum of radii), the relative velocity (vrx, vry) and wr = r_i w_i + r_j w_j.
template <class V>
[[gnu::always_inline]] inline ContactGeometry<V> Geometry(V ddx, V ddy, V rsq, V reach, V vrx, V vry, V wr) {
  const V r = Sqrt(rsq);
  const V inv_r = V(1.0) / r;
  ContactGeometry<V> g;
  g.nx = ddx * inv_r;
  g.ny = ddy * inv_r;
  g.delta = reach - r;
  g.vn = vrx * g.nx + vry * g.ny;
  g.vtx = vrx - g.vn * g.nx + wr * g.ny;
  g.vty = vry - g.vn * g.ny - wr * g.nx;
  return g;
}

// Normal force magnitude along n (positive = repulsive): s (K_n delta - m_eff gamma_n v_n).
template <class V>
[[gnu::always_inline]] inline V NormalPart(V s, V delta, V m_eff, V v_n, const LawConstants<V>& c) {
  const V fn = s * (c.kn * delta - m_eff * c.gamma_n * v_n);
  return c.clip_normal ? Select(fn < V(0.0), V(0.0), fn) : fn;
}

// Result of the tangential law for one 2-D contact: force on body i (world frame) and the
// new shear displacement vector (history).
template <class V>
struct Tangential {
  V fx, fy, sx, sy;
};

// Tangential force with history. (sx, sy) is the stored shear displacement, s the model's
// scale, fn the normal force, `need` the entries whose result is used (a lane type skips the
// slip rescale where none of them slips). Steps, in LAMMPS' order: xi += v_t dt; project xi
// onto the tangent line; F_t = -s (K_t xi + m_eff gamma_t v_t); cap at mu |F_n|. Both sides
// of a cap are computed, then selected: a selected value is computed by the same operations
// as in a branch. Quantities of the side not taken may be inf or NaN.
template <bool kLiggghtsCap, class V, class M>
[[gnu::always_inline]] inline Tangential<V> TangentialPart(V sx, V sy, const ContactGeometry<V>& g, V s, V m_eff, V fn,
                                                           M need, const LawConstants<V>& c) {
  const V nx = g.nx, ny = g.ny, vtx = g.vtx, vty = g.vty;
  sx = sx + vtx * c.dt;
  sy = sy + vty * c.dt;
  const V shrmag2 = sx * sx + sy * sy;  // |xi| before the projection (LAMMPS' shrmag)
  const V rsht = sx * nx + sy * ny;
  sx = sx - rsht * nx;
  sy = sy - rsht * ny;
  const V cap = c.mu * Abs(fn);
  Tangential<V> t;
  if constexpr (!kLiggghtsCap) {
    const V damp_x = m_eff * c.gamma_t * vtx;
    const V damp_y = m_eff * c.gamma_t * vty;
    const V fx = -s * (c.kt * sx + damp_x);
    const V fy = -s * (c.kt * sy + damp_y);
    const V fs2 = fx * fx + fy * fy;
    const M slip = fs2 > cap * cap;
    t = {fx, fy, sx, sy};
    if (NeedAny(slip & need)) {                      // rare: an entry slips
      const M rescale = slip & (shrmag2 != V(0.0));  // no history to rescale: F_t = 0
      const V ratio = cap / Sqrt(fs2);
      // Rescale xi so that spring + damping give exactly the capped force (LAMMPS).
      const V kx = damp_x / c.kt, ky = damp_y / c.kt;
      t.sx = Select(rescale, ratio * (sx + kx) - kx, sx);
      t.sy = Select(rescale, ratio * (sy + ky) - ky, sy);
      t.fx = Select(slip, Select(rescale, fx * ratio, V(0.0)), fx);
      t.fy = Select(slip, Select(rescale, fy * ratio, V(0.0)), fy);
    }
  } else {
    // LIGGGHTS 3.8 tangential_model_history: compare only the spring part with mu|F_n|;
    // when it slips, F_t is the capped spring force without damping and xi = -F_t / k_t_eff.
    const V kt_eff = s * c.kt;
    const V gt_eff = s * m_eff * c.gamma_t;
    const V spx = -kt_eff * sx;
    const V spy = -kt_eff * sy;
    const V spring2 = spx * spx + spy * spy;
    const M slip = spring2 > cap * cap;
    t = {spx - gt_eff * vtx, spy - gt_eff * vty, sx, sy};
    if (NeedAny(slip & need)) {
      const V ratio = cap / Sqrt(spring2);
      const V cfx = spx * ratio, cfy = spy * ratio;
      t.fx = Select(slip, cfx, t.fx);
      t.fy = Select(slip, cfy, t.fy);
      const M reset = slip & (kt_eff > V(0.0));
      t.sx = Select(reset, -cfx / kt_eff, sx);
      t.sy = Select(reset, -cfy / kt_eff, sy);
    }
  }
  return t;
}

// The force of one contact: new history (sx, sy), force on i (fx, fy) and the tangential
// couple c = n x F_t (the torque on i is -r_i c).
template <class V>
struct ContactForce {
  V sx, sy, fx, fy, c;
};

template <class Normal, bool kLiggghtsCap, class V, class M>
[[gnu::always_inline]] inline ContactForce<V> ContactLaw(const ContactGeometry<V>& g, V r_eff, V m_eff, V sx, V sy,
                                                         M need, const LawConstants<V>& c) {
  const V s = Normal::Scale(g.delta, r_eff);
  const V fn = NormalPart(s, g.delta, m_eff, g.vn, c);
  const Tangential<V> t = TangentialPart<kLiggghtsCap>(sx, sy, g, s, m_eff, fn, need, c);
  return {t.sx, t.sy, fn * g.nx + t.fx, fn * g.ny + t.fy, g.nx * t.fy - g.ny * t.fx};
}

// The fields of a disc record (World::DiscKin) the law reads, one disc per lane.
template <class V>
struct DiscState {
  V x, y, vx, vy, r, w;
};

// One pair-list entry (a lane type: one per lane) from the two discs' records: its new
// history and force (on i) and couple into the entry's slots at sx..c; zeros where the
// discs do not touch (the history resets). r_eff and m_eff are the entry's.
template <class Normal, bool kLiggghtsCap, class V>
[[gnu::always_inline]] inline void PairEntry(const DiscState<V>& a, const DiscState<V>& b, const double* r_eff,
                                             const double* m_eff, double* sx, double* sy, double* fx, double* fy,
                                             double* c, const LawConstants<V>& law) {
  const V ddx = a.x - b.x, ddy = a.y - b.y;
  const V rsq = ddx * ddx + ddy * ddy;
  const V radsum = a.r + b.r;
  const auto touch = rsq < radsum * radsum;
  const V zero(0.0);
  if (!NeedAny(touch)) {  // nothing touches: every output is zero (as the selects give)
    Store(sx, zero);
    Store(sy, zero);
    Store(fx, zero);
    Store(fy, zero);
    Store(c, zero);
    return;
  }
  const ContactGeometry<V> g = Geometry(ddx, ddy, rsq, radsum, a.vx - b.vx, a.vy - b.vy, a.r * a.w + b.r * b.w);
  const ContactForce<V> f =
      ContactLaw<Normal, kLiggghtsCap>(g, Load<V>(r_eff), Load<V>(m_eff), Load<V>(sx), Load<V>(sy), touch, law);
  Store(sx, Select(touch, f.sx, zero));
  Store(sy, Select(touch, f.sy, zero));
  Store(fx, Select(touch, f.fx, zero));
  Store(fy, Select(touch, f.fy, zero));
  Store(c, Select(touch, f.c, zero));
}

// Scalar entry points (tests, tools): the law of p for one contact.
inline double NormalForce(double delta, double r_eff, double m_eff, double v_n, const ContactParams& p) {
  const LawConstants<double> c(p, 0.0);
  return WithContactLaw(
      p, [&](auto model, auto) { return NormalPart(decltype(model)::Scale(delta, r_eff), delta, m_eff, v_n, c); });
}
inline Tangential<double> TangentialForce(double sx, double sy, double nx, double ny, double vtx, double vty,
                                          double delta, double r_eff, double m_eff, double fn, double dt,
                                          const ContactParams& p) {
  const LawConstants<double> c(p, dt);
  ContactGeometry<double> g{nx, ny, delta, 0.0, vtx, vty};
  return WithContactLaw(p, [&](auto model, auto cap) {
    return TangentialPart<decltype(cap)::value>(sx, sy, g, decltype(model)::Scale(delta, r_eff), m_eff, fn, true, c);
  });
}

// Duration of an undamped Hertz collision F = k delta^1.5 with k = K_n sqrt(R_eff) at impact
// speed v0: delta_max = (5 m v0^2 / (4 k))^(2/5) and t_c = 2.9432 delta_max / v0 (closed form).
// Used to recommend dt (t_c / 50, as MercuryDPM suggests).
inline double HertzCollisionTime(double m_eff, double r_eff, double v0, double kn) {
  const double k = kn * std::sqrt(r_eff);
  const double delta_max = std::pow(1.25 * m_eff * v0 * v0 / k, 0.4);
  return 2.9432 * delta_max / v0;
}

}  // namespace granary::engine
