// Forces, neighbour lists and the velocity-Verlet step of the rigid-clump DEM (docs/model.md).
#include "engine/world.h"

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>

#include "engine/avx512_kernels.h"
#include "engine/pair_entries.h"

namespace granary::engine {

// The step's kernels are compiled for x86-64-v4 (AVX-512: 32 vector registers), v3
// (AVX2) and the baseline, and the loader picks the best the CPU has. Floating-point
// contraction is off for the engine (CMakeLists.txt), so the three give the same bits.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(GRANARY_NO_KERNEL_CLONES)
#define GRANARY_KERNEL __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
#else
#define GRANARY_KERNEL
#endif

WorldParams ParamsFromSpec(const RunSpec& spec) {
  WorldParams p;
  p.dt = spec.time_step;
  p.gravity = spec.gravity;
  ContactParams c;
  c.kn = spec.contact.kn;
  c.kt = spec.contact.kt;
  c.gamma_n = spec.contact.gamma_n;
  c.gamma_t = spec.contact.gamma_t;
  c.mu = spec.contact.mu;
  c.normal_model = spec.contact.normal_model;
  c.liggghts_cap = spec.contact.tangential_cap == TangentialCap::kLiggghts;
  c.clip_normal = spec.contact.clip_normal;
  p.pair = c;
  p.wall = c;
  p.wall.mu = spec.contact.mu_wall;
  return p;
}

World::World(WorldParams params, std::vector<silo::ShapeTemplate> templates, silo::SiloGeometry geometry)
    : params_(params), templates_(std::move(templates)), geometry_(std::move(geometry)),
      use_avx512_(params_.avx512_kernels && Avx512Available()) {
  for (const silo::ShapeTemplate& t : templates_)
    for (double r : t.r) max_radius_ = std::max(max_radius_, r);
}

int World::AddBody(int tmpl, double x, double y, double theta) {
  if (tmpl < 0 || tmpl >= static_cast<int>(templates_.size()))
    throw std::invalid_argument("World::AddBody: no shape template " + std::to_string(tmpl));
  const silo::ShapeTemplate& t = templates_[static_cast<std::size_t>(tmpl)];
  const int id = BodyCount();
  tmpl_.push_back(tmpl);
  active_.push_back(1);
  bx_.push_back(x);
  by_.push_back(y);
  bth_.push_back(theta);
  bc_.push_back(std::cos(theta));
  bs_.push_back(std::sin(theta));
  bvx_.push_back(0);
  bvy_.push_back(0);
  bw_.push_back(0);
  bfx_.push_back(0);
  bfy_.push_back(0);
  btq_.push_back(0);
  bmass_.push_back(t.mass);
  binertia_.push_back(t.inertia);
  binv_mass_.push_back(1.0 / t.mass);
  binv_inertia_.push_back(1.0 / t.inertia);
  disc_begin_.push_back(DiscCount());
  disc_n_.push_back(static_cast<int>(t.r.size()));
  double reach = 0.0;
  for (std::size_t k = 0; k < t.r.size(); ++k) reach = std::max(reach, std::hypot(t.ox[k], t.oy[k]));
  bradius_.push_back(reach);
  const int n = static_cast<int>(t.r.size());
  uniform_discs_ = id == 0 || uniform_discs_ == n ? n : -1;
  max_discs_ = std::max(max_discs_, n);
  for (std::size_t k = 0; k < t.r.size(); ++k) {
    dbody_.push_back(id);
    dr_.push_back(t.r[k]);
    dmass_.push_back(t.disc_mass[k]);
    dox_.push_back(t.ox[k]);
    doy_.push_back(t.oy[k]);
    dx_.push_back(0);
    dy_.push_back(0);
    kin_.push_back({0.0, 0.0, 0.0, 0.0, t.r[k], 0.0});
    dfx_.push_back(0);
    dfy_.push_back(0);
    dtz_.push_back(0);
    refx_.push_back(0);
    refy_.push_back(0);
  }
  ++active_count_;
  UpdateDiscs(id);
  rebuild_needed_ = true;
  return id;
}

void World::SetVelocity(int b, double vx, double vy, double omega) {
  bvx_[b] = vx;
  bvy_[b] = vy;
  bw_[b] = omega;
  UpdateDiscs(b);
  // The rebuild decision for the next step assumed the old velocity (Step).
  rebuild_needed_ = true;
}

void World::PlaceBody(int b, double x, double y, double theta, double vx, double vy, double omega) {
  if (!active_[b]) {
    active_[b] = 1;
    ++active_count_;
  }
  bx_[b] = x;
  by_[b] = y;
  bth_[b] = theta;
  bc_[b] = std::cos(theta);
  bs_[b] = std::sin(theta);
  bvx_[b] = vx;
  bvy_[b] = vy;
  bw_[b] = omega;
  // A body is placed where it touches nothing: its force until the next step is gravity.
  bfx_[b] = 0.0;
  bfy_[b] = -bmass_[b] * params_.gravity;
  btq_[b] = 0.0;
  UpdateDiscs(b);
  rebuild_needed_ = true;
}

int World::ActiveDiscCount() const {
  int n = 0;
  for (std::size_t b = 0; b < active_.size(); ++b)
    if (active_[b]) n += disc_n_[b];
  return n;
}

void World::Deactivate(int b) {
  if (!active_[b]) return;
  active_[b] = 0;
  --active_count_;
  bfx_[b] = bfy_[b] = btq_[b] = 0;
  rebuild_needed_ = true;
}

void World::OpenOutlets() {
  outlets_open_ = true;
  rebuild_needed_ = true;
}

void World::CloseOutlets() {
  outlets_open_ = false;
  rebuild_needed_ = true;
}

bool World::ElementActive(const silo::WallElement& e) const {
  switch (e.group) {
    case silo::WallGroup::kAlways: return true;
    case silo::WallGroup::kPlug: return !outlets_open_;
    case silo::WallGroup::kOpen: return outlets_open_;
  }
  return true;
}

void World::UpdateDiscs(int b) {
  const double x = bx_[b], y = by_[b], c = bc_[b], s = bs_[b], vx = bvx_[b], vy = bvy_[b], w = bw_[b];
  const int d0 = disc_begin_[b], d1 = d0 + disc_n_[b];
  for (int d = d0; d < d1; ++d) {  // (the step does this in DriftBodies, the same way)
    const double wx = c * dox_[d] - s * doy_[d];
    const double wy = s * dox_[d] + c * doy_[d];
    const double px = x + wx, py = y + wy;
    dx_[d] = px;
    dy_[d] = py;
    DiscKin& k = kin_[d];
    k.x = px;
    k.y = py;
    k.vx = vx - w * wy;
    k.vy = vy + w * wx;
    k.w = w;
  }
}

void World::RefreshDiscs() {
  for (int b = 0; b < BodyCount(); ++b) UpdateDiscs(b);
}

bool World::NeedsRebuild() const {
  const int n = DiscCount();
  const double limit = 0.25 * params_.skin * params_.skin;
  double worst = 0.0;
#pragma omp parallel for schedule(static) reduction(max : worst) if (Parallel())
  for (int i = 0; i < n; ++i) {
    if (!active_[dbody_[i]]) continue;
    const double ddx = dx_[i] - refx_[i], ddy = dy_[i] - refy_[i];
    worst = std::max(worst, ddx * ddx + ddy * ddy);
  }
  return worst > limit;
}

void World::RebuildNow() { Rebuild(); }

void World::Rebuild() {
  ++rebuilds_;
  rebuild_needed_ = false;
  const int n = DiscCount();
  old_start_.swap(nl_start_);
  old_j_.swap(nl_j_);
  old_sx_.swap(nl_sx_);
  old_sy_.swap(nl_sy_);
  old_wstart_.swap(wl_start_);
  old_we_.swap(wl_e_);
  old_wsx_.swap(wl_sx_);
  old_wsy_.swap(wl_sy_);
  const int old_n = old_start_.empty() ? 0 : static_cast<int>(old_start_.size()) - 1;
  const int old_wn = old_wstart_.empty() ? 0 : static_cast<int>(old_wstart_.size()) - 1;

  // Cell grid over the bounding box of the active discs.
  double xmin = 1e300, xmax = -1e300, ymin = 1e300, ymax = -1e300;
  for (int i = 0; i < n; ++i) {
    if (!active_[dbody_[i]]) continue;
    xmin = std::min(xmin, dx_[i]);
    xmax = std::max(xmax, dx_[i]);
    ymin = std::min(ymin, dy_[i]);
    ymax = std::max(ymax, dy_[i]);
  }
  if (xmin > xmax) xmin = xmax = ymin = ymax = 0.0;
  double cell = 2.0 * max_radius_ + params_.skin;
  long ncx = 0, ncy = 0;
  for (;;) {
    ncx = static_cast<long>((xmax - xmin) / cell) + 1;
    ncy = static_cast<long>((ymax - ymin) / cell) + 1;
    if (ncx * ncy <= 4L * n + 1024) break;
    cell *= 1.5;  // a far-away body must not blow up the grid
  }
  const int ncells = static_cast<int>(ncx * ncy);
  cell_count_.assign(static_cast<std::size_t>(ncells), 0);
  disc_cell_.resize(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    if (!active_[dbody_[i]]) {
      disc_cell_[i] = -1;
      continue;
    }
    const long cx = std::min(ncx - 1, static_cast<long>((dx_[i] - xmin) / cell));
    const long cy = std::min(ncy - 1, static_cast<long>((dy_[i] - ymin) / cell));
    disc_cell_[i] = static_cast<int>(cx + ncx * cy);
    ++cell_count_[disc_cell_[i]];
  }
  cell_start_.resize(static_cast<std::size_t>(ncells) + 1);
  cell_start_[0] = 0;
  for (int c = 0; c < ncells; ++c) cell_start_[c + 1] = cell_start_[c] + cell_count_[c];
  cell_disc_.resize(static_cast<std::size_t>(cell_start_[ncells]));
  for (int c = 0; c < ncells; ++c) cell_count_[c] = cell_start_[c];
  for (int i = 0; i < n; ++i)
    if (disc_cell_[i] >= 0) cell_disc_[cell_count_[disc_cell_[i]]++] = i;

  const double skin = params_.skin;
  const int icx = static_cast<int>(ncx), icy = static_cast<int>(ncy);
  // Visits the candidate partners j > i of disc i (different body, within cutoff).
  auto for_neighbours = [&](int i, auto&& visit) {
    const int c = disc_cell_[i];
    if (c < 0) return;
    const int cx = c % icx, cy = c / icx;
    for (int yy = std::max(0, cy - 1); yy <= std::min(icy - 1, cy + 1); ++yy)
      for (int xx = std::max(0, cx - 1); xx <= std::min(icx - 1, cx + 1); ++xx) {
        const int cc = xx + icx * yy;
        for (int k = cell_start_[cc]; k < cell_start_[cc + 1]; ++k) {
          const int j = cell_disc_[k];
          if (j <= i || dbody_[j] == dbody_[i]) continue;
          const double ddx = dx_[i] - dx_[j], ddy = dy_[i] - dy_[j];
          const double cut = dr_[i] + dr_[j] + skin;
          if (ddx * ddx + ddy * ddy < cut * cut) visit(j);
        }
      }
  };
  nl_start_.resize(static_cast<std::size_t>(n) + 1);
  // One cell search per disc: each thread keeps the partners of its discs in a buffer of its
  // own and copies them into place once the offsets are known (both loops are static over
  // the same range, so a thread meets its discs in the same order twice).
  if (rebuild_partners_.size() < static_cast<std::size_t>(omp_get_max_threads()))
    rebuild_partners_.resize(static_cast<std::size_t>(omp_get_max_threads()));
#pragma omp parallel if (Parallel())
  {
    std::vector<int>& found = rebuild_partners_[static_cast<std::size_t>(omp_get_thread_num())];
    found.clear();
#pragma omp for schedule(static)
    for (int i = 0; i < n; ++i) {
      const std::size_t before = found.size();
      for_neighbours(i, [&](int j) { found.push_back(j); });
      nl_start_[i + 1] = static_cast<int>(found.size() - before);
    }
#pragma omp single
    {
      nl_start_[0] = 0;
      std::partial_sum(nl_start_.begin(), nl_start_.end(), nl_start_.begin());  // counts to offsets
      const std::size_t m = static_cast<std::size_t>(nl_start_[n]);
      nl_j_.resize(m);
      nl_i_.resize(m);
      nl_sx_.resize(m);
      nl_sy_.resize(m);
      nl_fx_.assign(m, 0.0);
      nl_fy_.assign(m, 0.0);
      nl_c_.assign(m, 0.0);
      nl_reff_.resize(m);
      nl_meff_.resize(m);
    }
    std::size_t next = 0;  // in `found`
#pragma omp for schedule(static)
    for (int i = 0; i < n; ++i) {
      for (int e = nl_start_[i]; e < nl_start_[i + 1]; ++e) nl_j_[e] = found[next++];
      std::sort(nl_j_.begin() + nl_start_[i], nl_j_.begin() + nl_start_[i + 1]);
      for (int e = nl_start_[i]; e < nl_start_[i + 1]; ++e) {
        const int j = nl_j_[e];
        nl_i_[e] = i;
        nl_reff_[e] = EffectiveRadius(dr_[i], dr_[j]);
        nl_meff_[e] = EffectiveMass(bmass_[dbody_[i]], bmass_[dbody_[j]]);
      }
      // History transfer: both segments are sorted by j.
      int o = i < old_n ? old_start_[i] : 0;
      const int oend = i < old_n ? old_start_[i + 1] : 0;
      for (int e = nl_start_[i]; e < nl_start_[i + 1]; ++e) {
        while (o < oend && old_j_[o] < nl_j_[e]) ++o;
        if (o < oend && old_j_[o] == nl_j_[e]) {
          nl_sx_[e] = old_sx_[o];
          nl_sy_[e] = old_sy_[o];
        } else {
          nl_sx_[e] = 0.0;
          nl_sy_[e] = 0.0;
        }
      }
    }
  }
  // Transpose of the entries that cross into a later force block.
  const int block = params_.force_block;
  const int nblocks = (n + block - 1) / block;
  block_last_partner_.resize(static_cast<std::size_t>(nblocks));
  block_first_source_.resize(static_cast<std::size_t>(nblocks));
  for (int b = 0; b < nblocks; ++b) {
    const int i1 = std::min(n, (b + 1) * block);
    int last = i1 - 1;
    for (int e = nl_start_[b * block]; e < nl_start_[i1]; ++e) last = std::max(last, nl_j_[e]);
    block_last_partner_[b] = last;
    block_first_source_[b] = b;
  }
  xl_start_.assign(static_cast<std::size_t>(n) + 1, 0);
  for (int i = 0; i < n; ++i) {
    const int block_end = (i / block + 1) * block;
    for (int e = nl_start_[i]; e < nl_start_[i + 1]; ++e)
      if (nl_j_[e] >= block_end) {
        ++xl_start_[nl_j_[e] + 1];
        int& first = block_first_source_[nl_j_[e] / block];
        first = std::min(first, i / block);
      }
  }
  std::partial_sum(xl_start_.begin(), xl_start_.end(), xl_start_.begin());
  xl_fill_.assign(xl_start_.begin(), xl_start_.end() - 1);
  xl_entry_.resize(static_cast<std::size_t>(xl_start_[n]));
  for (int i = 0; i < n; ++i) {
    const int block_end = (i / block + 1) * block;
    for (int e = nl_start_[i]; e < nl_start_[i + 1]; ++e)
      if (nl_j_[e] >= block_end) xl_entry_[xl_fill_[nl_j_[e]]++] = e;
  }

  // Wall list: the elements within reach of each disc, counted per disc and then written in
  // place (both loops static over the same range, as the pair list), with the history of the
  // continuing contacts.
  const int ne = static_cast<int>(geometry_.elements.size());
  auto for_walls = [&](int i, auto&& visit) {
    if (!active_[dbody_[i]]) return;
    for (int e = 0; e < ne; ++e) {
      const silo::WallElement& el = geometry_.elements[e];
      if (!ElementActive(el)) continue;
      double reach = dr_[i] + skin;
      double qx, qy;
      if (el.kind == silo::ElementKind::kSegment) {
        // Keep segments whose line is within reach, even if the foot is just outside the
        // segment now: the disc may slide onto it before the next rebuild.
        const double sx = el.bx - el.ax, sy = el.by - el.ay;
        const double len2 = sx * sx + sy * sy;
        const double t = std::clamp(((dx_[i] - el.ax) * sx + (dy_[i] - el.ay) * sy) / len2, 0.0, 1.0);
        qx = el.ax + t * sx;
        qy = el.ay + t * sy;
      } else {
        qx = el.ax;
        qy = el.ay;
        reach += el.radius;
      }
      const double ddx = dx_[i] - qx, ddy = dy_[i] - qy;
      if (ddx * ddx + ddy * ddy < reach * reach) visit(e);
    }
  };
  wl_start_.resize(static_cast<std::size_t>(n) + 1);
#pragma omp parallel if (Parallel())
  {
#pragma omp for schedule(static)
    for (int i = 0; i < n; ++i) {
      int count = 0;
      for_walls(i, [&](int) { ++count; });
      wl_start_[i + 1] = count;
      refx_[i] = dx_[i];
      refy_[i] = dy_[i];
    }
#pragma omp single
    {
      wl_start_[0] = 0;
      std::partial_sum(wl_start_.begin(), wl_start_.end(), wl_start_.begin());
      const std::size_t m = static_cast<std::size_t>(wl_start_[n]);
      wl_e_.resize(m);
      wl_i_.resize(m);
      wl_sx_.resize(m);
      wl_sy_.resize(m);
      wl_fx_.assign(m, 0.0);
      wl_fy_.assign(m, 0.0);
    }
#pragma omp for schedule(static)
    for (int i = 0; i < n; ++i) {
      int k = wl_start_[i];
      int o = i < old_wn ? old_wstart_[i] : 0;
      const int oend = i < old_wn ? old_wstart_[i + 1] : 0;
      for_walls(i, [&](int e) {
        while (o < oend && old_we_[o] < e) ++o;
        const bool had = o < oend && old_we_[o] == e;
        wl_e_[k] = e;
        wl_i_[k] = i;
        wl_sx_[k] = had ? old_wsx_[o] : 0.0;
        wl_sy_[k] = had ? old_wsy_[o] : 0.0;
        ++k;
      });
    }
  }
}

void World::ComputeForces() { Forces(rebuild_needed_ || NeedsRebuild(), false); }

namespace {

// Step 2 of SumPartForces: sums per disc in list order and reactions inside the block, for
// the block's discs [i0, i1). A part of a block after its start first takes the reactions
// of the entries from the block's earlier discs into it (`earlier`, ascending: the order in
// which the whole block's loop adds them), then continues as that loop, so a block summed
// in parts gives the bits of a block summed at once. An entry that does not touch adds
// +0.0, which leaves every sum as it was (they start at +0.0 and so are never -0.0). A
// function of its own, not inlined: inside the block's function the loop keeps its pointers
// on the stack, which costs (docs/benchmarks.md). Scalar, so no instruction-set variants.
[[gnu::noinline]] void SumBlock(int i0, int i1, const int* __restrict earlier, int n_earlier,
                                const int* __restrict nl_start, const int* __restrict nl_j,
                                const double* __restrict nl_fx, const double* __restrict nl_fy,
                                const double* __restrict nl_c, const double* __restrict dr, double* __restrict dfx,
                                double* __restrict dfy, double* __restrict dtz) {
  for (int i = i0; i < i1; ++i) dfx[i] = dfy[i] = dtz[i] = 0.0;
  for (int k = 0; k < n_earlier; ++k) {
    const int e = earlier[k], j = nl_j[e];
    dfx[j] -= nl_fx[e];
    dfy[j] -= nl_fy[e];
    dtz[j] += nl_c[e];
  }
  for (int i = i0; i < i1; ++i) {
    double sfx = 0.0, sfy = 0.0, sc = 0.0;
    const int e1 = nl_start[i + 1];
    for (int e = nl_start[i]; e < e1; ++e) {
      const int j = nl_j[e];
      const double fx = nl_fx[e], fy = nl_fy[e], c = nl_c[e];
      sfx += fx;
      sfy += fy;
      sc += c;
      if (j < i1) {
        dfx[j] -= fx;
        dfy[j] -= fy;
        dtz[j] += c;  // n x F_t is the same seen from j (both n and F_t flip)
      }
    }
    // Every reaction from this block has arrived (they come from lower i).
    dfx[i] += sfx;
    dfy[i] += sfy;
    dtz[i] = -dr[i] * (dtz[i] + sc);  // torque of tangential forces at the contact point -r n (LAMMPS)
  }
}

}  // namespace

// Eight entries at a time by the AVX-512 loop where the CPU has it, the rest (or all) by the
// portable loop; both give the same bits. (Inlined into PairEntriesOf's instruction-set variants.)
template <class Normal, bool kLiggghtsCap>
[[gnu::always_inline]] inline void World::PairRange(int e0, int e1) {
  const ContactParams& pp = params_.pair;
  const int e = use_avx512_ ? PairEntriesAvx512(e0, e1, nl_i_.data(), nl_j_.data(), nl_reff_.data(), nl_meff_.data(),
                                                nl_sx_.data(), nl_sy_.data(), nl_fx_.data(), nl_fy_.data(),
                                                nl_c_.data(), kin_.data(), pp, params_.dt)
                            : e0;
  PairEntries<Normal, kLiggghtsCap>(e, e1, nl_i_.data(), nl_j_.data(), nl_reff_.data(), nl_meff_.data(),
                                    nl_sx_.data(), nl_sy_.data(), nl_fx_.data(), nl_fy_.data(), nl_c_.data(),
                                    kin_.data(), pp, params_.dt);
}

GRANARY_KERNEL void World::PairEntriesOf(int i0, int i1) {
  WithContactLaw(params_.pair, [&](auto model, auto cap) __attribute__((always_inline)) {
    PairRange<decltype(model), decltype(cap)::value>(nl_start_[i0], nl_start_[i1]);
  });
}

// The wall entries [k0, k1) of a force block: the contact kernel with the closest point of
// the element as the partner (radius el.radius, at rest, infinite mass).
template <class Normal, bool kLiggghtsCap>
[[gnu::always_inline]] inline void World::WallEntries(int k0, int k1, const ContactParams& wp) {
  const LawConstants<double> law(wp, params_.dt);
  double* __restrict dfx = dfx_.data();
  double* __restrict dfy = dfy_.data();
  double* __restrict dtz = dtz_.data();
  for (int k = k0; k < k1; ++k) {
    const int i = wl_i_[k];
    const DiscKin& a = kin_[i];
    const silo::WallElement& el = geometry_.elements[wl_e_[k]];
    const silo::Closest q = silo::ClosestPoint(el, a.x, a.y);
    const double ddx = a.x - q.qx, ddy = a.y - q.qy;
    const double rsq = ddx * ddx + ddy * ddy;
    const double reach = a.r + el.radius;
    if (!q.valid || rsq >= reach * reach || rsq == 0.0) {
      wl_sx_[k] = wl_sy_[k] = wl_fx_[k] = wl_fy_[k] = 0.0;
      continue;
    }
    const ContactGeometry<double> g = Geometry(ddx, ddy, rsq, reach, a.vx, a.vy, a.r * a.w);
    const double reff = el.kind == silo::ElementKind::kCircle ? EffectiveRadius(a.r, el.radius) : a.r;
    const double meff = bmass_[dbody_[i]];
    const ContactForce<double> f =
        ContactLaw<Normal, kLiggghtsCap>(g, reff, meff, wl_sx_[k], wl_sy_[k], true, law);
    wl_sx_[k] = f.sx;
    wl_sy_[k] = f.sy;
    wl_fx_[k] = f.fx;
    wl_fy_[k] = f.fy;
    dfx[i] += f.fx;
    dfy[i] += f.fy;
    dtz[i] -= a.r * f.c;
  }
}

GRANARY_KERNEL void World::SumPartForces(int i0, int i1, const std::vector<int>& earlier) {
  const ContactParams wp = params_.wall;
  double* __restrict dfx = dfx_.data();
  double* __restrict dfy = dfy_.data();
  double* __restrict dtz = dtz_.data();
  // 2. Sums per disc and reactions inside the block.
  SumBlock(i0, i1, earlier.data(), static_cast<int>(earlier.size()), nl_start_.data(), nl_j_.data(), nl_fx_.data(),
           nl_fy_.data(), nl_c_.data(), dr_.data(), dfx, dfy, dtz);
  // 3. Wall contacts, added after each disc's pair sums as before, but in a loop of their
  // own over the block's few wall entries: the pair-sum loop above stays small (no disc
  // record, no wall state in registers).
  WithContactLaw(wp, [&](auto model, auto cap) __attribute__((always_inline)) {
    WallEntries<decltype(model), decltype(cap)::value>(wl_start_[i0], wl_start_[i1], wp);
  });
}

namespace {

// Whether the next drift may take a disc of a body farther than `limit` (half the skin)
// from its position at the last rebuild, `moved` away now: the drift moves the body by
// dt v' and turns it by dt w', v' and w' the velocities after its half kick (computed as
// DriftKernel does), so a disc ends within dt |v'| + |dt w'| R of where it is (R: the
// farthest disc centre from the body centre); 1e-9 d covers the rounding.
[[gnu::always_inline]] inline bool OutrunsSkin(double vx, double vy, double w, double fx, double fy, double tq,
                                               double inv_mass, double inv_inertia, double radius, double moved2,
                                               double half, double dt, double limit) {
  const double nvx = vx + half * fx * inv_mass;
  const double nvy = vy + half * fy * inv_mass;
  const double nw = w + half * tq * inv_inertia;
  const double reach = limit - (dt * std::sqrt(nvx * nvx + nvy * nvy) + std::fabs(dt * nw) * radius + 1e-9);
  return (reach <= 0.0) | (moved2 > reach * reach);
}

// Body sums of BodyForces for bodies [b0, b1) of kDiscs discs each, disc k of body b being
// kDiscs b + k: a straight loop over the bodies (it vectorizes), the same arithmetic as the
// general loop. An inactive body's discs have no contacts, so its sums are +0.0, the
// values Deactivate left; it gets no gravity, and its velocity is kept (select). Returns
// whether an active body OutrunsSkin.
template <int kDiscs, bool kKick>
[[gnu::always_inline]] inline bool BodySums(int b0, int b1, double g, double half, double dt, double limit,
                                            const std::uint8_t* __restrict active, const double* __restrict dfx,
                                            const double* __restrict dfy, const double* __restrict dtz,
                                            const double* __restrict dx, const double* __restrict dy,
                                            const double* __restrict refx, const double* __restrict refy,
                                            const double* __restrict bx, const double* __restrict by,
                                            const double* __restrict bmass, const double* __restrict binv_mass,
                                            const double* __restrict binv_inertia, const double* __restrict bradius,
                                            double* __restrict bfx_out, double* __restrict bfy_out,
                                            double* __restrict btq_out, double* __restrict bvx,
                                            double* __restrict bvy, double* __restrict bw) {
  int outrun = 0;
#pragma GCC ivdep  // each iteration reads its body's discs and writes its body only
  for (int b = b0; b < b1; ++b) {
    const bool on = active[b] != 0;
    double bfx = 0, bfy = 0, btq = 0, moved2 = 0;
    const double cx = bx[b], cy = by[b];
    const std::size_t i0 = static_cast<std::size_t>(kDiscs) * static_cast<std::size_t>(b);
    if constexpr (kDiscs == 1) {
      // A disc body's disc sits at its centre (offset +0.0, so dx == bx exactly): the lever
      // arms are +0.0 and the general sum below reduces to these, bit for bit (0.0 + -0.0
      // is +0.0 either way), without reading the disc positions.
      bfx += dfx[i0];
      bfy += dfy[i0];
      btq += dtz[i0];
      const double mx = cx - refx[i0], my = cy - refy[i0];
      moved2 = std::max(moved2, mx * mx + my * my);
    } else {
#pragma GCC unroll 8
      for (int k = 0; k < kDiscs; ++k) {
        const std::size_t i = i0 + static_cast<std::size_t>(k);
        bfx += dfx[i];
        bfy += dfy[i];
        btq += (dx[i] - cx) * dfy[i] - (dy[i] - cy) * dfx[i] + dtz[i];
        const double mx = dx[i] - refx[i], my = dy[i] - refy[i];
        moved2 = std::max(moved2, mx * mx + my * my);
      }
    }
    bfy = bfy - bmass[b] * (on ? g : 0.0);
    bfx_out[b] = bfx;
    bfy_out[b] = bfy;
    btq_out[b] = btq;
    double vx = bvx[b], vy = bvy[b], w = bw[b];
    if constexpr (kKick) {  // the second half kick of the step
      vx = on ? vx + half * bfx * binv_mass[b] : vx;
      vy = on ? vy + half * bfy * binv_mass[b] : vy;
      w = on ? w + half * btq * binv_inertia[b] : w;
      bvx[b] = vx;
      bvy[b] = vy;
      bw[b] = w;
    }
    outrun |= on & OutrunsSkin(vx, vy, w, bfx, bfy, btq, binv_mass[b], binv_inertia[b], bradius[b], moved2, half, dt,
                               limit);
  }
  return outrun != 0;
}

// BodySums for bodies of one or two discs (mixtures of discs and dumbbells): a body's
// second disc is read at its first disc's index + 1, or again at its first when it has
// none, and added only if it exists (a select: 0.0 + x is not always x), so the loop has no
// branches and vectorizes (gathers); the same arithmetic as the general loop.
template <bool kKick>
[[gnu::always_inline]] inline bool BodySumsUpTo2(int b0, int b1, double g, double half, double dt, double limit,
                                                 const std::uint8_t* __restrict active,
                                                 const int* __restrict disc_begin, const int* __restrict disc_n,
                                                 const double* __restrict dfx, const double* __restrict dfy,
                                                 const double* __restrict dtz, const double* __restrict dx,
                                                 const double* __restrict dy, const double* __restrict refx,
                                                 const double* __restrict refy, const double* __restrict bx,
                                                 const double* __restrict by, const double* __restrict bmass,
                                                 const double* __restrict binv_mass,
                                                 const double* __restrict binv_inertia,
                                                 const double* __restrict bradius, double* __restrict bfx_out,
                                                 double* __restrict bfy_out, double* __restrict btq_out,
                                                 double* __restrict bvx, double* __restrict bvy,
                                                 double* __restrict bw) {
  int outrun = 0;
#pragma GCC ivdep  // each iteration reads its body's discs and writes its body only
  for (int b = b0; b < b1; ++b) {
    const bool on = active[b] != 0;
    const double cx = bx[b], cy = by[b];
    const int i = disc_begin[b];
    const bool two = disc_n[b] > 1;
    const int j = two ? i + 1 : i;
    double bfx = 0.0 + dfx[i], bfy = 0.0 + dfy[i];
    double btq = 0.0 + ((dx[i] - cx) * dfy[i] - (dy[i] - cy) * dfx[i] + dtz[i]);
    const double mx = dx[i] - refx[i], my = dy[i] - refy[i];
    double moved2 = std::max(0.0, mx * mx + my * my);
    const double tj = (dx[j] - cx) * dfy[j] - (dy[j] - cy) * dfx[j] + dtz[j];
    const double mxj = dx[j] - refx[j], myj = dy[j] - refy[j];
    bfx = two ? bfx + dfx[j] : bfx;
    bfy = two ? bfy + dfy[j] : bfy;
    btq = two ? btq + tj : btq;
    moved2 = two ? std::max(moved2, mxj * mxj + myj * myj) : moved2;
    bfy = bfy - bmass[b] * (on ? g : 0.0);
    bfx_out[b] = bfx;
    bfy_out[b] = bfy;
    btq_out[b] = btq;
    double vx = bvx[b], vy = bvy[b], w = bw[b];
    if constexpr (kKick) {  // the second half kick of the step
      vx = on ? vx + half * bfx * binv_mass[b] : vx;
      vy = on ? vy + half * bfy * binv_mass[b] : vy;
      w = on ? w + half * btq * binv_inertia[b] : w;
      bvx[b] = vx;
      bvy[b] = vy;
      bw[b] = w;
    }
    outrun |= on & OutrunsSkin(vx, vy, w, bfx, bfy, btq, binv_mass[b], binv_inertia[b], bradius[b], moved2, half, dt,
                               limit);
  }
  return outrun != 0;
}

}  // namespace

GRANARY_KERNEL bool World::BodyForces(int b0, int b1, bool kick) {
  if (b0 >= b1) return false;
  const double g = params_.gravity, half = 0.5 * params_.dt;
  const int* __restrict xl_start = xl_start_.data();
  const int* __restrict xl_entry = xl_entry_.data();
  const double* __restrict nl_fx = nl_fx_.data();
  const double* __restrict nl_fy = nl_fy_.data();
  const double* __restrict nl_c = nl_c_.data();
  double* __restrict dfx = dfx_.data();
  double* __restrict dfy = dfy_.data();
  double* __restrict dtz = dtz_.data();
  // 1. Reactions of entries from earlier blocks, ascending i (few discs have any; discs of
  // inactive bodies have no entries).
  const int d0 = disc_begin_[b0], d1 = disc_begin_[b1 - 1] + disc_n_[b1 - 1];
  for (int i = d0; i < d1; ++i) {
    const int k0 = xl_start[i], k1 = xl_start[i + 1];
    if (k0 == k1) continue;
    double fx = dfx[i], fy = dfy[i], c = 0.0;
    for (int k = k0; k < k1; ++k) {
      const int e = xl_entry[k];
      fx -= nl_fx[e];
      fy -= nl_fy[e];
      c += nl_c[e];
    }
    dfx[i] = fx;
    dfy[i] = fy;
    dtz[i] -= dr_[i] * c;
  }
  // 2. Body sums, gravity (and the half kick).
  const double dt = params_.dt, limit = 0.5 * params_.skin;
  // Discs and dumbbells get the vectorized loop (no lambda: one called twice in a
  // target_clones function is compiled for baseline x86-64 only).
#define GRANARY_BODY_SUMS(kDiscs, kKick)                                                                             \
  BodySums<kDiscs, kKick>(b0, b1, g, half, dt, limit, active_.data(), dfx, dfy, dtz, dx_.data(), dy_.data(),          \
                          refx_.data(), refy_.data(), bx_.data(), by_.data(), bmass_.data(), binv_mass_.data(),      \
                          binv_inertia_.data(), bradius_.data(), bfx_.data(), bfy_.data(), btq_.data(), bvx_.data(), \
                          bvy_.data(), bw_.data())
  if (uniform_discs_ == 1) return kick ? GRANARY_BODY_SUMS(1, true) : GRANARY_BODY_SUMS(1, false);
  if (uniform_discs_ == 2) return kick ? GRANARY_BODY_SUMS(2, true) : GRANARY_BODY_SUMS(2, false);
#undef GRANARY_BODY_SUMS
#define GRANARY_BODY_SUMS_UP_TO_2(kKick)                                                                              \
  BodySumsUpTo2<kKick>(b0, b1, g, half, dt, limit, active_.data(), disc_begin_.data(), disc_n_.data(), dfx, dfy, dtz, \
                       dx_.data(), dy_.data(), refx_.data(), refy_.data(), bx_.data(), by_.data(), bmass_.data(),      \
                       binv_mass_.data(), binv_inertia_.data(), bradius_.data(), bfx_.data(), bfy_.data(),            \
                       btq_.data(), bvx_.data(), bvy_.data(), bw_.data())
  if (max_discs_ <= 2) {  // a mixture of discs and dumbbells: eight bodies at a time by the AVX-512 loop
    bool outrun = false;
    if (use_avx512_) {
      const BodySumArrays arrays{active_.data(), disc_begin_.data(), disc_n_.data(), dfx, dfy, dtz, dx_.data(),
                                 dy_.data(), refx_.data(), refy_.data(), bx_.data(), by_.data(), bmass_.data(),
                                 binv_mass_.data(), binv_inertia_.data(), bradius_.data(), bfx_.data(), bfy_.data(),
                                 btq_.data(), bvx_.data(), bvy_.data(), bw_.data()};
      b0 = kick ? BodySumsUpTo2Avx512<true>(b0, b1, arrays, d1, g, half, dt, limit, &outrun)
                : BodySumsUpTo2Avx512<false>(b0, b1, arrays, d1, g, half, dt, limit, &outrun);
    }
    return (kick ? GRANARY_BODY_SUMS_UP_TO_2(true) : GRANARY_BODY_SUMS_UP_TO_2(false)) || outrun;
  }
#undef GRANARY_BODY_SUMS_UP_TO_2
  bool outrun = false;
  for (int b = b0; b < b1; ++b) {
    if (!active_[b]) continue;
    double bfx = 0, bfy = 0, btq = 0, moved2 = 0;
    const double cx = bx_[b], cy = by_[b];
    const int e0 = disc_begin_[b], e1 = e0 + disc_n_[b];
    for (int i = e0; i < e1; ++i) {
      bfx += dfx[i];
      bfy += dfy[i];
      btq += (dx_[i] - cx) * dfy[i] - (dy_[i] - cy) * dfx[i] + dtz[i];
      const double mx = dx_[i] - refx_[i], my = dy_[i] - refy_[i];
      moved2 = std::max(moved2, mx * mx + my * my);
    }
    bfx_[b] = bfx;
    bfy_[b] = bfy - bmass_[b] * g;
    btq_[b] = btq;
    if (kick) {  // the second half kick of the step
      bvx_[b] += half * bfx_[b] * binv_mass_[b];
      bvy_[b] += half * bfy_[b] * binv_mass_[b];
      bw_[b] += half * btq_[b] * binv_inertia_[b];
    }
    outrun = outrun || OutrunsSkin(bvx_[b], bvy_[b], bw_[b], bfx_[b], bfy_[b], btq_[b], binv_mass_[b],
                                   binv_inertia_[b], bradius_[b], moved2, half, dt, limit);
  }
  return outrun;
}

void World::Forces(bool rebuild, bool kick) {
  if (rebuild) Rebuild();
  const std::int64_t pass = NextForcePass();
  bool outrun = false;
#pragma omp parallel if (Parallel()) reduction(|| : outrun)
  outrun = ForcePasses(kick, pass, false);
  rebuild_predicted_ = outrun;
}

std::int64_t World::NextForcePass() {
  const int nblocks = (DiscCount() + params_.force_block - 1) / params_.force_block;
  if (nblocks != block_done_count_) {  // only when bodies are added
    block_done_ = std::make_unique<PassStamp[]>(static_cast<std::size_t>(nblocks));
    block_done_count_ = nblocks;
  }
  const int nchunks = (BodyCount() + kBodyChunk - 1) / kBodyChunk;
  if (nchunks != chunk_done_count_) {
    chunk_done_ = std::make_unique<PassStamp[]>(static_cast<std::size_t>(nchunks));
    chunk_done_count_ = nchunks;
  }
  const int threads = omp_get_max_threads();
  if (threads > share_done_count_) {
    share_done_ = std::make_unique<PassStamp[]>(static_cast<std::size_t>(threads));
    share_done_count_ = threads;
    lead_sources_.resize(static_cast<std::size_t>(threads));
    step_done_ = std::make_unique<StepDone[]>(static_cast<std::size_t>(threads));
    thread_busy_ = std::make_unique<ThreadClock[]>(static_cast<std::size_t>(threads));
    balance_team_ = 0;
  }
  share_starts_.resize(static_cast<std::size_t>(threads) + 1);
  for (int t = 0; t <= threads; ++t) share_starts_[static_cast<std::size_t>(t)] = FindShareStart(t, threads);
  share_team_ = threads;
  return ++force_pass_;
}

namespace {

// Waits until `stamp` holds `pass` or a later one (another thread publishes it when its work
// is done; passes only grow).
// Adds the seconds waited to *waited, if given.
void AwaitPass(const std::atomic<std::int64_t>& stamp, std::int64_t pass, double* waited = nullptr) {
  if (stamp.load(std::memory_order_acquire) >= pass) return;
  const auto start = std::chrono::steady_clock::now();
  for (int spins = 0; stamp.load(std::memory_order_acquire) < pass; ++spins) {
#if defined(__x86_64__)
    __builtin_ia32_pause();
#endif
    if (spins > 4096) std::this_thread::yield();  // the other thread may not be running now
  }
  if (waited) *waited += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

int World::ChunkShareStart(int t, int nt) const {
  return nt == share_team_ ? share_starts_[static_cast<std::size_t>(t)] : FindShareStart(t, nt);
}

int World::FindShareStart(int t, int nt) const {
  const int n = DiscCount(), nchunks = (BodyCount() + kBodyChunk - 1) / kBodyChunk;
  if (t <= 0) return 0;
  if (t >= nt) return nchunks;
  if (nl_start_.size() != static_cast<std::size_t>(n) + 1)  // no lists yet (bodies added since)
    return static_cast<int>(static_cast<long>(nchunks) * t / nt);
  // A disc costs about as much as a list entry (its drift and body sums against an entry's
  // force and sums: measured), so the work before disc i is about nl_start_[i] + i; the
  // measured shift (Rebalance) moves the target by what the threads' times say.
  const double shift = balance_team_ == nt ? share_shift_[static_cast<std::size_t>(t)] : params_.share_shift;
  const long target = std::lround((static_cast<double>(nl_start_[n]) + n) * (static_cast<double>(t) / nt + shift));
  int lo = 0, hi = n;  // the first i with nl_start_[i] + i >= target
  while (lo < hi) {
    const int mid = lo + (hi - lo) / 2;
    if (static_cast<long>(nl_start_[mid]) + mid < target)
      lo = mid + 1;
    else
      hi = mid;
  }
  return lo >= n ? nchunks : std::min(nchunks, (dbody_[lo] + kBodyChunk / 2) / kBodyChunk);
}

void World::Rebalance(int nt, int steps) {
  if (nt != balance_team_) {  // a new team: start from the split even in work
    share_shift_.assign(static_cast<std::size_t>(nt), params_.share_shift);
    for (int t = 0; t < nt; ++t) thread_busy_[t].busy = 0.0;
    balance_team_ = nt;
    balance_steps_ = 0;
    return;
  }
  balance_steps_ += steps;
  if (balance_steps_ < kBalanceEvery || !params_.rebalance_shares) return;
  balance_steps_ = 0;
  double total = 0.0;
  for (int t = 0; t < nt; ++t) total += thread_busy_[t].busy;
  double before = 0.0;  // busy seconds of the threads before boundary t
  for (int t = 1; t < nt && total > 0.0; ++t) {
    before += thread_busy_[t - 1].busy;
    // Threads before the boundary that worked more than their part give work to those after
    // (half the difference at a time, so that noise in the times does not swing the split).
    const double limit = 0.25 / nt;
    const std::size_t k = static_cast<std::size_t>(t);
    share_shift_[k] = std::clamp(share_shift_[k] + 0.5 * (static_cast<double>(t) / nt - before / total), -limit, limit);
  }
  for (int t = 0; t < nt; ++t) thread_busy_[t].busy = 0.0;
}

int World::PairShareStart(int t, int nt) const {
  const int b = ChunkShareStart(t, nt) * kBodyChunk;
  return b >= BodyCount() ? DiscCount() : disc_begin_[b];
}

const std::vector<int>& World::LeadSources(int t, int i0, int i1) {
  LeadSourceCache& c = lead_sources_[static_cast<std::size_t>(t)];
  if (c.rebuild != rebuilds_ || c.i0 != i0 || c.i1 != i1) {  // the shares move with the lists only
    c.rebuild = rebuilds_;
    c.i0 = i0;
    c.i1 = i1;
    c.entries.clear();
    const int first = i0 / params_.force_block * params_.force_block;
    for (int e = nl_start_[first]; e < nl_start_[i0]; ++e)
      if (nl_j_[e] >= i0 && nl_j_[e] < i1) c.entries.push_back(e);
  }
  return c.entries;
}

// Called by every thread of a parallel region, each taking its share (PairShareStart): inside Step's
// region (one region per step: fewer forks and joins), elsewhere in the one Forces opens.
bool World::ForcePasses(bool kick, std::int64_t pass, bool await_drift, double* waited) {
  const int t = omp_get_thread_num(), nt = omp_get_num_threads();
  // 1. Pair and wall forces by blocks of discs; within a block the order is ascending i,
  // whichever thread runs it. Each thread takes a contiguous share, the same from step to
  // step, like the drift and body loops: its discs, bodies and list entries stay in its
  // core's cache (with dynamic blocks, 2 threads gave 1.2x instead of 1.7x). In a step, a
  // block first waits for the drift of the chunks holding its discs and their partners
  // (j > i: its own discs and a few beyond), not for a barrier after the whole drift.
  //
  // The shares are even in work (ChunkShareStart), so they split blocks: each thread computes
  // the entries and the sums of the discs in its share (SumPartForces: a block summed in
  // parts gives the bits of the block summed at once), so the sums of a disc are made where
  // its body's forces are. A block's stamp says that all its entries are computed and the
  // sums of the part in the share of its first disc: a later thread computes its part of
  // that block's entries first (share_done_), and its sums last (they need the earlier
  // parts' entries: LeadSources).
  const int n = DiscCount(), block = params_.force_block;
  const int m0 = PairShareStart(t, nt), m1 = PairShareStart(t + 1, nt);
  auto await_drift_of = [&](int i, int blk) {
    if (!await_drift) return;
    const int c1 = dbody_[block_last_partner_[blk]] / kBodyChunk;
    for (int c = dbody_[i] / kBodyChunk; c <= c1; ++c) AwaitPass(chunk_done_[c].pass, pass, waited);
  };
  int i = m0;
  int lead_end = m0;  // [m0, lead_end): the part of a block that starts in an earlier share
  if (i < m1 && i % block != 0) {
    const int blk = i / block;
    lead_end = std::min({m1, n, (blk + 1) * block});
    await_drift_of(i, blk);
    PairEntriesOf(i, lead_end);
    i = lead_end;
  }
  share_done_[t].pass.store(pass, std::memory_order_release);
  static const std::vector<int> kNone;
  while (i < m1) {  // blocks that start in the share
    const int blk = i / block, i1 = std::min(n, i + block), end = std::min(i1, m1);
    await_drift_of(i, blk);
    PairEntriesOf(i, end);
    SumPartForces(i, end, kNone);
    for (int u = t + 1; u < nt && PairShareStart(u, nt) < i1; ++u) AwaitPass(share_done_[u].pass, pass, waited);
    block_done_[blk].pass.store(pass, std::memory_order_release);
    i = i1;
  }
  // 2. Reactions across blocks, body forces, gravity, torques (and the half kick). A chunk
  // of bodies reads the sums of its discs' blocks and the reactions of entries from earlier
  // blocks, so it waits for those blocks only, not for a barrier. A thread past the first
  // takes its chunks last to first: the last read only its own blocks, and by the time it
  // reaches the first, which read the previous thread's last block, that is done. (Both
  // callers end their parallel region right after, which is a barrier.)
  const int nb = BodyCount();
  const int ch0 = ChunkShareStart(t, nt), ch1 = ChunkShareStart(t + 1, nt);
  bool outrun = false;
  for (int k = 0; k < ch1 - ch0; k += kChunksPerCall) {
    const int first = t == 0 ? ch0 + k : std::max(ch0, ch1 - k - kChunksPerCall);
    const int last = t == 0 ? std::min(ch1, first + kChunksPerCall) : ch1 - k;  // [first, last)
    const int b0 = first * kBodyChunk, b1 = std::min(nb, last * kBodyChunk);
    const int first_block = disc_begin_[b0] / params_.force_block;
    const int last_block = (disc_begin_[b1 - 1] + disc_n_[b1 - 1] - 1) / params_.force_block;
    int from = first_block;
    for (int blk = first_block; blk <= last_block; ++blk) from = std::min(from, block_first_source_[blk]);
    for (int blk = from; blk <= last_block; ++blk) AwaitPass(block_done_[blk].pass, pass, waited);
    if (lead_end > m0 && disc_begin_[b0] < lead_end) {  // (its block's stamp is awaited above)
      SumPartForces(m0, lead_end, LeadSources(t, m0, lead_end));
      lead_end = m0;
    }
    outrun = BodyForces(b0, b1, kick) || outrun;
  }
  return outrun;
}

namespace {

// The body part of DriftBodies: half kick, drift, rotation of bodies [b0, b1), one straight
// loop (it vectorizes); an inactive body keeps its state (selects). Rotation angles of 0.01
// or more, which need libm, are left to the caller. Returns kWide if there were any, and
// kBeyond if an active body's centre has left the box {xmin, xmax, ymin}.
constexpr int kWide = 1, kBeyond = 2;
[[gnu::always_inline]] inline int DriftKernel(int b0, int b1, double dt, const double box[3],
                                              const std::uint8_t* __restrict active,
                                               double* __restrict bx, double* __restrict by, double* __restrict bth,
                                               double* __restrict bvx, double* __restrict bvy, double* __restrict bw,
                                               double* __restrict bc, double* __restrict bs,
                                               const double* __restrict bfx, const double* __restrict bfy,
                                               const double* __restrict btq, const double* __restrict binv_mass,
                                               const double* __restrict binv_inertia) {
  const double half = 0.5 * dt;
  const double xmin = box[0], xmax = box[1], ymin = box[2];
  int wide = 0, beyond = 0;
#pragma GCC ivdep  // each iteration reads and writes body b only
  for (int b = b0; b < b1; ++b) {
    const bool on = active[b] != 0;
    const double vx = bvx[b] + half * bfx[b] * binv_mass[b];
    const double vy = bvy[b] + half * bfy[b] * binv_mass[b];
    const double w = bw[b] + half * btq[b] * binv_inertia[b];
    const double a = dt * w;
    // Rotate (cos, sin) by a. For |a| < 0.01 the series to a^8 is exact to rounding; one
    // Newton step keeps |(c, s)| = 1 without a square root.
    const bool small = std::fabs(a) < 0.01;
    const double a2 = a * a;
    // (multiplications by constant reciprocals: divisions here cost as much as the rest)
    constexpr double k2 = 1.0 / 2, k12 = 1.0 / 12, k30 = 1.0 / 30, k56 = 1.0 / 56;
    constexpr double k6 = 1.0 / 6, k20 = 1.0 / 20, k42 = 1.0 / 42;
    const double ca = 1.0 - a2 * k2 * (1.0 - a2 * k12 * (1.0 - a2 * k30 * (1.0 - a2 * k56)));
    const double sa = a * (1.0 - a2 * k6 * (1.0 - a2 * k20 * (1.0 - a2 * k42)));
    const double c = bc[b] * ca - bs[b] * sa, s = bs[b] * ca + bc[b] * sa;
    const double f = 1.5 - 0.5 * (c * c + s * s);
    // (every value computed before the selects, and & not &&: no branches)
    const double x = bx[b] + dt * vx, y = by[b] + dt * vy, th = bth[b] + a;
    const double cn = c * f, sn = s * f;
    bx[b] = on ? x : bx[b];
    by[b] = on ? y : by[b];
    bth[b] = on ? th : bth[b];
    bvx[b] = on ? vx : bvx[b];
    bvy[b] = on ? vy : bvy[b];
    bw[b] = on ? w : bw[b];
    bc[b] = (on & small) ? cn : bc[b];
    bs[b] = (on & small) ? sn : bs[b];
    wide |= on & !small;
    beyond |= on & ((x < xmin) | (x > xmax) | (y < ymin));
  }
  return (wide != 0 ? kWide : 0) | (beyond != 0 ? kBeyond : 0);
}

// One disc d of a body with centre (x, y), velocity (vx, vy), orientation (c, s) and angular
// velocity w: its position and kinematics; returns whether it has moved more than sqrt(limit)
// since the last rebuild. Shared by both disc loops of the drift.
[[gnu::always_inline]] inline bool PlaceDisc(std::size_t d, double x, double y, double vx, double vy, double c,
                                             double s, double w, double limit, const double* __restrict dox,
                                             const double* __restrict doy, const double* __restrict dr,
                                             const double* __restrict refx, const double* __restrict refy,
                                             double* __restrict dx, double* __restrict dy,
                                             World::DiscKin* __restrict kin) {
  const double wx = c * dox[d] - s * doy[d];
  const double wy = s * dox[d] + c * doy[d];
  const double px = x + wx, py = y + wy;
  dx[d] = px;
  dy[d] = py;
  kin[d] = {px, py, vx - w * wy, vy + w * wx, dr[d], w};
  const double ddx = px - refx[d], ddy = py - refy[d];
  return ddx * ddx + ddy * ddy > limit;
}

// The disc part of DriftBodies: positions and velocities of discs [d0, d1) from their
// bodies (as UpdateDiscs), one straight loop; returns whether a disc has moved more than
// sqrt(limit) since the last rebuild.
[[gnu::always_inline]] inline bool DiscKernel(int d0, int d1, double limit,
                                              const int* __restrict dbody, const double* __restrict bx,
                                              const double* __restrict by, const double* __restrict bvx,
                                              const double* __restrict bvy, const double* __restrict bw,
                                              const double* __restrict bc, const double* __restrict bs,
                                              const double* __restrict dox, const double* __restrict doy,
                                              const double* __restrict dr, const double* __restrict refx, const double* __restrict refy,
                                              double* __restrict dx, double* __restrict dy,
                                              World::DiscKin* __restrict kin) {
  int moved = 0;
#pragma GCC ivdep  // each iteration writes disc d only, and reads no array it writes
  for (int d = d0; d < d1; ++d) {
    const int b = dbody[d];
    moved |= PlaceDisc(static_cast<std::size_t>(d), bx[b], by[b], bvx[b], bvy[b], bc[b], bs[b], bw[b], limit, dox, doy,
                       dr, refx, refy, dx, dy, kin);
  }
  return moved != 0;
}

// DiscKernel for bodies [b0, b1) of kDiscs discs each, disc k of body b being kDiscs b + k:
// a loop over the bodies, so the body state is read without gathers.
template <int kDiscs>
[[gnu::always_inline]] inline bool DiscKernelUniform(int b0, int b1, double limit, const double* __restrict bx,
                                                     const double* __restrict by, const double* __restrict bvx,
                                                     const double* __restrict bvy, const double* __restrict bw,
                                                     const double* __restrict bc, const double* __restrict bs,
                                                     const double* __restrict dox, const double* __restrict doy,
                                                     const double* __restrict dr, const double* __restrict refx,
                                                     const double* __restrict refy, double* __restrict dx,
                                                     double* __restrict dy, World::DiscKin* __restrict kin) {
  int moved = 0;
#pragma GCC ivdep  // each iteration writes its body's discs only, and reads no array it writes
  for (int b = b0; b < b1; ++b) {
    const double c = bc[b], s = bs[b], w = bw[b];
#pragma GCC unroll 8
    for (int k = 0; k < kDiscs; ++k) {
      const std::size_t d = static_cast<std::size_t>(kDiscs) * static_cast<std::size_t>(b) + static_cast<std::size_t>(k);
      moved |= PlaceDisc(d, bx[b], by[b], bvx[b], bvy[b], c, s, w, limit, dox, doy, dr, refx, refy, dx, dy, kin);
    }
  }
  return moved != 0;
}

}  // namespace

GRANARY_KERNEL int World::DriftBodyKernel(int b0, int b1) {
  const double dt = params_.dt;
  const int flags = DriftKernel(b0, b1, dt, exit_box_, active_.data(), bx_.data(), by_.data(), bth_.data(), bvx_.data(),
                                bvy_.data(), bw_.data(), bc_.data(), bs_.data(), bfx_.data(), bfy_.data(),
                                btq_.data(), binv_mass_.data(), binv_inertia_.data());
  if (flags & kWide) {  // the rotations the series does not cover
    for (int b = b0; b < b1; ++b) {
      const double a = dt * bw_[b];
      if (!active_[b] || std::fabs(a) < 0.01) continue;
      const double ca = std::cos(a), sa = std::sin(a);
      const double c = bc_[b] * ca - bs_[b] * sa, s = bs_[b] * ca + bc_[b] * sa;
      const double f = 1.5 - 0.5 * (c * c + s * s);
      bc_[b] = c * f;
      bs_[b] = s * f;
    }
  }
  return flags & kBeyond;
}

GRANARY_KERNEL int World::DriftPortable(int b0, int b1) {
  if (b0 >= b1) return 0;
  const int flags = DriftBodyKernel(b0, b1);
  // Discs of an inactive body are recomputed from its unchanged state, which gives the
  // values they have. They count in the displacement check, harmlessly: a body is switched
  // off or on only with a rebuild requested, and then it does not move.
  const double limit = 0.25 * params_.skin * params_.skin;
  const int beyond = flags & kBeyond ? kDriftBeyond : 0;
  // (no lambda: one called twice in a target_clones function is compiled for baseline x86-64 only)
  if (uniform_discs_ == 1)
    return beyond | (DiscKernelUniform<1>(b0, b1, limit, bx_.data(), by_.data(), bvx_.data(), bvy_.data(), bw_.data(),
                                          bc_.data(), bs_.data(), dox_.data(), doy_.data(), dr_.data(), refx_.data(),
                                          refy_.data(), dx_.data(), dy_.data(), kin_.data())
                         ? kDriftMoved
                         : 0);
  if (uniform_discs_ == 2)
    return beyond | (DiscKernelUniform<2>(b0, b1, limit, bx_.data(), by_.data(), bvx_.data(), bvy_.data(), bw_.data(),
                                          bc_.data(), bs_.data(), dox_.data(), doy_.data(), dr_.data(), refx_.data(),
                                          refy_.data(), dx_.data(), dy_.data(), kin_.data())
                         ? kDriftMoved
                         : 0);
  const int d0 = disc_begin_[b0], d1 = disc_begin_[b1 - 1] + disc_n_[b1 - 1];
  return beyond | (DiscKernel(d0, d1, limit, dbody_.data(), bx_.data(),
                    by_.data(), bvx_.data(), bvy_.data(), bw_.data(), bc_.data(), bs_.data(), dox_.data(),
                    doy_.data(), dr_.data(), refx_.data(), refy_.data(), dx_.data(), dy_.data(), kin_.data())
                       ? kDriftMoved
                       : 0);
}

int World::DriftBodies(int b0, int b1) {
  if (b0 >= b1) return 0;
  if (!use_avx512_) return DriftPortable(b0, b1);
  const DriftArrays arrays{active_.data(), bx_.data(),   by_.data(),    bth_.data(),          bvx_.data(),
                           bvy_.data(),    bw_.data(),   bc_.data(),    bs_.data(),           bfx_.data(),
                           bfy_.data(),    btq_.data(),  binv_mass_.data(), binv_inertia_.data(), dox_.data(),
                           doy_.data(),    dr_.data(),   refx_.data(),  refy_.data(),         dx_.data(),
                           dy_.data(),     kin_.data()};
  const double limit = 0.25 * params_.skin * params_.skin;
  bool beyond = false, moved = false;
  if (uniform_discs_ != 1 && uniform_discs_ != 2) {
    // Bodies of several shapes on an AVX-512 CPU: the portable body loop, then the discs
    // eight at a time (their bodies' state gathered), the last few portably.
    const int flags = DriftBodyKernel(b0, b1);
    const int d0 = disc_begin_[b0], d1 = disc_begin_[b1 - 1] + disc_n_[b1 - 1];
    const int d = PlaceDiscsAvx512(d0, d1, limit, dbody_.data(), b1, arrays, &moved);
    moved |= DiscKernel(d, d1, limit, dbody_.data(), bx_.data(), by_.data(), bvx_.data(), bvy_.data(), bw_.data(),
                        bc_.data(), bs_.data(), dox_.data(), doy_.data(), dr_.data(), refx_.data(), refy_.data(),
                        dx_.data(), dy_.data(), kin_.data());
    return (flags & kBeyond ? kDriftBeyond : 0) | (moved ? kDriftMoved : 0);
  }
  // Discs or dumbbells on an AVX-512 CPU: eight bodies at a time in one pass; a group with a
  // rotation that needs libm, and the last few bodies, by the portable loops.
  int flags = 0;
  for (int b = b0; b < b1;) {
    b = uniform_discs_ == 1 ? DriftUniformAvx512<1>(b, b1, arrays, params_.dt, exit_box_, limit, &beyond, &moved)
                            : DriftUniformAvx512<2>(b, b1, arrays, params_.dt, exit_box_, limit, &beyond, &moved);
    const int e = std::min(b1, b + 8);
    if (b < e) flags |= DriftPortable(b, e);
    b = e;
  }
  return flags | (beyond ? kDriftBeyond : 0) | (moved ? kDriftMoved : 0);
}

int World::DriftShare(int t, int nt, std::int64_t pass) {
  const int nb = BodyCount();
  const int ch0 = ChunkShareStart(t, nt), ch1 = ChunkShareStart(t + 1, nt);
  int flags = 0;
  for (int ch = ch0; ch < ch1; ch += kChunksPerCall) {
    const int end = std::min(ch1, ch + kChunksPerCall);
    flags |= DriftBodies(ch * kBodyChunk, std::min(nb, end * kBodyChunk));
    for (int c = ch; c < end; ++c) chunk_done_[c].pass.store(pass, std::memory_order_release);
  }
  return flags;
}

void World::Step() {
  // The last force pass said whether this drift may take a disc beyond half the skin
  // (OutrunsSkin): then this step rebuilds, after a drift of its own. Otherwise drift,
  // pair blocks and body chunks run in one region with no barrier: each waits only for the
  // work it reads (ForcePasses).
  const bool rebuild = rebuild_needed_ || rebuild_predicted_;
  const std::int64_t pass = NextForcePass();
  int flags = 0;
  bool outrun = false;
#pragma omp parallel if (Parallel()) reduction(| : flags) reduction(|| : outrun)
  {
    // (the same shares of body chunks as in ForcePasses: each thread keeps its bodies)
    flags |= DriftShare(omp_get_thread_num(), omp_get_num_threads(), pass);
    if (!rebuild) outrun = ForcePasses(true, pass, true);
  }
  if (rebuild) {
    Forces(true, true);
  } else {
    rebuild_predicted_ = outrun;
    // The bound makes this impossible; if it ever failed, this step's forces missed
    // contacts, and a run must stop rather than go on wrong.
    if (flags & kDriftMoved)
      throw std::logic_error("engine: a disc moved more than half the Verlet skin between list rebuilds");
  }
  beyond_exit_box_ = !exit_box_set_ || (flags & kDriftBeyond) != 0;
}

int World::Steps(int max_steps) {
  int taken = 0;
  while (taken < max_steps) {
    // A step that rebuilds the lists has serial parts and parallel loops of its own (Step);
    // without an exit box every step is "beyond" it, so steps go one by one.
    if (rebuild_needed_ || rebuild_predicted_ || !exit_box_set_ || !Parallel() || max_steps - taken == 1) {
      Step();
      ++taken;
    } else {
      taken += StepsInOneRegion(max_steps - taken);
    }
    if (beyond_exit_box_) break;
  }
  return taken;
}

// Each step as in Step without a rebuild; then every thread publishes its flags and waits for
// everyone's (the barrier between steps: the next drift moves discs that the other threads'
// pair blocks of this step read). All threads see the same flags, so all stop after the same
// step: one that leaves a body beyond the exit box, predicts a rebuild, or is the last.
int World::StepsInOneRegion(int max_steps) {
  const std::int64_t first = NextForcePass();
  int taken = 0, flags = 0, team = 1;
#pragma omp parallel
  {
    const int t = omp_get_thread_num(), nt = omp_get_num_threads();
    if (t == 0) team = nt;
    for (int k = 0;; ++k) {
      const std::int64_t pass = first + k;
      const auto start = std::chrono::steady_clock::now();
      double waited = 0.0;
      int mine = DriftShare(t, nt, pass);
      if (ForcePasses(true, pass, true, &waited)) mine |= kStepOutrun;
      thread_busy_[t].busy += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() - waited;
      StepDone& own = step_done_[t];
      own.flags[static_cast<std::size_t>(pass & 1)] = mine;
      own.pass.store(pass, std::memory_order_release);
      int all = 0;
      for (int u = 0; u < nt; ++u) {
        AwaitPass(step_done_[u].pass, pass);
        all |= step_done_[u].flags[static_cast<std::size_t>(pass & 1)];
      }
      if (all != 0 || k + 1 == max_steps) {
        if (t == 0) {
          taken = k + 1;
          flags = all;
        }
        break;
      }
    }
  }
  force_pass_ = first + taken - 1;
  if (team > 1) Rebalance(team, taken);
  rebuild_predicted_ = (flags & kStepOutrun) != 0;
  // (as in Step: the bound makes this impossible)
  if (flags & kDriftMoved)
    throw std::logic_error("engine: a disc moved more than half the Verlet skin between list rebuilds");
  beyond_exit_box_ = (flags & kDriftBeyond) != 0;
  return taken;
}

void World::SetExitBox(double xmin, double xmax, double ymin) {
  exit_box_[0] = xmin;
  exit_box_[1] = xmax;
  exit_box_[2] = ymin;
  exit_box_set_ = true;
}

double World::KineticEnergy() const {
  double ke = 0.0;
  for (int b = 0; b < BodyCount(); ++b) {
    if (!active_[b]) continue;
    ke += 0.5 * bmass_[b] * (bvx_[b] * bvx_[b] + bvy_[b] * bvy_[b]) + 0.5 * binertia_[b] * bw_[b] * bw_[b];
  }
  return ke;
}

double World::MaxDiscTop() const {
  double top = 0.0;
  for (int i = 0; i < DiscCount(); ++i)
    if (active_[dbody_[i]]) top = std::max(top, dy_[i] + dr_[i]);
  return top;
}

void World::ExportHistory(std::vector<HistoryEntry>& pairs, std::vector<HistoryEntry>& walls) const {
  pairs.clear();
  walls.clear();
  const int n = static_cast<int>(nl_start_.empty() ? 0 : nl_start_.size() - 1);
  for (int i = 0; i < n; ++i) {
    for (int e = nl_start_[i]; e < nl_start_[i + 1]; ++e)
      if (nl_sx_[e] != 0.0 || nl_sy_[e] != 0.0) pairs.push_back({i, nl_j_[e], nl_sx_[e], nl_sy_[e]});
    for (int k = wl_start_[i]; k < wl_start_[i + 1]; ++k)
      if (wl_sx_[k] != 0.0 || wl_sy_[k] != 0.0) walls.push_back({i, wl_e_[k], wl_sx_[k], wl_sy_[k]});
  }
}

namespace {

// Lays out history entries (sorted by i, then j) as a CSR list over n discs.
template <class Doubles>
void HistoryToCsr(const std::vector<HistoryEntry>& entries, int n, const char* what, std::vector<int>& start,
                  std::vector<int>& other, Doubles& sx, Doubles& sy) {
  start.assign(static_cast<std::size_t>(n) + 1, 0);
  other.clear();
  sx.clear();
  sy.clear();
  for (const HistoryEntry& h : entries) {
    if (h.i < 0 || h.i >= n)
      throw std::runtime_error(std::string(what) + " history: disc " + std::to_string(h.i) + " out of range [0, " +
                               std::to_string(n) + ")");
    ++start[h.i + 1];
    other.push_back(h.j);
    sx.push_back(h.sx);
    sy.push_back(h.sy);
  }
  std::partial_sum(start.begin(), start.end(), start.begin());
}

}  // namespace

void World::ImportHistory(const std::vector<HistoryEntry>& pairs, const std::vector<HistoryEntry>& walls) {
  // Present the stored entries as the "current" lists; the rebuild transfers them.
  HistoryToCsr(pairs, DiscCount(), "pair", nl_start_, nl_j_, nl_sx_, nl_sy_);
  HistoryToCsr(walls, DiscCount(), "wall", wl_start_, wl_e_, wl_sx_, wl_sy_);
  Rebuild();
}

WorldSnapshot World::Snapshot() {
  // Both this world and one restored from the snapshot rebuild their lists here.
  RebuildNow();
  WorldSnapshot s;
  s.tmpl = tmpl_;
  s.active = active_;
  s.x.assign(bx_.begin(), bx_.end());
  s.y.assign(by_.begin(), by_.end());
  s.theta.assign(bth_.begin(), bth_.end());
  s.c.assign(bc_.begin(), bc_.end());
  s.s.assign(bs_.begin(), bs_.end());
  s.vx.assign(bvx_.begin(), bvx_.end());
  s.vy.assign(bvy_.begin(), bvy_.end());
  s.w.assign(bw_.begin(), bw_.end());
  s.fx.assign(bfx_.begin(), bfx_.end());
  s.fy.assign(bfy_.begin(), bfy_.end());
  s.torque.assign(btq_.begin(), btq_.end());
  ExportHistory(s.pairs, s.walls);
  s.outlets_open = outlets_open_;
  s.rebuild_predicted = rebuild_predicted_;
  return s;
}

void World::Restore(const WorldSnapshot& s) {
  if (BodyCount() != 0) throw std::invalid_argument("World::Restore: the world already has bodies");
  const std::size_t n = s.tmpl.size();
  for (const auto* v : {&s.x, &s.y, &s.theta, &s.c, &s.s, &s.vx, &s.vy, &s.w, &s.fx, &s.fy, &s.torque})
    if (v->size() != n) throw std::invalid_argument("World::Restore: body arrays of different lengths");
  if (s.active.size() != n) throw std::invalid_argument("World::Restore: body arrays of different lengths");
  for (std::size_t b = 0; b < n; ++b) AddBody(s.tmpl[b], 0, 0, 0);  // (throws for an unknown template)
  for (const HistoryEntry& h : s.pairs)
    if (h.j < 0 || h.j >= DiscCount() || h.j <= h.i)
      throw std::invalid_argument("World::Restore: pair history entry (" + std::to_string(h.i) + ", " + std::to_string(h.j) +
                                  ") is not a pair of discs i < j");
  for (const HistoryEntry& h : s.walls)
    if (h.j < 0 || h.j >= static_cast<int>(geometry_.elements.size()))
      throw std::invalid_argument("World::Restore: wall history names element " + std::to_string(h.j) + " of " +
                                  std::to_string(geometry_.elements.size()));
  for (int b = 0; b < BodyCount(); ++b) {
    PlaceBody(b, s.x[b], s.y[b], s.theta[b], s.vx[b], s.vy[b], s.w[b]);
    if (!s.active[b]) Deactivate(b);
  }
  // The forces of the step the snapshot was taken at, and the integrated orientation (not
  // cos and sin of theta).
  bfx_.assign(s.fx.begin(), s.fx.end());
  bfy_.assign(s.fy.begin(), s.fy.end());
  btq_.assign(s.torque.begin(), s.torque.end());
  bc_.assign(s.c.begin(), s.c.end());
  bs_.assign(s.s.begin(), s.s.end());
  RefreshDiscs();
  outlets_open_ = s.outlets_open;
  ImportHistory(s.pairs, s.walls);  // rebuilds the lists
  rebuild_predicted_ = s.rebuild_predicted;
}

void World::CollectContacts(std::vector<ContactView>& out) const {
  out.clear();
  const int n = static_cast<int>(nl_start_.empty() ? 0 : nl_start_.size() - 1);
  for (int i = 0; i < n; ++i) {
    for (int e = nl_start_[i]; e < nl_start_[i + 1]; ++e) {
      if (nl_fx_[e] == 0.0 && nl_fy_[e] == 0.0) continue;
      const int j = nl_j_[e];
      const double ddx = dx_[i] - dx_[j], ddy = dy_[i] - dy_[j];
      const double r = std::sqrt(ddx * ddx + ddy * ddy);
      out.push_back({i, j, -1, dx_[i] - dr_[i] * ddx / r, dy_[i] - dr_[i] * ddy / r, nl_fx_[e], nl_fy_[e]});
    }
    for (int k = wl_start_[i]; k < wl_start_[i + 1]; ++k) {
      if (wl_fx_[k] == 0.0 && wl_fy_[k] == 0.0) continue;
      const silo::Closest q = silo::ClosestPoint(geometry_.elements[wl_e_[k]], dx_[i], dy_[i]);
      double cx = q.qx, cy = q.qy;
      const silo::WallElement& el = geometry_.elements[wl_e_[k]];
      if (el.kind == silo::ElementKind::kCircle) {
        const double ddx = dx_[i] - el.ax, ddy = dy_[i] - el.ay;
        const double r = std::sqrt(ddx * ddx + ddy * ddy);
        cx = el.ax + el.radius * ddx / r;
        cy = el.ay + el.radius * ddy / r;
      }
      out.push_back({i, -1, wl_e_[k], cx, cy, wl_fx_[k], wl_fy_[k]});
    }
  }
}

void World::MarkBodiesInContact(std::vector<std::uint8_t>& out) const {
  out.assign(bx_.size(), 0);
  const int n = static_cast<int>(nl_start_.empty() ? 0 : nl_start_.size() - 1);
  for (int i = 0; i < n; ++i) {
    for (int e = nl_start_[i]; e < nl_start_[i + 1]; ++e) {
      if (nl_fx_[e] == 0.0 && nl_fy_[e] == 0.0) continue;
      out[static_cast<std::size_t>(dbody_[i])] = 1;
      out[static_cast<std::size_t>(dbody_[nl_j_[e]])] = 1;
    }
    for (int k = wl_start_[i]; k < wl_start_[i + 1]; ++k)
      if (wl_fx_[k] != 0.0 || wl_fy_[k] != 0.0) out[static_cast<std::size_t>(dbody_[i])] = 1;
  }
}

}  // namespace granary::engine
