// The simulated system: the body store (body_store.h) over shape templates, the wall
// elements, and the parts of a velocity-Verlet step of rigid clumps (docs/model.md), each in
// a unit of its own: the neighbour lists with their contact history (neighbour_lists.h), the
// force pass (force_pass.h), the drift (integrator.h) and the threads' shares of the work
// (thread_shares.h). World owns them and runs the steps.
//
// Determinism: results do not depend on the thread count (force_pass.h). The step loop
// allocates nothing once the vectors have reached their working size.
#pragma once

#include <cstdint>
#include <vector>

#include "engine/body_store.h"
#include "engine/contact_law.h"
#include "engine/force_pass.h"
#include "engine/integrator.h"
#include "engine/neighbour_lists.h"
#include "engine/thread_shares.h"
#include "silo/geometry.h"
#include "silo/shapes.h"

namespace granary::engine {

struct WorldParams {
  double dt = 1e-4;
  double gravity = 1.0;
  ContactParams pair;  // body-body
  ContactParams wall;  // body-wall and body-obstacle (mu_wall)
  double skin = 0.2;   // Verlet-list skin in d (0.1-0.5 measured: 0.2 balances list length and serial rebuilds)
  // Below this many discs the loops run on one thread: forking costs more than it saves
  // (results are the same either way).
  int parallel_min_discs = 2000;
  // Discs per block of the pair-force pass: a thread takes whole blocks, and the partner
  // forces inside a block are added at once (Newton's third law); those crossing into a
  // later block are gathered afterwards. Results depend on this number (last bits), not on
  // the thread count.
  int force_block = 1024;
  // The pair loop and the dumbbells' disc placement in AVX-512 intrinsics where the CPU has
  // it (avx512_kernels.h). The results are the same to the bit either way; off only to
  // compare the two.
  bool avx512_kernels = true;
  // With two threads or more, the share boundaries start where list entries + discs split
  // evenly, shifted by `share_shift` (a fraction of all that work), and then move towards
  // even measured work times (ThreadShares::Rebalance). Which thread computes what changes no bit;
  // these are here to test that.
  bool rebalance_shares = true;
  double share_shift = 0.0;
};

WorldParams ParamsFromSpec(const RunSpec& spec);

// Everything of a world's state that a run continues from (checkpoints): per body its
// template, activity and state, including the last forces and the integrated orientation
// (cos, sin); the nonzero contact histories; the outlets; and the last force pass's verdict on
// the next rebuild. Taking a snapshot rebuilds the lists and restoring one rebuilds them at
// the same state, so a world continued from a snapshot steps to the same bits as the world
// it was taken from (Run.ContinuedRunEqualsUninterruptedRun and others).
struct WorldSnapshot {
  std::vector<int> tmpl;
  std::vector<std::uint8_t> active;
  std::vector<double> x, y, theta, c, s, vx, vy, w, fx, fy, torque;
  std::vector<HistoryEntry> pairs, walls;
  bool outlets_open = false;
  bool rebuild_predicted = true;
};

// The body store's arrays are World's public members (for the drivers, tests and writers).
class World : public BodyStore {
 public:
  using DiscKin = engine::DiscKin;
  using ContactView = engine::ContactView;

  World(WorldParams params, std::vector<silo::ShapeTemplate> templates, silo::SiloGeometry geometry);
  // The parts point to the body store, the parameters and each other: a moved world points
  // them to itself.
  World(World&& other) noexcept;
  World(const World&) = delete;
  World& operator=(const World&) = delete;

  // Adds a body of template `tmpl` at rest; returns its id. Discs of a body are contiguous.
  int AddBody(int tmpl, double x, double y, double theta);
  void SetVelocity(int body, double vx, double vy, double omega);  // (rebuilds the lists at the next step)
  // Moves a body (reinjection) and clears its contacts at the next list rebuild.
  void PlaceBody(int body, double x, double y, double theta, double vx, double vy, double omega);
  void Deactivate(int body);
  // Switches the plug off and the outlet edges on (t = 0).
  void OpenOutlets();
  void CloseOutlets();
  bool OutletsOpen() const { return outlets_open_; }

  // Computes forces for the current state (call once before the first Step, and after
  // changing bodies from outside). Rebuilds the neighbour lists if needed.
  void ComputeForces();
  // One velocity-Verlet step of dt.
  void Step();
  // Up to `max_steps` steps, the same bits as as many Step() calls; returns how many were
  // taken. Returns early after a step that leaves a body beyond the exit box (then
  // BeyondExitBox() is true), so the driver handles exits at the step it would have. Steps
  // that do not rebuild the lists share one parallel region: the threads meet at a
  // light barrier between steps instead of a region's fork and join each step.
  int Steps(int max_steps);
  // Recomputes every disc's position and velocity from the body state (after restoring it).
  void RefreshDiscs();
  // The exit box: after each step, whether an active body's centre lies left of xmin,
  // right of xmax or below ymin (computed in the drift, so the driver need not look at every
  // body each step). Without a box it is always true.
  void SetExitBox(double xmin, double xmax, double ymin) { integrator_.SetExitBox(xmin, xmax, ymin); }
  bool BeyondExitBox() const { return beyond_exit_box_; }
  // Rebuild the lists at the next force computation (after adding/moving/removing bodies).
  void RequestRebuild() { rebuild_needed_ = true; }

  // Diagnostics.
  double KineticEnergy() const;  // sum over active bodies, translational + rotational
  double MaxDiscTop() const;     // max y + r over active discs (0 if none)
  int ActiveCount() const { return active_count_; }
  // Discs of the active bodies: the discs a step computes (a loop over the bodies).
  int ActiveDiscCount() const;
  std::int64_t Rebuilds() const { return lists_.Rebuilds(); }

  // Contact history for checkpoints: the nonzero entries, and restoring them (the lists are
  // rebuilt from positions; a rebuild is forced when saving so that a continued run and an
  // uninterrupted one rebuild at the same steps).
  void ExportHistory(std::vector<HistoryEntry>& pairs, std::vector<HistoryEntry>& walls) const {
    lists_.ExportHistory(pairs, walls);
  }
  void ImportHistory(const std::vector<HistoryEntry>& pairs, const std::vector<HistoryEntry>& walls);
  // Force the list rebuild now (keeps the history of continuing contacts).
  void RebuildNow() { Rebuild(); }
  // The state to continue from (rebuilds the lists first: see WorldSnapshot).
  WorldSnapshot Snapshot();
  // Restores a snapshot into a world that has no bodies yet and was built with the same
  // parameters, templates and geometry. Throws std::invalid_argument if it does not fit.
  void Restore(const WorldSnapshot& snapshot);

  const WorldParams& Params() const { return params_; }
  const std::vector<silo::ShapeTemplate>& Templates() const { return templates_; }
  const silo::SiloGeometry& Geometry() const { return geometry_; }
  // Whether a wall element takes part now (the plug before t = 0, the outlet edges after).
  bool ElementActive(const silo::WallElement& e) const { return engine::ElementActive(e, outlets_open_); }

  // Contact forces of the last computation, for contact dumps.
  void CollectContacts(std::vector<ContactView>& out) const { lists_.CollectContacts(out); }
  // out[b] = 1 where body b had a contact force (with a body or a wall) in the last force
  // computation, else 0 (a body in free flight).
  void MarkBodiesInContact(std::vector<std::uint8_t>& out) const { lists_.MarkBodiesInContact(out); }

 private:
  // Forces of the current state; with `kick`, also the second half kick of a step.
  void Forces(bool rebuild, bool kick);
  // Steps without a rebuild in one parallel region (Steps); returns how many were taken.
  int StepsInOneRegion(int max_steps);
  // Numbers a force pass and readies the shares and per-thread state for it (before the
  // parallel region: lists and shares do not change inside one).
  std::int64_t NextForcePass();
  void Rebuild();
  bool Parallel() const { return DiscCount() >= params_.parallel_min_discs; }
  // (with Integrator::kDriftMoved and kDriftBeyond in a step's flags)
  static constexpr int kStepOutrun = 4;

  WorldParams params_;
  std::vector<silo::ShapeTemplate> templates_;
  silo::SiloGeometry geometry_;
  bool outlets_open_ = false;
  bool rebuild_needed_ = true;
  int active_count_ = 0;
  bool beyond_exit_box_ = true;
  // Set by the force pass: the next step must rebuild the lists (a disc may outrun the
  // skin), so the step knows it before its drift and needs no barrier to find out.
  bool rebuild_predicted_ = true;
  // The parts of a step (in this order: each refers to those before it).
  NeighbourLists lists_;
  ThreadShares shares_;
  ForcePass forces_;
  Integrator integrator_;
};

}  // namespace granary::engine
