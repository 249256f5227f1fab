// The Verlet neighbour lists and their contact history: a cell grid finds the pairs of discs
// of different bodies within their radii plus the skin, and the wall elements within a
// disc's radius plus the skin; a rebuild carries the shear history of the contacts that
// continue. The force pass writes each entry's history and force (force_pass.h).
#pragma once

#include <cstdint>
#include <vector>

#include "engine/body_store.h"
#include "engine/thread_shared.h"
#include "silo/geometry.h"

namespace granary::engine {

struct WorldParams;

// One stored contact history entry (for checkpoints): disc i with disc j (pair) or with wall
// element j (wall), shear displacement (sx, sy).
struct HistoryEntry {
  std::int32_t i, j;
  double sx, sy;
};

// A contact force of the last computation, for contact dumps: a pair (disc_i, disc_j, the
// force on disc_i) or a wall entry (disc_i and the element).
struct ContactView {
  int disc_i, disc_j;  // disc_j = -1 for walls
  int element;         // wall element, -1 for pairs
  double cx, cy, fx, fy;
};

// Whether a wall element takes part now (the plug before t = 0, the outlet edges after).
bool ElementActive(const silo::WallElement& e, bool outlets_open);

class NeighbourLists {
 public:
  NeighbourLists(const WorldParams& params, const BodyStore& bodies, const silo::SiloGeometry& geometry,
                 double max_radius)
      : max_radius_(max_radius) {
    Bind(params, bodies, geometry);
  }
  // What the lists are of (again after the owner has moved).
  void Bind(const WorldParams& params, const BodyStore& bodies, const silo::SiloGeometry& geometry) {
    params_ = &params;
    bodies_ = &bodies;
    geometry_ = &geometry;
  }

  // Room for the rebuild positions of `n` more discs (bodies added).
  void AddDiscs(int n);
  // New lists for the current disc positions; the history of the contacts that continue is
  // kept. `parallel`: the loops may use the threads.
  void Rebuild(bool outlets_open, bool parallel);
  // Whether a disc of an active body has moved more than half the skin since the last rebuild.
  bool NeedsRebuild(bool parallel) const;
  std::int64_t Rebuilds() const { return rebuilds_; }

  // Contact history for checkpoints: the nonzero entries; and the stored entries presented as
  // the current lists, for the next Rebuild to carry over (throws std::runtime_error for an
  // entry of a disc out of range).
  void ExportHistory(std::vector<HistoryEntry>& pairs, std::vector<HistoryEntry>& walls) const;
  void ImportHistory(const std::vector<HistoryEntry>& pairs, const std::vector<HistoryEntry>& walls);

  void CollectContacts(std::vector<ContactView>& out) const;
  void MarkBodiesInContact(std::vector<std::uint8_t>& out) const;

  // Pair list (CSR over disc i, partners j > i sorted), with per entry the shear history,
  // the force on i, the tangential couple n x F_t, and the pair's constants R_eff and m_eff
  // (computed at the rebuild).
  std::vector<int> pair_start_, pair_j_, pair_i_;  // pair_i_: disc i of each entry
  SharedVector<double> pair_shear_x_, pair_shear_y_, pair_fx_, pair_fy_, pair_couple_, pair_eff_radius_, pair_eff_mass_;
  // Transpose of the entries whose disc j lies in a later force block than i: for disc j,
  // those entries in ascending i (cross_fill_: the next free slot while it is built).
  std::vector<int> cross_start_, cross_entry_, cross_fill_;
  // Wall list (CSR over disc), with history and force; wall_disc_: the disc of each entry.
  std::vector<int> wall_start_, wall_element_, wall_disc_;
  SharedVector<double> wall_shear_x_, wall_shear_y_, wall_fx_, wall_fy_;
  // Disc positions at the last rebuild.
  SharedVector<double> rebuild_x_, rebuild_y_;
  SharedVector<int> block_last_partner_;  // per force block: its highest disc or partner j
  SharedVector<int> block_first_source_;  // per force block: first block with an entry into it

 private:
  const WorldParams* params_;
  const BodyStore* bodies_;
  const silo::SiloGeometry* geometry_;
  double max_radius_;  // of any template's discs: the cell size
  std::int64_t rebuilds_ = 0;
  // The previous lists during a rebuild (history transfer).
  std::vector<int> old_pair_start_, old_pair_j_, old_wall_start_, old_wall_element_;
  SharedVector<double> old_pair_shear_x_, old_pair_shear_y_, old_wall_shear_x_, old_wall_shear_y_;
  // Cell grid.
  std::vector<int> cell_start_, cell_disc_, disc_cell_, cell_count_;
  std::vector<std::vector<int>> rebuild_partners_;  // per thread: partners found in a rebuild
};

}  // namespace granary::engine
