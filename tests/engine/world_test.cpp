// Dynamics of one or two bodies against closed forms and independent integrations:
// restitution (RK4 of the Hertz-damped oscillator; Hooke's closed form), friction on an incline, energy
// conservation, free rotation, obstacle deflection, free fall (docs/model.md).
#include "engine/world.h"

#include <omp.h>

#include <cmath>
#include <cstring>
#include <numbers>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "world_parts.h"

namespace granary::engine {
namespace {

WorldParams Params(double gravity) {
  WorldParams p;
  p.gravity = gravity;
  return p;
}

// Independent reference: RK4 integration of the Hertz-damped normal oscillator
// m_eff delta'' = -sqrt(R delta) (K delta + m_eff gamma delta') from delta = 0, delta' = v0
// until delta returns to 0; returns e = -delta'_end / v0.
double RestitutionRk4(double kn, double gamma, double reff, double meff, double v0) {
  auto acc = [&](double d, double v) {
    const double dd = std::max(d, 0.0);
    return -std::sqrt(reff * dd) * (kn * dd + meff * gamma * v) / meff;
  };
  double d = 0.0, v = v0;
  const double h = 1e-8;
  for (int i = 0; i < 100000000; ++i) {
    const double k1d = v, k1v = acc(d, v);
    const double k2d = v + 0.5 * h * k1v, k2v = acc(d + 0.5 * h * k1d, v + 0.5 * h * k1v);
    const double k3d = v + 0.5 * h * k2v, k3v = acc(d + 0.5 * h * k2d, v + 0.5 * h * k2v);
    const double k4d = v + h * k3v, k4v = acc(d + h * k3d, v + h * k3v);
    const double dn = d + h / 6 * (k1d + 2 * k2d + 2 * k3d + k4d);
    const double vn = v + h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v);
    if (dn <= 0.0 && i > 10) {
      // linear interpolation of v at delta = 0
      const double f = d / (d - dn);
      return -(v + f * (vn - v)) / v0;
    }
    d = dn;
    v = vn;
  }
  return -1.0;
}

TEST(World, DiscDiscRestitutionMatchesIndependentOscillator) {
  World w(Params(0.0), {silo::MakeTemplate(DiscSpecies(1.0), 1.0, 0)}, silo::SiloGeometry{});
  const int a = w.AddBody(0, -0.55, 0.0, 0.0);
  const int b = w.AddBody(0, 0.55, 0.0, 0.0);
  w.SetVelocity(a, 0.5, 0.0, 0.0);
  w.SetVelocity(b, -0.5, 0.0, 0.0);
  w.ComputeForces();
  for (int s = 0; s < 3000; ++s) w.Step();
  const double e_dem = (w.body_vx_[b] - w.body_vx_[a]) / 1.0;
  const double m = std::numbers::pi * 0.25;
  const WorldParams p = Params(0.0);
  const double e_ref = RestitutionRk4(p.pair.kn, p.pair.gamma_n, 0.25, m / 2, 1.0);
  EXPECT_GT(e_ref, 0.1);
  EXPECT_LT(e_ref, 0.99);
  EXPECT_NEAR(e_dem, e_ref, 0.01 * e_ref) << "e_dem=" << e_dem << " e_ref=" << e_ref;
  // momentum is conserved exactly (equal and opposite pair forces)
  EXPECT_NEAR(w.body_vx_[a] + w.body_vx_[b], 0.0, 1e-12);
}

TEST(World, DiscWallRestitutionMatchesIndependentOscillator) {
  silo::SiloGeometry g;
  g.elements.push_back(WallSegment(-5, 0, 5, 0));
  World w(Params(0.0), {silo::MakeTemplate(DiscSpecies(1.0), 1.0, 0)}, g);
  const int a = w.AddBody(0, 0.0, 0.6, 0.0);
  w.SetVelocity(a, 0.0, -1.0, 0.0);
  w.ComputeForces();
  for (int s = 0; s < 3000; ++s) w.Step();
  const double m = std::numbers::pi * 0.25;
  const WorldParams p = Params(0.0);
  const double e_ref = RestitutionRk4(p.wall.kn, p.wall.gamma_n, 0.5, m, 1.0);
  EXPECT_NEAR(w.body_vy_[a], e_ref, 0.01 * e_ref) << "e_ref=" << e_ref;
}

// Hooke (linear spring-dashpot, LAMMPS gran/hooke/history): m_eff delta'' = -K_n delta -
// m_eff gamma_n delta' from delta = 0, delta' = v0 is delta = v0/w e^(-gamma_n t/2) sin(w t),
// w = sqrt(K_n/m_eff - (gamma_n/2)^2): the contact lasts t_c = pi/w and the normal speed
// comes back as e v0, e = exp(-gamma_n pi / (2 w)). The damping force jumps to m_eff gamma_n
// v0 when the discs touch and from about as much when they part, and the step places each
// jump within dt: e is off by up to gamma_n v0 dt (here 1e-3, at dt = 1e-5), the duration by
// a step. Stiffness and damping chosen so that a contact lasts ~1400 steps.
constexpr double kHookeDt = 1e-5;
WorldParams HookeParams() {
  WorldParams p = Params(0.0);
  p.dt = kHookeDt;
  for (ContactParams* c : {&p.pair, &p.wall}) {
    c->normal_model = NormalModel::kHooke;
    c->kn = 2.0e4;
    c->gamma_n = 100.0;
  }
  return p;
}
double HookeOmega(double meff) {
  const WorldParams p = HookeParams();
  return std::sqrt(p.pair.kn / meff - 0.25 * p.pair.gamma_n * p.pair.gamma_n);
}

TEST(World, HookeDiscDiscCollisionHasTheAnalyticDurationAndRestitution) {
  World w(HookeParams(), {silo::MakeTemplate(DiscSpecies(1.0), 1.0, 0)}, silo::SiloGeometry{});
  const int a = w.AddBody(0, -0.55, 0.0, 0.0);
  const int b = w.AddBody(0, 0.55, 0.0, 0.0);
  w.SetVelocity(a, 0.5, 0.0, 0.0);
  w.SetVelocity(b, -0.5, 0.0, 0.0);
  w.ComputeForces();
  int touching = 0;
  for (int s = 0; s < 20000; ++s) {
    w.Step();
    touching += w.body_x_[b] - w.body_x_[a] < 1.0;
  }
  const double meff = std::numbers::pi * 0.25 / 2, omega = HookeOmega(meff);
  const double t_c = std::numbers::pi / omega, e = std::exp(-100.0 * std::numbers::pi / (2 * omega));
  EXPECT_GT(t_c, 1000 * kHookeDt);
  EXPECT_NEAR(touching * kHookeDt, t_c, 1.5 * kHookeDt) << "steps in contact " << touching;
  EXPECT_NEAR(w.body_vx_[b] - w.body_vx_[a], e, 100.0 * kHookeDt) << "e=" << e;
  // Hertz with the same constants gives another collision (the model is in use).
  EXPECT_GT(std::fabs(e - RestitutionRk4(2.0e4, 100.0, 0.25, meff, 1.0)), 0.05);
  EXPECT_NEAR(w.body_vx_[a] + w.body_vx_[b], 0.0, 1e-12);
}

TEST(World, TheSpecsNormalModelReachesPairsAndWalls) {
  EXPECT_EQ(ParamsFromSpec(RunSpec::FromJson(nlohmann::json::object())).pair.normal_model, NormalModel::kHertz);
  const WorldParams p = ParamsFromSpec(RunSpec::FromJson({{"contact", {{"normal_model", "hooke"}}}}));
  EXPECT_EQ(p.pair.normal_model, NormalModel::kHooke);
  EXPECT_EQ(p.wall.normal_model, NormalModel::kHooke);
}

TEST(World, HookeDiscWallCollisionHasTheAnalyticDurationAndRestitution) {
  silo::SiloGeometry g;
  g.elements.push_back(WallSegment(-5, 0, 5, 0));
  World w(HookeParams(), {silo::MakeTemplate(DiscSpecies(1.0), 1.0, 0)}, g);
  const int a = w.AddBody(0, 0.0, 0.6, 0.0);
  w.SetVelocity(a, 0.0, -1.0, 0.0);
  w.ComputeForces();
  int touching = 0;
  for (int s = 0; s < 20000; ++s) {
    w.Step();
    touching += w.body_y_[a] < 0.5;
  }
  const double m = std::numbers::pi * 0.25, omega = HookeOmega(m);  // the wall: m_eff = M_I
  const double t_c = std::numbers::pi / omega, e = std::exp(-100.0 * std::numbers::pi / (2 * omega));
  EXPECT_NEAR(touching * kHookeDt, t_c, 1.5 * kHookeDt) << "steps in contact " << touching;
  EXPECT_NEAR(w.body_vy_[a], e, 100.0 * kHookeDt) << "e=" << e;
}

// A dumbbell lying along an inclined wall: static friction holds it while tan(angle) < mu;
// above, it slides with a = g (sin a - mu cos a).
double SlideVelocity(double tan_angle, double t_end) {
  const double ang = std::atan(tan_angle);
  const double c = std::cos(ang), s = std::sin(ang);
  silo::SiloGeometry g;
  g.elements.push_back(WallSegment(-40 * c, -40 * s, 40 * c, 40 * s));
  World w(Params(1.0), {silo::MakeTemplate(DumbbellSpecies(), 1.0, 0)}, g);
  const int a = w.AddBody(0, -s * 0.5, c * 0.5, ang);
  w.ComputeForces();
  const int steps = static_cast<int>(std::lround(t_end / 1e-4));
  for (int k = 0; k < steps; ++k) w.Step();
  return -(w.body_vx_[a] * c + w.body_vy_[a] * s);  // speed down the slope
}

TEST(World, BodyOnInclineSticksBelowFrictionAngle) { EXPECT_LT(std::fabs(SlideVelocity(0.3, 1.0)), 1e-3); }

TEST(World, BodyOnInclineSlidesAboveFrictionAngle) {
  const double tan_a = 0.8, ang = std::atan(tan_a), t = 1.0;
  const double expected = (std::sin(ang) - 0.5 * std::cos(ang)) * t;
  EXPECT_NEAR(SlideVelocity(tan_a, t), expected, 0.03 * expected);
}

// Hertz elastic energy of an overlap: U = (2/5) K_n sqrt(R) delta^(5/2).
double HertzEnergy(double kn, double reff, double delta) {
  return delta > 0 ? 0.4 * kn * std::sqrt(reff) * std::pow(delta, 2.5) : 0.0;
}

TEST(World, EnergyConservedWithoutDampingAndFriction) {
  WorldParams p = Params(0.0);
  for (ContactParams* c : {&p.pair, &p.wall}) {
    c->gamma_n = c->gamma_t = 0.0;
    c->mu = 0.0;
  }
  silo::SiloGeometry g;
  g.elements.push_back(WallSegment(-3, -3, 3, -3));
  g.elements.push_back(WallSegment(3, -3, 3, 3));
  g.elements.push_back(WallSegment(3, 3, -3, 3));
  g.elements.push_back(WallSegment(-3, 3, -3, -3));
  World w(p, {silo::MakeTemplate(DiscSpecies(1.0), 1.0, 0), silo::MakeTemplate(DumbbellSpecies(), 1.0, 1)}, g);
  w.AddBody(0, -1.5, 0.0, 0.0);
  w.AddBody(0, 1.5, 0.2, 0.0);
  w.AddBody(1, 0.0, -1.8, 0.3);
  w.SetVelocity(0, 1.0, 0.3, 0.0);
  w.SetVelocity(1, -0.8, 0.5, 0.0);
  w.SetVelocity(2, 0.2, 0.9, 0.5);
  auto energy = [&] {
    double e = w.KineticEnergy();
    for (int i = 0; i < w.DiscCount(); ++i) {
      for (int j = i + 1; j < w.DiscCount(); ++j) {
        if (w.disc_body_[i] == w.disc_body_[j]) continue;
        const double d = w.disc_radius_[i] + w.disc_radius_[j] -
                         std::hypot(w.disc_x_[i] - w.disc_x_[j], w.disc_y_[i] - w.disc_y_[j]);
        e += HertzEnergy(p.pair.kn, w.disc_radius_[i] * w.disc_radius_[j] / (w.disc_radius_[i] + w.disc_radius_[j]), d);
      }
      const double dist[4] = {w.disc_y_[i] + 3, 3 - w.disc_x_[i], 3 - w.disc_y_[i], w.disc_x_[i] + 3};
      for (double dd : dist) e += HertzEnergy(p.wall.kn, w.disc_radius_[i], w.disc_radius_[i] - dd);
    }
    return e;
  };
  w.ComputeForces();
  const double e0 = energy();
  int collisions = 0;
  for (int k = 0; k < 50000; ++k) {
    w.Step();
    if (k % 100 == 0 && std::fabs(w.body_fx_[0]) > 0) ++collisions;
  }
  EXPECT_GT(collisions, 0);
  EXPECT_NEAR(energy(), e0, 1e-4 * e0);
}

TEST(World, DumbbellRotatesFreely) {
  World w(Params(0.0), {silo::MakeTemplate(DumbbellSpecies(), 1.0, 0)}, silo::SiloGeometry{});
  const int a = w.AddBody(0, 1.0, 2.0, 0.3);
  w.SetVelocity(a, 0.1, -0.2, 2.5);
  w.ComputeForces();
  const double l0 = w.body_inertia_[a] * w.body_spin_[a];
  for (int k = 0; k < 20000; ++k) w.Step();
  const double t = 2.0;
  EXPECT_NEAR(w.body_angle_[a], 0.3 + 2.5 * t, 1e-10);
  EXPECT_NEAR(w.body_inertia_[a] * w.body_spin_[a], l0, 1e-14);
  EXPECT_NEAR(w.body_x_[a], 1.0 + 0.1 * t, 1e-10);
  // the discs sit at +-0.5 along the axis
  EXPECT_NEAR(w.disc_x_[1] - w.disc_x_[0], std::cos(0.3 + 2.5 * t), 1e-9);
  EXPECT_NEAR(w.disc_y_[1] - w.disc_y_[0], std::sin(0.3 + 2.5 * t), 1e-9);
}

double HorizontalVelocityAfterFall(double x0, bool with_obstacle) {
  silo::SiloGeometry g;
  if (with_obstacle) {
    silo::WallElement e;
    e.kind = silo::ElementKind::kCircle;
    e.ax = 0.0;
    e.ay = 2.0;
    e.radius = 1.0;
    g.elements.push_back(e);
  }
  World w(Params(1.0), {silo::MakeTemplate(DiscSpecies(1.0), 1.0, 0)}, g);
  const int a = w.AddBody(0, x0, 5.0, 0.0);
  w.ComputeForces();
  for (int k = 0; k < 40000; ++k) w.Step();
  return w.body_vx_[a];
}

TEST(World, ObstacleDeflectsAFallingDisc) {
  const double right = HorizontalVelocityAfterFall(0.3, true);
  const double left = HorizontalVelocityAfterFall(-0.3, true);
  EXPECT_GT(right, 0.1);
  EXPECT_NEAR(left, -right, 1e-9);
  EXPECT_EQ(HorizontalVelocityAfterFall(0.3, false), 0.0);
}

TEST(World, FreeFallIsExactUnderVelocityVerlet) {
  World w(Params(1.0), {silo::MakeTemplate(DumbbellSpecies(), 1.0, 0)}, silo::SiloGeometry{});
  const int a = w.AddBody(0, 0.0, 10.0, 0.0);
  w.SetVelocity(a, 0.0, 0.3, 0.0);
  w.ComputeForces();
  const int n = 12345;
  for (int k = 0; k < n; ++k) w.Step();
  const double t = n * 1e-4;
  EXPECT_NEAR(w.body_y_[a], 10.0 + 0.3 * t - 0.5 * t * t, 1e-11);
  EXPECT_NEAR(w.body_vy_[a], 0.3 - t, 1e-12);
}

// The step decides whether to rebuild the lists before its drift, from a bound on how far
// that drift moves each disc (no barrier after the drift); Step throws if a disc ever got
// more than half the skin from its rebuild position. Fast, spinning dumbbells crossing a
// pile of discs and bouncing off the walls: the lists are rebuilt often enough (no throw),
// and the collisions happen (the fast bodies lose speed).
TEST(World, ListsAreRebuiltBeforeFastBodiesOutrunTheSkin) {
  silo::SiloGeometry g;
  g.elements = {WallSegment(-10, 0, 10, 0), WallSegment(-10, 0, -10, 30), WallSegment(10, 0, 10, 30),
                WallSegment(-10, 30, 10, 30)};
  WorldParams p = Params(0.0);
  p.parallel_min_discs = 0;  // the threaded path, also on this small system
  World w(p, {silo::MakeTemplate(DumbbellSpecies(), 1.0, 0), silo::MakeTemplate(DiscSpecies(1.0), 1.0, 1)}, g);
  for (int k = 0; k < 60; ++k) w.AddBody(1, -7.5 + 1.5 * (k % 11), 2.0 + 1.5 * (k / 11), 0.0);
  std::vector<int> fast;
  for (int k = 0; k < 6; ++k) {
    fast.push_back(w.AddBody(0, -8.0 + 3.0 * k, 25.0, 0.4 * k));
    w.SetVelocity(fast.back(), (k % 2 ? -1.0 : 1.0) * 40.0, -60.0, 300.0 * (k % 3 - 1));
  }
  w.ComputeForces();
  const std::int64_t before = w.Rebuilds();
  for (int s = 0; s < 20000; ++s) ASSERT_NO_THROW(w.Step()) << "step " << s;
  // ~70 d/time unit over 2 time units, 0.1 d per rebuild at most: hundreds of rebuilds
  EXPECT_GT(w.Rebuilds() - before, 300);
  double fastest = 0.0;
  for (int b : fast) fastest = std::max(fastest, std::hypot(w.body_vx_[b], w.body_vy_[b]));
  EXPECT_LT(fastest, 60.0);
}

// Force blocks change only the summation order: reactions added inside a block (force_block
// large) and gathered across blocks (force_block 1) give the same pile to rounding.
TEST(World, ForceBlocksChangeOnlyRounding) {
  silo::SiloGeometry g;
  g.elements.push_back(WallSegment(-3.2, 0, 3.2, 0));
  g.elements.push_back(WallSegment(-3.2, 0, -3.2, 40));
  g.elements.push_back(WallSegment(3.2, 0, 3.2, 40));
  auto pile = [&](int block) {
    WorldParams p = Params(1.0);
    p.force_block = block;
    World w(p, {silo::MakeTemplate(DumbbellSpecies(), 1.0, 0), silo::MakeTemplate(DiscSpecies(1.0), 1.0, 1)}, g);
    for (int k = 0; k < 36; ++k)
      w.AddBody(k % 4 == 3 ? 1 : 0, -2.1 + 2.1 * (k % 3), 0.6 + 1.05 * (k / 3), 0.05 * (k % 5));
    w.ComputeForces();
    for (int s = 0; s < 3000; ++s) w.Step();
    return w;
  };
  const World one = pile(1), few = pile(7), all = pile(100000);
  double moved = 0.0;
  for (int b = 0; b < one.BodyCount(); ++b) {
    moved = std::max(moved, std::fabs(all.body_y_[b] - (0.6 + 1.05 * (b / 3))));
    for (const World* w : {&few, &all}) {
      EXPECT_NEAR(w->body_x_[b], one.body_x_[b], 1e-9) << "body " << b;
      EXPECT_NEAR(w->body_y_[b], one.body_y_[b], 1e-9) << "body " << b;
      EXPECT_NEAR(w->body_angle_[b], one.body_angle_[b], 1e-8) << "body " << b;
    }
  }
  EXPECT_GT(moved, 0.01);  // the bodies fell and pushed each other
}

// About 600 discs and dumbbells in a hexagonal pack of touching discs (a dumbbell takes two
// neighbouring places of a row) settling on a floor under its weight, so that contacts cross
// every share and block boundary, beside a disc thrown down past the exit line; force
// blocks of 64 discs, on the threaded path.
World SettlingPack(const WorldParams& params) {
  silo::SiloGeometry g;
  g.elements = {WallSegment(-12, 0, 12, 0), WallSegment(-12, 0, -12, 60), WallSegment(12, 0, 12, 60)};
  World w(params, {silo::MakeTemplate(DumbbellSpecies(), 1.0, 0), silo::MakeTemplate(DiscSpecies(1.0), 1.0, 1)}, g);
  for (int row = 0; w.BodyCount() < 600; ++row) {
    const double offset = 0.5 * (row % 2), y = 0.5 + 0.866 * row;
    const int places = 24 - row % 2;
    for (int c = 0; c < places; ++c) {
      const double x = -11.5 + offset + c;
      if (c % 5 == 1 && c + 1 < places) {
        w.AddBody(0, x + 0.5, y, 0.0);
        ++c;
      } else {
        w.AddBody(1, x, y, 0.0);
      }
    }
  }
  const int probe = w.AddBody(1, 40.0, 0.0, 0.0);
  w.SetVelocity(probe, 0.0, -5.0, 0.0);
  w.SetExitBox(-50.0, 50.0, -1.0);
  w.ComputeForces();
  return w;
}

WorldParams ThreadedParams() {
  WorldParams p;
  p.parallel_min_discs = 0;
  p.force_block = 64;
  return p;
}

bool SameState(const World& a, const World& b) {
  auto same = [](const auto& x, const auto& y) {
    return x.size() == y.size() && std::memcmp(x.data(), y.data(), x.size() * sizeof(double)) == 0;
  };
  return same(a.body_x_, b.body_x_) && same(a.body_y_, b.body_y_) && same(a.body_angle_, b.body_angle_) &&
         same(a.body_vx_, b.body_vx_) && same(a.body_vy_, b.body_vy_) && same(a.body_spin_, b.body_spin_) &&
         same(a.body_fx_, b.body_fx_) && same(a.body_torque_, b.body_torque_);
}

struct ThreadCount {
  explicit ThreadCount(int n) : before(omp_get_max_threads()) { omp_set_num_threads(n); }
  ~ThreadCount() { omp_set_num_threads(before); }
  int before;
};

// World::Steps runs steps without a rebuild in one parallel region and returns at the first
// step that leaves a body beyond the exit box: the same bits, the same rebuilds and the same
// step for the exit as one Step at a time.
TEST(World, StepsInOneRegionGiveTheBitsOfSingleSteps) {
  constexpr int kSteps = 2500;
  ThreadCount two(2);
  World single = SettlingPack(ThreadedParams());
  int single_exit = -1;
  for (int s = 1; s <= kSteps; ++s) {
    single.Step();
    if (single.BeyondExitBox() && single_exit < 0) single_exit = s;
  }
  World many = SettlingPack(ThreadedParams());
  int many_exit = -1, done = 0, calls = 0;
  while (done < kSteps) {
    done += many.Steps(std::min(400, kSteps - done));
    ++calls;
    if (many.BeyondExitBox() && many_exit < 0) many_exit = done;
  }
  EXPECT_EQ(done, kSteps);
  EXPECT_GT(single_exit, 1000);  // the probe falls 1 d at 5 d per time unit: about step 2000
  EXPECT_EQ(many_exit, single_exit);
  EXPECT_LT(calls, kSteps - single_exit + 50);  // steps before the exit went several at a time
  EXPECT_GT(single.Rebuilds(), 5);
  EXPECT_EQ(many.Rebuilds(), single.Rebuilds());
  EXPECT_TRUE(SameState(single, many));
}

// The threads' shares of the work may start anywhere (the measured rebalancing moves them):
// shifted either way, two threads give the bits of one.
TEST(World, ShareSplitsChangeNoBit) {
  auto run = [](int threads, double shift) {
    ThreadCount count(threads);
    WorldParams p = ThreadedParams();
    p.rebalance_shares = false;
    p.share_shift = shift;
    World w = SettlingPack(p);
    for (int done = 0; done < 1500;) done += w.Steps(1500 - done);
    return w;
  };
  const World one = run(1, 0.0);
  EXPECT_GT(one.Rebuilds(), 3);
  for (const double shift : {-0.2, -0.05, 0.0, 0.07, 0.2})
    EXPECT_TRUE(SameState(one, run(2, shift))) << "shift " << shift;
}

// World's parts (lists, shares, force pass, integrator) point to its body store, parameters
// and each other: a world moved in the middle of a run points them to itself and steps on
// to the bits of the world that was not moved (parts left pointing to the moved-from world
// would read its emptied arrays).
TEST(World, AMovedWorldStepsOnAsTheWorldItWas) {
  ThreadCount two(2);
  World kept = SettlingPack(ThreadedParams());
  World source = SettlingPack(ThreadedParams());
  for (int done = 0; done < 500;) done += kept.Steps(500 - done);
  for (int done = 0; done < 500;) done += source.Steps(500 - done);
  World moved(std::move(source));
  for (int done = 0; done < 1500;) done += kept.Steps(1500 - done);
  for (int done = 0; done < 1500;) done += moved.Steps(1500 - done);
  EXPECT_GT(moved.Rebuilds(), 3);
  EXPECT_EQ(moved.Rebuilds(), kept.Rebuilds());
  EXPECT_TRUE(SameState(kept, moved));
}

// What the threads write in shares starts on an aligned pair of cache lines (thread_shared.h),
// so that a share boundary at a whole body chunk shares no pair between two threads: a layout
// the bench measures (docs/benchmarks.md), kept by this check.
TEST(World, ArraysTheThreadsShareStartOnPairsOfCacheLines) {
  auto on_pair = [](const void* p) { return reinterpret_cast<std::uintptr_t>(p) % kThreadSharedAlign == 0; };
  for (const std::size_t n : {1u, 3u, 17u, 1000u}) {
    const SharedVector<int> a(n), b(n);
    EXPECT_TRUE(on_pair(a.data()) && on_pair(b.data())) << n;
  }
  const World w = SettlingPack(ThreadedParams());
  for (const auto* v :
       {&w.body_x_, &w.body_y_, &w.body_angle_, &w.body_vx_, &w.body_vy_, &w.body_spin_, &w.body_cos_, &w.body_sin_,
        &w.body_fx_, &w.body_fy_, &w.body_torque_, &w.disc_x_, &w.disc_y_, &w.disc_fx_, &w.disc_fy_, &w.disc_torque_})
    EXPECT_TRUE(on_pair(v->data()));
}

}  // namespace
}  // namespace granary::engine
