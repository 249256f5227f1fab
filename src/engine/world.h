// The simulated system: a structure-of-arrays body store over shape templates
// (style.md 8.2), the wall elements, the Verlet neighbour lists with per-contact shear
// history, and the velocity-Verlet rigid-body step (physics.md).
//
// Determinism: every pair force is computed once into a per-contact slot and gathered per
// disc and per body in a fixed order, so results do not depend on the thread count. The
// step loop allocates nothing once the vectors have reached their working size.
#pragma once

#include <cstdint>
#include <vector>

#include "engine/contact_law.h"
#include "engine/geometry.h"
#include "engine/shapes.h"

namespace granary::engine {

struct WorldParams {
  double dt = 1e-4;
  double gravity = 1.0;
  ContactParams pair;   // body-body
  ContactParams wall;   // body-wall and body-obstacle (mu_wall)
  double skin = 0.2;    // Verlet-list skin in d (0.1-0.5 measured: 0.2 balances list length and serial rebuilds)
  // Below this many discs the loops run on one thread: forking costs more than it saves
  // (results are the same either way).
  int parallel_min_discs = 2000;
};

WorldParams ParamsFromSpec(const RunSpec& spec);

// One stored contact history entry (for checkpoints): disc i with disc j (pair) or with wall
// element j (wall), shear displacement (sx, sy).
struct HistoryEntry {
  std::int32_t i, j;
  double sx, sy;
};

class World {
 public:
  World(WorldParams params, std::vector<ShapeTemplate> templates, SiloGeometry geometry);

  // Adds a body of template `tmpl` at rest; returns its id. Discs of a body are contiguous.
  int AddBody(int tmpl, double x, double y, double theta);
  void SetVelocity(int body, double vx, double vy, double omega);
  // Moves a body (reinjection) and clears its contacts at the next list rebuild.
  void PlaceBody(int body, double x, double y, double theta, double vx, double vy, double omega);
  void Deactivate(int body);
  // Switches the plug off and the outlet edges on (t = 0).
  void OpenOutlets();
  void CloseOutlets();
  bool outlets_open() const { return outlets_open_; }

  // Computes forces for the current state (call once before the first Step, and after
  // changing bodies from outside). Rebuilds the neighbour lists if needed.
  void ComputeForces();
  // One velocity-Verlet step of dt.
  void Step();
  // Recomputes every disc's position and velocity from the body state (after restoring it).
  void RefreshDiscs();
  // Rebuild the lists at the next force computation (after adding/moving/removing bodies).
  void RequestRebuild() { rebuild_needed_ = true; }

  // Diagnostics.
  double KineticEnergy() const;  // sum over active bodies, translational + rotational
  double MaxDiscTop() const;     // max y + r over active discs (0 if none)
  int active_count() const { return active_count_; }
  int body_count() const { return static_cast<int>(bx_.size()); }
  int disc_count() const { return static_cast<int>(dr_.size()); }
  std::int64_t rebuilds() const { return rebuilds_; }

  // Contact history for checkpoints: the nonzero entries, and restoring them (the lists are
  // rebuilt from positions; a rebuild is forced when saving so that a continued run and an
  // uninterrupted one rebuild at the same steps).
  void ExportHistory(std::vector<HistoryEntry>& pairs, std::vector<HistoryEntry>& walls) const;
  void ImportHistory(const std::vector<HistoryEntry>& pairs, const std::vector<HistoryEntry>& walls);
  // Force the list rebuild now (keeps the history of continuing contacts).
  void RebuildNow();

  const WorldParams& params() const { return params_; }
  const std::vector<ShapeTemplate>& templates() const { return templates_; }
  const SiloGeometry& geometry() const { return geometry_; }

  // Body state (public SoA for the drivers, tests and writers).
  std::vector<int> tmpl_;
  std::vector<std::uint8_t> active_;
  std::vector<double> bx_, by_, bth_, bvx_, bvy_, bw_, bfx_, bfy_, btq_, bmass_, binertia_;
  // Orientation as (cos, sin), rotated by omega dt each step (no libm call per body and
  // step); theta is integrated alongside for reference. Checkpoints store both.
  std::vector<double> bc_, bs_;
  std::vector<double> binv_mass_, binv_inertia_;  // 1/M and 1/I (the step multiplies)
  std::vector<int> disc_begin_;  // per body; discs [disc_begin_[b], disc_begin_[b] + n)
  std::vector<int> disc_n_;
  // Disc state: owning body, radius, mass, body-frame offset, world position and velocity.
  std::vector<int> dbody_;
  std::vector<double> dr_, dmass_, dox_, doy_, dx_, dy_, dvx_, dvy_;
  // Per-disc accumulated force and torque about the disc centre (last force computation).
  std::vector<double> dfx_, dfy_, dtz_;

  // Contact forces of the last computation, for contact dumps: pair entries (i, j, force on i)
  // and wall entries.
  struct ContactView {
    int disc_i, disc_j;  // disc_j = -1 for walls
    int element;         // wall element, -1 for pairs
    double cx, cy, fx, fy;
  };
  void CollectContacts(std::vector<ContactView>& out) const;

 private:
  void UpdateDiscs(int b);
  // Max squared displacement of body b's discs since the last rebuild.
  double Displacement2(int b) const;
  void Forces(bool rebuild);
  void Rebuild();
  bool NeedsRebuild() const;
  bool ElementActive(const WallElement& e) const;
  bool Parallel() const { return disc_count() >= params_.parallel_min_discs; }

  WorldParams params_;
  std::vector<ShapeTemplate> templates_;
  SiloGeometry geometry_;
  bool outlets_open_ = false;
  bool rebuild_needed_ = true;
  int active_count_ = 0;
  std::int64_t rebuilds_ = 0;
  double max_radius_ = 0.0;

  // Pair list (CSR over disc i, j > i sorted), with history and per-entry force.
  std::vector<int> nl_start_, nl_j_;
  std::vector<double> nl_sx_, nl_sy_, nl_fx_, nl_fy_, nl_c_;
  // Transpose: for disc j, the entries where it is the second disc, in ascending i.
  std::vector<int> tl_start_, tl_entry_, tl_fill_;
  // Wall list (CSR over disc), with history.
  std::vector<int> wl_start_, wl_e_;
  std::vector<double> wl_sx_, wl_sy_, wl_fx_, wl_fy_;
  // Previous lists during a rebuild (history transfer).
  std::vector<int> old_start_, old_j_, old_wstart_, old_we_;
  std::vector<double> old_sx_, old_sy_, old_wsx_, old_wsy_;
  // Reference positions of the last rebuild.
  std::vector<double> refx_, refy_;
  // Cell grid.
  std::vector<int> cell_start_, cell_disc_, disc_cell_, cell_count_;
  std::vector<int> cand_;
};

}  // namespace granary::engine
