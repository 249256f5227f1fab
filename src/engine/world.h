// The simulated system: a structure-of-arrays body store over shape templates,
// the wall elements, the Verlet neighbour lists with per-contact shear
// history, and the velocity-Verlet rigid-body step (docs/model.md).
//
// Determinism: every pair force is computed once, in a fixed block of discs (force_block),
// and summed per disc and per body in an order fixed by the disc numbering and the block
// size alone, so results do not depend on the thread count. The step loop allocates
// nothing once the vectors have reached their working size.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <vector>

#include "engine/contact_law.h"
#include "silo/geometry.h"
#include "silo/shapes.h"
#include "engine/thread_shared.h"

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
  // even measured work times (World::Rebalance). Which thread computes what changes no bit;
  // these are here to test that.
  bool rebalance_shares = true;
  double share_shift = 0.0;
};

WorldParams ParamsFromSpec(const RunSpec& spec);

// One stored contact history entry (for checkpoints): disc i with disc j (pair) or with wall
// element j (wall), shear displacement (sx, sy).
struct HistoryEntry {
  std::int32_t i, j;
  double sx, sy;
};

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

class World {
 public:
  // What the pair loop reads of a partner disc, in one cache line: position, velocity,
  // radius and the body's angular velocity (written with the disc positions each step).
  struct alignas(64) DiscKin {
    double x, y, vx, vy, r, w;
    double pad0 = 0.0, pad1 = 0.0;  // written with the rest: the disc loop's stores fill the line
  };

  World(WorldParams params, std::vector<silo::ShapeTemplate> templates, silo::SiloGeometry geometry);

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
  void SetExitBox(double xmin, double xmax, double ymin);
  bool BeyondExitBox() const { return beyond_exit_box_; }
  // Rebuild the lists at the next force computation (after adding/moving/removing bodies).
  void RequestRebuild() { rebuild_needed_ = true; }

  // Diagnostics.
  double KineticEnergy() const;  // sum over active bodies, translational + rotational
  double MaxDiscTop() const;     // max y + r over active discs (0 if none)
  int ActiveCount() const { return active_count_; }
  int BodyCount() const { return static_cast<int>(bx_.size()); }
  int DiscCount() const { return static_cast<int>(dr_.size()); }
  // Discs of the active bodies: the discs a step computes (a loop over the bodies).
  int ActiveDiscCount() const;
  std::int64_t Rebuilds() const { return rebuilds_; }

  // Contact history for checkpoints: the nonzero entries, and restoring them (the lists are
  // rebuilt from positions; a rebuild is forced when saving so that a continued run and an
  // uninterrupted one rebuild at the same steps).
  void ExportHistory(std::vector<HistoryEntry>& pairs, std::vector<HistoryEntry>& walls) const;
  void ImportHistory(const std::vector<HistoryEntry>& pairs, const std::vector<HistoryEntry>& walls);
  // Force the list rebuild now (keeps the history of continuing contacts).
  void RebuildNow();
  // The state to continue from (rebuilds the lists first: see WorldSnapshot).
  WorldSnapshot Snapshot();
  // Restores a snapshot into a world that has no bodies yet and was built with the same
  // parameters, templates and geometry. Throws std::invalid_argument if it does not fit.
  void Restore(const WorldSnapshot& snapshot);

  const WorldParams& Params() const { return params_; }
  const std::vector<silo::ShapeTemplate>& Templates() const { return templates_; }
  const silo::SiloGeometry& Geometry() const { return geometry_; }
  // Whether a wall element takes part now (the plug before t = 0, the outlet edges after).
  bool ElementActive(const silo::WallElement& e) const;

  // Body state (public SoA for the drivers, tests and writers).
  std::vector<int> tmpl_;
  std::vector<std::uint8_t> active_;
  SharedVector<double> bx_, by_, bth_, bvx_, bvy_, bw_, bfx_, bfy_, btq_, bmass_, binertia_;
  // Orientation as (cos, sin), rotated by omega dt each step (no libm call per body and
  // step); theta is integrated alongside for reference. Checkpoints store both.
  SharedVector<double> bc_, bs_;
  SharedVector<double> binv_mass_, binv_inertia_;  // 1/M and 1/I (the step multiplies)
  std::vector<int> disc_begin_;  // per body; discs [disc_begin_[b], disc_begin_[b] + n)
  std::vector<int> disc_n_;
  // Disc state: owning body, radius, mass, body-frame offset, world position.
  std::vector<int> dbody_;
  SharedVector<double> dr_, dmass_, dox_, doy_, dx_, dy_;
  // Per-disc accumulated force and torque about the disc centre (last force computation).
  SharedVector<double> dfx_, dfy_, dtz_;

  // Contact forces of the last computation, for contact dumps: pair entries (i, j, force on i)
  // and wall entries.
  struct ContactView {
    int disc_i, disc_j;  // disc_j = -1 for walls
    int element;         // wall element, -1 for pairs
    double cx, cy, fx, fy;
  };
  void CollectContacts(std::vector<ContactView>& out) const;
  // out[b] = 1 where body b had a contact force (with a body or a wall) in the last force
  // computation, else 0 (a body in free flight).
  void MarkBodiesInContact(std::vector<std::uint8_t>& out) const;

 private:
  // Disc positions and velocities of body b from the body state.
  void UpdateDiscs(int b);
  // Forces of the current state; with `kick`, also the second half kick of a step.
  void Forces(bool rebuild, bool kick);
  // The kernels of a step, each over a range that one thread owns (compiled for several
  // instruction sets, chosen at load time; the arithmetic is the same in each).
  void PairEntriesOf(int i0, int i1);            // the pair entries of discs [i0, i1)
  // Sums and wall forces of discs [i0, i1) of one force block; `earlier`: the entries from
  // the block's discs before i0 into them (LeadSources).
  void SumPartForces(int i0, int i1, const std::vector<int>& earlier);
  template <class Normal, bool kLiggghtsCap>
  void PairRange(int e0, int e1);                // the pair loop over list entries [e0, e1)
  template <class Normal, bool kLiggghtsCap>
  void WallEntries(int k0, int k1, const ContactParams& wp);  // the wall loop of a force block
  // Cross-block reactions, body sums, kick; returns whether the next drift may take a disc
  // of these bodies beyond half the skin from its rebuild position (OutrunsSkin).
  bool BodyForces(int b0, int b1, bool kick);
  // The pair entries, block sums and BodyForces, shared by the threads; with `await_drift`,
  // pair entries first wait for the drift of the discs they read (Step's drift publishes it
  // with `pass`). Returns BodyForces' verdict for the thread's bodies.
  // Adds the seconds the thread waited for others to *waited, if given.
  bool ForcePasses(bool kick, std::int64_t pass, bool await_drift, double* waited = nullptr);
  // Thread t's of nt shares, contiguous and about even in work: body chunks
  // [ChunkShareStart(t), ChunkShareStart(t + 1)) for the drift and the body sums, and their
  // discs [PairShareStart(t), PairShareStart(t + 1)) for the pair entries and sums.
  // The shares start even in list entries + discs; Rebalance moves them towards even
  // measured times.
  // (NextForcePass works them out once per region, for omp_get_max_threads() threads;
  // FindShareStart finds one.)
  int ChunkShareStart(int t, int nt) const;
  int PairShareStart(int t, int nt) const;
  int FindShareStart(int t, int nt) const;
  SharedVector<int> share_starts_;  // ChunkShareStart(t, share_team_) for t = 0..share_team_
  int share_team_ = 0;
  // The entries from the discs of i0's force block before i0 into discs [i0, i1), ascending
  // (thread t's, kept until the lists or the bounds change).
  const std::vector<int>& LeadSources(int t, int i0, int i1);
  // Half kick and drift; flags: kDriftMoved (a disc moved > skin/2 since the rebuild),
  // kDriftBeyond (an active body's centre is outside the exit box).
  int DriftBodies(int b0, int b1);
  int DriftPortable(int b0, int b1);  // DriftBodies without the AVX-512 loops
  int DriftBodyKernel(int b0, int b1);  // its body part: returns kBeyond (world.cpp)
  static constexpr int kDriftMoved = 1, kDriftBeyond = 2;
  static constexpr int kBodyChunk = 64;          // bodies per parallel work item (small: even shares)
  static constexpr int kChunksPerCall = 8;       // chunks per call of the drift and body loops (fewer calls)
  void Rebuild();
  bool NeedsRebuild() const;
  bool Parallel() const { return DiscCount() >= params_.parallel_min_discs; }

  WorldParams params_;
  std::vector<silo::ShapeTemplate> templates_;
  silo::SiloGeometry geometry_;
  bool outlets_open_ = false;
  bool rebuild_needed_ = true;
  int active_count_ = 0;
  std::int64_t rebuilds_ = 0;
  double max_radius_ = 0.0;
  double exit_box_[3] = {0.0, 0.0, 0.0};
  bool exit_box_set_ = false;
  bool beyond_exit_box_ = true;
  int uniform_discs_ = -1;  // discs per body if all bodies have as many, else -1
  int max_discs_ = 0;       // the most discs of any body
  bool use_avx512_ = false;  // params_.avx512_kernels and the CPU has AVX-512F
  // Which force pass each force block has finished (ForcePasses): a thread's body forces wait
  // for the blocks they read, not for every thread at a barrier. A pair of cache lines each
  // (thread_shared.h).
  struct alignas(kThreadSharedAlign) PassStamp {
    std::atomic<std::int64_t> pass{-1};
  };
  std::unique_ptr<PassStamp[]> block_done_;
  int block_done_count_ = 0;
  // Which pass each body chunk's drift has finished: a pair block waits for the chunks that
  // hold its discs and partners (from the first disc to block_last_partner_).
  std::unique_ptr<PassStamp[]> chunk_done_;
  int chunk_done_count_ = 0;
  // Per thread: the pass whose pair entries it has computed in the block an earlier thread
  // sums (ForcePasses).
  std::unique_ptr<PassStamp[]> share_done_;
  int share_done_count_ = 0;
  struct alignas(kThreadSharedAlign) LeadSourceCache {
    std::int64_t rebuild = -1;
    int i0 = -1, i1 = -1;
    std::vector<int> entries;
  };
  std::vector<LeadSourceCache> lead_sources_;  // per thread (LeadSources)
  // Per thread, in a region of several steps (StepsInOneRegion): the last step it has
  // finished and its drift and force flags, in a slot by the step's parity (a thread is at
  // most one step ahead of another when it reads them).
  struct alignas(kThreadSharedAlign) StepDone {
    std::atomic<std::int64_t> pass{-1};
    int flags[2] = {0, 0};
  };
  std::unique_ptr<StepDone[]> step_done_;
  // Steps without a rebuild in one parallel region (Steps); returns how many were taken.
  int StepsInOneRegion(int max_steps);
  // Thread t's of nt share of the drift (body chunks), publishing each chunk with `pass`.
  int DriftShare(int t, int nt, std::int64_t pass);
  static constexpr int kStepOutrun = 4;  // (with kDriftMoved and kDriftBeyond in a step's flags)
  // Every kBalanceEvery steps in regions of a team of nt threads, moves the share boundaries
  // towards even measured work times (thread_busy_, waits excluded): a disc or an entry does
  // not cost the same in every part of the bed, nor next to another core's share (its data
  // cross between the cores). Which thread computes what changes no bit.
  void Rebalance(int nt, int steps);
  static constexpr int kBalanceEvery = 100;
  struct alignas(kThreadSharedAlign) ThreadClock {
    double busy = 0.0;  // seconds worked, not waited, since the last Rebalance
  };
  std::unique_ptr<ThreadClock[]> thread_busy_;
  std::vector<double> share_shift_;  // per share boundary t: shift of its work target (a fraction of all work)
  int balance_team_ = 0;             // the team share_shift_ is for (0: none yet)
  int balance_steps_ = 0;
  SharedVector<int> block_last_partner_;  // per force block: its highest disc or partner j
  SharedVector<int> block_first_source_;  // per force block: first block with an entry into it
  // Set by the force pass: the next step must rebuild the lists (OutrunsSkin), so the
  // step knows it before its drift and needs no barrier to find out.
  bool rebuild_predicted_ = true;
  std::vector<double> bradius_;  // per body: largest distance of a disc centre from the body's centre
  std::int64_t force_pass_ = 0;
  // Numbers a force pass, sizes the stamps and works out the shares (before the parallel
  // region: lists and shares do not change inside one).
  std::int64_t NextForcePass();

  SharedVector<DiscKin> kin_;
  // Pair list (CSR over disc i, j > i sorted), with history, per-entry force and the
  // pair's constants R_eff and m_eff (computed at the rebuild).
  std::vector<int> nl_start_, nl_j_, nl_i_;  // nl_i_: disc i of each entry
  SharedVector<double> nl_sx_, nl_sy_, nl_fx_, nl_fy_, nl_c_, nl_reff_, nl_meff_;
  // Transpose of the entries whose disc j lies in a later force block than i: for disc j,
  // those entries in ascending i.
  std::vector<int> xl_start_, xl_entry_, xl_fill_;
  // Wall list (CSR over disc), with history; wl_i_: disc of each entry.
  std::vector<int> wl_start_, wl_e_, wl_i_;
  SharedVector<double> wl_sx_, wl_sy_, wl_fx_, wl_fy_;
  // Previous lists during a rebuild (history transfer).
  std::vector<int> old_start_, old_j_, old_wstart_, old_we_;
  SharedVector<double> old_sx_, old_sy_, old_wsx_, old_wsy_;
  // Reference positions of the last rebuild.
  SharedVector<double> refx_, refy_;
  // Cell grid.
  std::vector<int> cell_start_, cell_disc_, disc_cell_, cell_count_;
  std::vector<std::vector<int>> rebuild_partners_;  // per thread: partners found in a rebuild
};

}  // namespace granary::engine
