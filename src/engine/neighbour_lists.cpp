// The neighbour lists (neighbour_lists.h).
#include "engine/neighbour_lists.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>

#include "engine/contact_law.h"
#include "engine/world.h"

namespace granary::engine {

bool ElementActive(const silo::WallElement& e, bool outlets_open) {
  switch (e.group) {
    case silo::WallGroup::kAlways: return true;
    case silo::WallGroup::kPlug: return !outlets_open;
    case silo::WallGroup::kOpen: return outlets_open;
  }
  return true;
}

void NeighbourLists::AddDiscs(int n) {
  rebuild_x_.resize(rebuild_x_.size() + static_cast<std::size_t>(n), 0.0);
  rebuild_y_.resize(rebuild_y_.size() + static_cast<std::size_t>(n), 0.0);
}

bool NeighbourLists::NeedsRebuild(bool parallel) const {
  const int n = bodies_->DiscCount();
  const double limit = 0.25 * params_->skin * params_->skin;
  double worst = 0.0;
#pragma omp parallel for schedule(static) reduction(max : worst) if (parallel)
  for (int i = 0; i < n; ++i) {
    if (!bodies_->body_active_[bodies_->disc_body_[i]]) continue;
    const double ddx = bodies_->disc_x_[i] - rebuild_x_[i], ddy = bodies_->disc_y_[i] - rebuild_y_[i];
    worst = std::max(worst, ddx * ddx + ddy * ddy);
  }
  return worst > limit;
}

void NeighbourLists::Rebuild(bool outlets_open, bool parallel) {
  ++rebuilds_;
  const int n = bodies_->DiscCount();
  old_pair_start_.swap(pair_start_);
  old_pair_j_.swap(pair_j_);
  old_pair_shear_x_.swap(pair_shear_x_);
  old_pair_shear_y_.swap(pair_shear_y_);
  old_wall_start_.swap(wall_start_);
  old_wall_element_.swap(wall_element_);
  old_wall_shear_x_.swap(wall_shear_x_);
  old_wall_shear_y_.swap(wall_shear_y_);
  const int old_n = old_pair_start_.empty() ? 0 : static_cast<int>(old_pair_start_.size()) - 1;
  const int old_wn = old_wall_start_.empty() ? 0 : static_cast<int>(old_wall_start_.size()) - 1;

  // Cell grid over the bounding box of the active discs.
  double xmin = 1e300, xmax = -1e300, ymin = 1e300, ymax = -1e300;
  for (int i = 0; i < n; ++i) {
    if (!bodies_->body_active_[bodies_->disc_body_[i]]) continue;
    xmin = std::min(xmin, bodies_->disc_x_[i]);
    xmax = std::max(xmax, bodies_->disc_x_[i]);
    ymin = std::min(ymin, bodies_->disc_y_[i]);
    ymax = std::max(ymax, bodies_->disc_y_[i]);
  }
  if (xmin > xmax) xmin = xmax = ymin = ymax = 0.0;
  double cell = 2.0 * max_radius_ + params_->skin;
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
    if (!bodies_->body_active_[bodies_->disc_body_[i]]) {
      disc_cell_[i] = -1;
      continue;
    }
    const long cx = std::min(ncx - 1, static_cast<long>((bodies_->disc_x_[i] - xmin) / cell));
    const long cy = std::min(ncy - 1, static_cast<long>((bodies_->disc_y_[i] - ymin) / cell));
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

  const double skin = params_->skin;
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
          if (j <= i || bodies_->disc_body_[j] == bodies_->disc_body_[i]) continue;
          const double ddx = bodies_->disc_x_[i] - bodies_->disc_x_[j], ddy = bodies_->disc_y_[i] - bodies_->disc_y_[j];
          const double cut = bodies_->disc_radius_[i] + bodies_->disc_radius_[j] + skin;
          if (ddx * ddx + ddy * ddy < cut * cut) visit(j);
        }
      }
  };
  pair_start_.resize(static_cast<std::size_t>(n) + 1);
  // One cell search per disc: each thread keeps the partners of its discs in a buffer of its
  // own and copies them into place once the offsets are known (both loops are static over
  // the same range, so a thread meets its discs in the same order twice).
  if (rebuild_partners_.size() < static_cast<std::size_t>(omp_get_max_threads()))
    rebuild_partners_.resize(static_cast<std::size_t>(omp_get_max_threads()));
#pragma omp parallel if (parallel)
  {
    std::vector<int>& found = rebuild_partners_[static_cast<std::size_t>(omp_get_thread_num())];
    found.clear();
#pragma omp for schedule(static)
    for (int i = 0; i < n; ++i) {
      const std::size_t before = found.size();
      for_neighbours(i, [&](int j) { found.push_back(j); });
      pair_start_[i + 1] = static_cast<int>(found.size() - before);
    }
#pragma omp single
    {
      pair_start_[0] = 0;
      std::partial_sum(pair_start_.begin(), pair_start_.end(), pair_start_.begin());  // counts to offsets
      const std::size_t m = static_cast<std::size_t>(pair_start_[n]);
      pair_j_.resize(m);
      pair_i_.resize(m);
      pair_shear_x_.resize(m);
      pair_shear_y_.resize(m);
      pair_fx_.assign(m, 0.0);
      pair_fy_.assign(m, 0.0);
      pair_couple_.assign(m, 0.0);
      pair_eff_radius_.resize(m);
      pair_eff_mass_.resize(m);
    }
    std::size_t next = 0;  // in `found`
#pragma omp for schedule(static)
    for (int i = 0; i < n; ++i) {
      for (int e = pair_start_[i]; e < pair_start_[i + 1]; ++e) pair_j_[e] = found[next++];
      std::sort(pair_j_.begin() + pair_start_[i], pair_j_.begin() + pair_start_[i + 1]);
      for (int e = pair_start_[i]; e < pair_start_[i + 1]; ++e) {
        const int j = pair_j_[e];
        pair_i_[e] = i;
        pair_eff_radius_[e] = EffectiveRadius(bodies_->disc_radius_[i], bodies_->disc_radius_[j]);
        pair_eff_mass_[e] =
            EffectiveMass(bodies_->body_mass_[bodies_->disc_body_[i]], bodies_->body_mass_[bodies_->disc_body_[j]]);
      }
      // History transfer: both segments are sorted by j.
      int o = i < old_n ? old_pair_start_[i] : 0;
      const int oend = i < old_n ? old_pair_start_[i + 1] : 0;
      for (int e = pair_start_[i]; e < pair_start_[i + 1]; ++e) {
        while (o < oend && old_pair_j_[o] < pair_j_[e]) ++o;
        if (o < oend && old_pair_j_[o] == pair_j_[e]) {
          pair_shear_x_[e] = old_pair_shear_x_[o];
          pair_shear_y_[e] = old_pair_shear_y_[o];
        } else {
          pair_shear_x_[e] = 0.0;
          pair_shear_y_[e] = 0.0;
        }
      }
    }
  }
  // Transpose of the entries that cross into a later force block.
  const int block = params_->force_block;
  const int nblocks = (n + block - 1) / block;
  block_last_partner_.resize(static_cast<std::size_t>(nblocks));
  block_first_source_.resize(static_cast<std::size_t>(nblocks));
  for (int b = 0; b < nblocks; ++b) {
    const int i1 = std::min(n, (b + 1) * block);
    int last = i1 - 1;
    for (int e = pair_start_[b * block]; e < pair_start_[i1]; ++e) last = std::max(last, pair_j_[e]);
    block_last_partner_[b] = last;
    block_first_source_[b] = b;
  }
  cross_start_.assign(static_cast<std::size_t>(n) + 1, 0);
  for (int i = 0; i < n; ++i) {
    const int block_end = (i / block + 1) * block;
    for (int e = pair_start_[i]; e < pair_start_[i + 1]; ++e)
      if (pair_j_[e] >= block_end) {
        ++cross_start_[pair_j_[e] + 1];
        int& first = block_first_source_[pair_j_[e] / block];
        first = std::min(first, i / block);
      }
  }
  std::partial_sum(cross_start_.begin(), cross_start_.end(), cross_start_.begin());
  cross_fill_.assign(cross_start_.begin(), cross_start_.end() - 1);
  cross_entry_.resize(static_cast<std::size_t>(cross_start_[n]));
  for (int i = 0; i < n; ++i) {
    const int block_end = (i / block + 1) * block;
    for (int e = pair_start_[i]; e < pair_start_[i + 1]; ++e)
      if (pair_j_[e] >= block_end) cross_entry_[cross_fill_[pair_j_[e]]++] = e;
  }

  // Wall list: the elements within reach of each disc, counted per disc and then written in
  // place (both loops static over the same range, as the pair list), with the history of the
  // continuing contacts.
  const int ne = static_cast<int>(geometry_->elements.size());
  auto for_walls = [&](int i, auto&& visit) {
    if (!bodies_->body_active_[bodies_->disc_body_[i]]) return;
    for (int e = 0; e < ne; ++e) {
      const silo::WallElement& el = geometry_->elements[e];
      if (!ElementActive(el, outlets_open)) continue;
      double reach = bodies_->disc_radius_[i] + skin;
      double qx, qy;
      if (el.kind == silo::ElementKind::kSegment) {
        // Keep segments whose line is within reach, even if the foot is just outside the
        // segment now: the disc may slide onto it before the next rebuild.
        const double sx = el.bx - el.ax, sy = el.by - el.ay;
        const double len2 = sx * sx + sy * sy;
        const double t =
            std::clamp(((bodies_->disc_x_[i] - el.ax) * sx + (bodies_->disc_y_[i] - el.ay) * sy) / len2, 0.0, 1.0);
        qx = el.ax + t * sx;
        qy = el.ay + t * sy;
      } else {
        qx = el.ax;
        qy = el.ay;
        reach += el.radius;
      }
      const double ddx = bodies_->disc_x_[i] - qx, ddy = bodies_->disc_y_[i] - qy;
      if (ddx * ddx + ddy * ddy < reach * reach) visit(e);
    }
  };
  wall_start_.resize(static_cast<std::size_t>(n) + 1);
#pragma omp parallel if (parallel)
  {
#pragma omp for schedule(static)
    for (int i = 0; i < n; ++i) {
      int count = 0;
      for_walls(i, [&](int) { ++count; });
      wall_start_[i + 1] = count;
      rebuild_x_[i] = bodies_->disc_x_[i];
      rebuild_y_[i] = bodies_->disc_y_[i];
    }
#pragma omp single
    {
      wall_start_[0] = 0;
      std::partial_sum(wall_start_.begin(), wall_start_.end(), wall_start_.begin());
      const std::size_t m = static_cast<std::size_t>(wall_start_[n]);
      wall_element_.resize(m);
      wall_disc_.resize(m);
      wall_shear_x_.resize(m);
      wall_shear_y_.resize(m);
      wall_fx_.assign(m, 0.0);
      wall_fy_.assign(m, 0.0);
    }
#pragma omp for schedule(static)
    for (int i = 0; i < n; ++i) {
      int k = wall_start_[i];
      int o = i < old_wn ? old_wall_start_[i] : 0;
      const int oend = i < old_wn ? old_wall_start_[i + 1] : 0;
      for_walls(i, [&](int e) {
        while (o < oend && old_wall_element_[o] < e) ++o;
        const bool had = o < oend && old_wall_element_[o] == e;
        wall_element_[k] = e;
        wall_disc_[k] = i;
        wall_shear_x_[k] = had ? old_wall_shear_x_[o] : 0.0;
        wall_shear_y_[k] = had ? old_wall_shear_y_[o] : 0.0;
        ++k;
      });
    }
  }
}

void NeighbourLists::ExportHistory(std::vector<HistoryEntry>& pairs, std::vector<HistoryEntry>& walls) const {
  pairs.clear();
  walls.clear();
  const int n = static_cast<int>(pair_start_.empty() ? 0 : pair_start_.size() - 1);
  for (int i = 0; i < n; ++i) {
    for (int e = pair_start_[i]; e < pair_start_[i + 1]; ++e)
      if (pair_shear_x_[e] != 0.0 || pair_shear_y_[e] != 0.0)
        pairs.push_back({i, pair_j_[e], pair_shear_x_[e], pair_shear_y_[e]});
    for (int k = wall_start_[i]; k < wall_start_[i + 1]; ++k)
      if (wall_shear_x_[k] != 0.0 || wall_shear_y_[k] != 0.0)
        walls.push_back({i, wall_element_[k], wall_shear_x_[k], wall_shear_y_[k]});
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

void NeighbourLists::ImportHistory(const std::vector<HistoryEntry>& pairs, const std::vector<HistoryEntry>& walls) {
  // Present the stored entries as the "current" lists; the rebuild transfers them.
  HistoryToCsr(pairs, bodies_->DiscCount(), "pair", pair_start_, pair_j_, pair_shear_x_, pair_shear_y_);
  HistoryToCsr(walls, bodies_->DiscCount(), "wall", wall_start_, wall_element_, wall_shear_x_, wall_shear_y_);
}

void NeighbourLists::CollectContacts(std::vector<ContactView>& out) const {
  out.clear();
  const int n = static_cast<int>(pair_start_.empty() ? 0 : pair_start_.size() - 1);
  for (int i = 0; i < n; ++i) {
    for (int e = pair_start_[i]; e < pair_start_[i + 1]; ++e) {
      if (pair_fx_[e] == 0.0 && pair_fy_[e] == 0.0) continue;
      const int j = pair_j_[e];
      const double ddx = bodies_->disc_x_[i] - bodies_->disc_x_[j], ddy = bodies_->disc_y_[i] - bodies_->disc_y_[j];
      const double r = std::sqrt(ddx * ddx + ddy * ddy);
      out.push_back({i, j, -1, bodies_->disc_x_[i] - bodies_->disc_radius_[i] * ddx / r,
                     bodies_->disc_y_[i] - bodies_->disc_radius_[i] * ddy / r, pair_fx_[e], pair_fy_[e]});
    }
    for (int k = wall_start_[i]; k < wall_start_[i + 1]; ++k) {
      if (wall_fx_[k] == 0.0 && wall_fy_[k] == 0.0) continue;
      const silo::Closest q =
          silo::ClosestPoint(geometry_->elements[wall_element_[k]], bodies_->disc_x_[i], bodies_->disc_y_[i]);
      double cx = q.qx, cy = q.qy;
      const silo::WallElement& el = geometry_->elements[wall_element_[k]];
      if (el.kind == silo::ElementKind::kCircle) {
        const double ddx = bodies_->disc_x_[i] - el.ax, ddy = bodies_->disc_y_[i] - el.ay;
        const double r = std::sqrt(ddx * ddx + ddy * ddy);
        cx = el.ax + el.radius * ddx / r;
        cy = el.ay + el.radius * ddy / r;
      }
      out.push_back({i, -1, wall_element_[k], cx, cy, wall_fx_[k], wall_fy_[k]});
    }
  }
}

void NeighbourLists::MarkBodiesInContact(std::vector<std::uint8_t>& out) const {
  out.assign(bodies_->body_x_.size(), 0);
  const int n = static_cast<int>(pair_start_.empty() ? 0 : pair_start_.size() - 1);
  for (int i = 0; i < n; ++i) {
    for (int e = pair_start_[i]; e < pair_start_[i + 1]; ++e) {
      if (pair_fx_[e] == 0.0 && pair_fy_[e] == 0.0) continue;
      out[static_cast<std::size_t>(bodies_->disc_body_[i])] = 1;
      out[static_cast<std::size_t>(bodies_->disc_body_[pair_j_[e]])] = 1;
    }
    for (int k = wall_start_[i]; k < wall_start_[i + 1]; ++k)
      if (wall_fx_[k] != 0.0 || wall_fy_[k] != 0.0) out[static_cast<std::size_t>(bodies_->disc_body_[i])] = 1;
  }
}

}  // namespace granary::engine
