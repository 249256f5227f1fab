// The contact law as pure functions (docs/model.md "Contact law"): Hertz normal force with
// velocity damping and a tangential spring with history, capped by Coulomb friction.
// The convention is LAMMPS pair gran/hertz/history (dampflag 1) with BODY masses in m_eff;
// the LIGGGHTS 3.8 cap (only the spring part is capped) is selectable (docs/liggghts.md).
// Inputs are scalars in reduced units; no state; geometry is computed separately.
#pragma once

#include <cmath>

namespace granary::engine {

struct ContactParams {
  double kn = 2.0e6;
  double kt = 2.45e6;
  double gamma_n = 1000.0;
  double gamma_t = 1000.0;
  double mu = 0.5;
  bool liggghts_cap = false;  // false: LAMMPS caps spring + damping; true: LIGGGHTS caps the spring only
  bool clip_normal = false;   // clip an attractive normal force to zero
};

// Effective radius of two discs (docs/model.md): r_i r_j / (r_i + r_j). A wall is r_j = infinity.
inline double EffectiveRadius(double ri, double rj) { return ri * rj / (ri + rj); }
// Effective mass of two bodies: M_I M_J / (M_I + M_J). A wall or obstacle: M_I.
inline double EffectiveMass(double mi, double mj) { return mi * mj / (mi + mj); }

// Normal force magnitude along n (positive = repulsive):
// F_n = sqrt(R_eff delta) (K_n delta - m_eff gamma_n v_n), v_n = (v_i - v_j).n (docs/model.md).
inline double NormalForce(double delta, double r_eff, double m_eff, double v_n, const ContactParams& p) {
  const double h = std::sqrt(r_eff * delta);
  const double fn = h * (p.kn * delta - m_eff * p.gamma_n * v_n);
  return p.clip_normal && fn < 0.0 ? 0.0 : fn;
}

// Result of the tangential law for one 2-D contact: force on body i (world frame) and the
// new shear displacement vector (history).
struct Tangential {
  double fx = 0.0, fy = 0.0;
  double sx = 0.0, sy = 0.0;
};

// Tangential force with history. (sx, sy) is the stored shear displacement, (nx, ny) the
// current unit normal from j to i, (vtx, vty) the tangential relative velocity at the
// contact point, fn the normal force. Steps, in LAMMPS' order: xi += v_t dt; project xi
// onto the tangent line; F_t = -h (K_t xi + m_eff gamma_t v_t); cap at mu |F_n|.
//
// Written without branches (both sides computed, then selected) so that the pair loop
// vectorizes; a selected value is computed by the same operations as in a branch, so the
// result is the same to the bit. Quantities of the side not taken may be inf or NaN.
template <bool kLiggghtsCap>
inline Tangential TangentialForceT(double sx, double sy, double nx, double ny, double vtx, double vty,
                                   double delta, double r_eff, double m_eff, double fn, double dt,
                                   const ContactParams& p) {
  const double h = std::sqrt(r_eff * delta);
  sx += vtx * dt;
  sy += vty * dt;
  const double shrmag2 = sx * sx + sy * sy;  // |xi| before the projection (LAMMPS' shrmag)
  const double rsht = sx * nx + sy * ny;
  sx -= rsht * nx;
  sy -= rsht * ny;
  const double cap = p.mu * std::fabs(fn);
  const double damp_x = m_eff * p.gamma_t * vtx;
  const double damp_y = m_eff * p.gamma_t * vty;
  Tangential t;
  if constexpr (!kLiggghtsCap) {
    const double fx = -h * (p.kt * sx + damp_x);
    const double fy = -h * (p.kt * sy + damp_y);
    const double fs2 = fx * fx + fy * fy;
    const bool slip = fs2 > cap * cap;
    const bool rescale = slip && shrmag2 != 0.0;  // no history to rescale: F_t = 0
    const double ratio = cap / std::sqrt(fs2);
    // Rescale xi so that spring + damping give exactly the capped force (LAMMPS).
    const double kx = damp_x / p.kt, ky = damp_y / p.kt;
    t.sx = rescale ? ratio * (sx + kx) - kx : sx;
    t.sy = rescale ? ratio * (sy + ky) - ky : sy;
    t.fx = slip ? (rescale ? fx * ratio : 0.0) : fx;
    t.fy = slip ? (rescale ? fy * ratio : 0.0) : fy;
  } else {
    // LIGGGHTS 3.8 tangential_model_history: compare only the spring part with mu|F_n|;
    // when it slips, F_t is the capped spring force without damping and xi = -F_t / k_t_eff.
    const double kt_eff = h * p.kt;
    const double gt_eff = h * m_eff * p.gamma_t;
    const double spx = -kt_eff * sx;
    const double spy = -kt_eff * sy;
    const double spring2 = spx * spx + spy * spy;
    const bool slip = spring2 > cap * cap;
    const double ratio = cap / std::sqrt(spring2);
    const double cfx = spx * ratio, cfy = spy * ratio;
    t.fx = slip ? cfx : spx - gt_eff * vtx;
    t.fy = slip ? cfy : spy - gt_eff * vty;
    const bool reset = slip && kt_eff > 0.0;
    t.sx = reset ? -cfx / kt_eff : sx;
    t.sy = reset ? -cfy / kt_eff : sy;
  }
  return t;
}

inline Tangential TangentialForce(double sx, double sy, double nx, double ny, double vtx, double vty,
                                  double delta, double r_eff, double m_eff, double fn, double dt,
                                  const ContactParams& p) {
  return p.liggghts_cap ? TangentialForceT<true>(sx, sy, nx, ny, vtx, vty, delta, r_eff, m_eff, fn, dt, p)
                        : TangentialForceT<false>(sx, sy, nx, ny, vtx, vty, delta, r_eff, m_eff, fn, dt, p);
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
