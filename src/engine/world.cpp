// The world's bodies and the step loop over its parts (world.h).
#include "engine/world.h"

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

#include "engine/avx512_kernels.h"

namespace granary::engine {

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
    : params_(params),
      templates_(std::move(templates)),
      geometry_(std::move(geometry)),
      lists_(params_, *this, geometry_,
             [&] {
               double r = 0.0;
               for (const silo::ShapeTemplate& t : templates_)
                 for (double d : t.r) r = std::max(r, d);
               return r;
             }()),
      shares_(params_, *this, lists_),
      forces_(params_, geometry_, *this, lists_, shares_, params_.avx512_kernels && Avx512Available()),
      integrator_(params_, *this, lists_, shares_, params_.avx512_kernels && Avx512Available()) {}

World::World(World&& other) noexcept
    : BodyStore(std::move(other)),
      params_(other.params_),
      templates_(std::move(other.templates_)),
      geometry_(std::move(other.geometry_)),
      outlets_open_(other.outlets_open_),
      rebuild_needed_(other.rebuild_needed_),
      active_count_(other.active_count_),
      beyond_exit_box_(other.beyond_exit_box_),
      rebuild_predicted_(other.rebuild_predicted_),
      lists_(std::move(other.lists_)),
      shares_(std::move(other.shares_)),
      forces_(std::move(other.forces_)),
      integrator_(std::move(other.integrator_)) {
  lists_.Bind(params_, *this, geometry_);
  shares_.Bind(params_, *this, lists_);
  forces_.Bind(params_, geometry_, *this, lists_, shares_);
  integrator_.Bind(params_, *this, lists_, shares_);
}

int World::AddBody(int tmpl, double x, double y, double theta) {
  if (tmpl < 0 || tmpl >= static_cast<int>(templates_.size()))
    throw std::invalid_argument("World::AddBody: no shape template " + std::to_string(tmpl));
  const silo::ShapeTemplate& t = templates_[static_cast<std::size_t>(tmpl)];
  const int id = BodyCount();
  Append(tmpl, t);
  body_x_[id] = x;
  body_y_[id] = y;
  body_angle_[id] = theta;
  body_cos_[id] = std::cos(theta);
  body_sin_[id] = std::sin(theta);
  lists_.AddDiscs(static_cast<int>(t.r.size()));
  ++active_count_;
  PlaceDiscs(id);
  rebuild_needed_ = true;
  return id;
}

void World::SetVelocity(int b, double vx, double vy, double omega) {
  body_vx_[b] = vx;
  body_vy_[b] = vy;
  body_spin_[b] = omega;
  PlaceDiscs(b);
  // The rebuild decision for the next step assumed the old velocity (Step).
  rebuild_needed_ = true;
}

void World::PlaceBody(int b, double x, double y, double theta, double vx, double vy, double omega) {
  if (!body_active_[b]) {
    body_active_[b] = 1;
    ++active_count_;
  }
  body_x_[b] = x;
  body_y_[b] = y;
  body_angle_[b] = theta;
  body_cos_[b] = std::cos(theta);
  body_sin_[b] = std::sin(theta);
  body_vx_[b] = vx;
  body_vy_[b] = vy;
  body_spin_[b] = omega;
  // A body is placed where it touches nothing: its force until the next step is gravity.
  body_fx_[b] = 0.0;
  body_fy_[b] = -body_mass_[b] * params_.gravity;
  body_torque_[b] = 0.0;
  PlaceDiscs(b);
  rebuild_needed_ = true;
}

int World::ActiveDiscCount() const {
  int n = 0;
  for (std::size_t b = 0; b < body_active_.size(); ++b)
    if (body_active_[b]) n += body_disc_count_[b];
  return n;
}

void World::Deactivate(int b) {
  if (!body_active_[b]) return;
  body_active_[b] = 0;
  --active_count_;
  body_fx_[b] = body_fy_[b] = body_torque_[b] = 0;
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

void World::RefreshDiscs() {
  for (int b = 0; b < BodyCount(); ++b) PlaceDiscs(b);
}

void World::Rebuild() {
  rebuild_needed_ = false;
  lists_.Rebuild(outlets_open_, Parallel());
}

void World::ComputeForces() { Forces(rebuild_needed_ || lists_.NeedsRebuild(Parallel()), false); }

void World::Forces(bool rebuild, bool kick) {
  if (rebuild) Rebuild();
  const std::int64_t pass = NextForcePass();
  bool outrun = false;
#pragma omp parallel if (Parallel()) reduction(|| : outrun)
  outrun = forces_.Run(kick, pass, false);
  rebuild_predicted_ = outrun;
}

std::int64_t World::NextForcePass() {
  const std::int64_t pass = shares_.NextPass();
  forces_.PrepareThreads(omp_get_max_threads());
  return pass;
}

void World::Step() {
  // The last force pass said whether this drift may take a disc beyond half the skin
  // (OutrunsSkin): then this step rebuilds, after a drift of its own. Otherwise drift,
  // pair blocks and body chunks run in one region with no barrier: each waits only for the
  // work it reads (ForcePass::Run).
  const bool rebuild = rebuild_needed_ || rebuild_predicted_;
  const std::int64_t pass = NextForcePass();
  int flags = 0;
  bool outrun = false;
#pragma omp parallel if (Parallel()) reduction(| : flags) reduction(|| : outrun)
  {
    // (the same shares of body chunks as in the force pass: each thread keeps its bodies)
    flags |= integrator_.DriftShare(omp_get_thread_num(), omp_get_num_threads(), pass);
    if (!rebuild) outrun = forces_.Run(true, pass, true);
  }
  if (rebuild) {
    Forces(true, true);
  } else {
    rebuild_predicted_ = outrun;
    // The bound makes this impossible; if it ever failed, this step's forces missed
    // contacts, and a run must stop rather than go on wrong.
    if (flags & Integrator::kDriftMoved)
      throw std::logic_error("engine: a disc moved more than half the Verlet skin between list rebuilds");
  }
  beyond_exit_box_ = !integrator_.ExitBoxSet() || (flags & Integrator::kDriftBeyond) != 0;
}

int World::Steps(int max_steps) {
  int taken = 0;
  while (taken < max_steps) {
    // A step that rebuilds the lists has serial parts and parallel loops of its own (Step);
    // without an exit box every step is "beyond" it, so steps go one by one.
    if (rebuild_needed_ || rebuild_predicted_ || !integrator_.ExitBoxSet() || !Parallel() || max_steps - taken == 1) {
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
      int mine = integrator_.DriftShare(t, nt, pass);
      if (forces_.Run(true, pass, true, &waited)) mine |= kStepOutrun;
      shares_.ThreadBusy(t).busy +=
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() - waited;
      StepDone& own = shares_.StepDoneOf(t);
      own.flags[static_cast<std::size_t>(pass & 1)] = mine;
      own.pass.store(pass, std::memory_order_release);
      int all = 0;
      for (int u = 0; u < nt; ++u) {
        AwaitPass(shares_.StepDoneOf(u).pass, pass);
        all |= shares_.StepDoneOf(u).flags[static_cast<std::size_t>(pass & 1)];
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
  shares_.SetLastPass(first + taken - 1);
  if (team > 1) shares_.Rebalance(team, taken);
  rebuild_predicted_ = (flags & kStepOutrun) != 0;
  // (as in Step: the bound makes this impossible)
  if (flags & Integrator::kDriftMoved)
    throw std::logic_error("engine: a disc moved more than half the Verlet skin between list rebuilds");
  beyond_exit_box_ = (flags & Integrator::kDriftBeyond) != 0;
  return taken;
}

double World::KineticEnergy() const {
  double ke = 0.0;
  for (int b = 0; b < BodyCount(); ++b) {
    if (!body_active_[b]) continue;
    ke += 0.5 * body_mass_[b] * (body_vx_[b] * body_vx_[b] + body_vy_[b] * body_vy_[b]) +
          0.5 * body_inertia_[b] * body_spin_[b] * body_spin_[b];
  }
  return ke;
}

double World::MaxDiscTop() const {
  double top = 0.0;
  for (int i = 0; i < DiscCount(); ++i)
    if (body_active_[disc_body_[i]]) top = std::max(top, disc_y_[i] + disc_radius_[i]);
  return top;
}

void World::ImportHistory(const std::vector<HistoryEntry>& pairs, const std::vector<HistoryEntry>& walls) {
  lists_.ImportHistory(pairs, walls);
  Rebuild();
}

WorldSnapshot World::Snapshot() {
  // Both this world and one restored from the snapshot rebuild their lists here.
  RebuildNow();
  WorldSnapshot s;
  s.tmpl = body_template_;
  s.active = body_active_;
  s.x.assign(body_x_.begin(), body_x_.end());
  s.y.assign(body_y_.begin(), body_y_.end());
  s.theta.assign(body_angle_.begin(), body_angle_.end());
  s.c.assign(body_cos_.begin(), body_cos_.end());
  s.s.assign(body_sin_.begin(), body_sin_.end());
  s.vx.assign(body_vx_.begin(), body_vx_.end());
  s.vy.assign(body_vy_.begin(), body_vy_.end());
  s.w.assign(body_spin_.begin(), body_spin_.end());
  s.fx.assign(body_fx_.begin(), body_fx_.end());
  s.fy.assign(body_fy_.begin(), body_fy_.end());
  s.torque.assign(body_torque_.begin(), body_torque_.end());
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
      throw std::invalid_argument("World::Restore: pair history entry (" + std::to_string(h.i) + ", " +
                                  std::to_string(h.j) + ") is not a pair of discs i < j");
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
  body_fx_.assign(s.fx.begin(), s.fx.end());
  body_fy_.assign(s.fy.begin(), s.fy.end());
  body_torque_.assign(s.torque.begin(), s.torque.end());
  body_cos_.assign(s.c.begin(), s.c.end());
  body_sin_.assign(s.s.begin(), s.s.end());
  RefreshDiscs();
  outlets_open_ = s.outlets_open;
  ImportHistory(s.pairs, s.walls);  // rebuilds the lists
  rebuild_predicted_ = s.rebuild_predicted;
}

}  // namespace granary::engine
