// The AVX-512 loops (avx512_kernels.h) against the portable ones: the pair loop
// (pair_entries.h) gives the same bits for every output, over entries that touch or not,
// stick or slip, with and without shear history, under both normal models, both tangential
// caps and the normal clip; piles of discs, dumbbells and both step to the same bits with the AVX-512 pair loop
// and drift as without them.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "engine/avx512_kernels.h"
#include "engine/world.h"
#include "engine/pair_entries.h"
#include "silo/shapes.h"
#include "world_parts.h"

namespace granary::engine {
namespace {

struct Entries {
  std::vector<DiscKin> kin;
  std::vector<int> i, j;
  std::vector<double> reff, meff, sx, sy, fx, fy, c;
  int size() const { return static_cast<int>(i.size()); }
};

// Discs in pairs at random separations around contact, random velocities and spins; the
// first 16 entries are far apart (a whole group of eight that does not touch).
Entries MakeEntries(int n, std::uint32_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Entries s;
  s.kin.resize(static_cast<std::size_t>(2 * n));
  for (int e = 0; e < n; ++e) {
    const double ri = 0.5 + 0.25 * std::fabs(u(rng)), rj = 0.5 + 0.25 * std::fabs(u(rng));
    const double angle = 3.14159 * u(rng);
    const double gap = e < 16 ? 0.5 : 0.004 * u(rng);  // < 0: overlap
    const double dist = ri + rj + gap;
    DiscKin& a = s.kin[static_cast<std::size_t>(2 * e)];
    DiscKin& b = s.kin[static_cast<std::size_t>(2 * e + 1)];
    a = {10.0 * u(rng), 10.0 * u(rng), u(rng), u(rng), ri, 3.0 * u(rng)};
    b = {a.x - dist * std::cos(angle), a.y - dist * std::sin(angle), u(rng), u(rng), rj, 3.0 * u(rng)};
    s.i.push_back(2 * e);
    s.j.push_back(2 * e + 1);
    s.reff.push_back(EffectiveRadius(ri, rj));
    s.meff.push_back(EffectiveMass(1.0 + std::fabs(u(rng)), 1.0 + std::fabs(u(rng))));
    // A third of the entries without history (LAMMPS: nothing to rescale), the rest with
    // shear up to 2e-3, enough for many to slip.
    const bool fresh = e % 3 == 0;
    s.sx.push_back(fresh ? 0.0 : 2e-3 * u(rng));
    s.sy.push_back(fresh ? 0.0 : 2e-3 * u(rng));
  }
  s.fx.assign(static_cast<std::size_t>(n), -1.0);
  s.fy = s.fx;
  s.c = s.fx;
  return s;
}

template <class Normal, bool kCap>
void Portable(Entries& s, const ContactParams& p, double dt) {
  PairEntries<Normal, kCap>(0, s.size(), s.i.data(), s.j.data(), s.reff.data(), s.meff.data(), s.sx.data(), s.sy.data(),
                            s.fx.data(), s.fy.data(), s.c.data(), s.kin.data(), p, dt);
}

template <class Normal, bool kCap>
void Simd(Entries& s, const ContactParams& p, double dt) {
  const int done = PairEntriesAvx512(0, s.size(), s.i.data(), s.j.data(), s.reff.data(), s.meff.data(), s.sx.data(),
                                     s.sy.data(), s.fx.data(), s.fy.data(), s.c.data(), s.kin.data(), p, dt);
  EXPECT_EQ(done, s.size() / 8 * 8);
  PairEntries<Normal, kCap>(done, s.size(), s.i.data(), s.j.data(), s.reff.data(), s.meff.data(), s.sx.data(),
                            s.sy.data(), s.fx.data(), s.fy.data(), s.c.data(), s.kin.data(), p, dt);
}

template <class A, class B>
bool SameBits(const A& a, const B& b) {  // (std::vector<double> or the world's SharedVector<double>)
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0;
}

template <class Normal, bool kCap>
void ExpectSameBits(bool clip) {
  ContactParams p;
  p.normal_model = Normal::kModel;
  p.liggghts_cap = kCap;
  p.clip_normal = clip;
  const double dt = 1e-4;
  Entries portable = MakeEntries(1003, 7);
  Entries simd = portable;
  // Two steps: the second starts from the history the first wrote.
  for (int step = 0; step < 2; ++step) {
    Portable<Normal, kCap>(portable, p, dt);
    Simd<Normal, kCap>(simd, p, dt);
  }
  EXPECT_TRUE(SameBits(portable.sx, simd.sx));
  EXPECT_TRUE(SameBits(portable.sy, simd.sy));
  EXPECT_TRUE(SameBits(portable.fx, simd.fx));
  EXPECT_TRUE(SameBits(portable.fy, simd.fy));
  EXPECT_TRUE(SameBits(portable.c, simd.c));
  // The data cover what the kernel distinguishes: contacts that do not touch, that stick
  // and that slip (tangential force at the Coulomb cap).
  int apart = 0, stick = 0, slip = 0;
  for (int e = 0; e < portable.size(); ++e) {
    const DiscKin& a = portable.kin[static_cast<std::size_t>(portable.i[e])];
    const DiscKin& b = portable.kin[static_cast<std::size_t>(portable.j[e])];
    const double dx = a.x - b.x, dy = a.y - b.y, r = std::hypot(dx, dy);
    if (r >= a.r + b.r) {
      ++apart;
      continue;
    }
    const double nx = dx / r, ny = dy / r;
    const double fn = portable.fx[e] * nx + portable.fy[e] * ny;
    const double ft = std::fabs(portable.fy[e] * nx - portable.fx[e] * ny);
    (ft > p.mu * std::fabs(fn) * (1.0 - 1e-9) ? slip : stick) += 1;
  }
  EXPECT_GT(apart, 100);
  EXPECT_GT(stick, 100);
  EXPECT_GT(slip, 50);
}

TEST(PairKernel, Avx512LoopGivesThePortableBitsWithTheLammpsCap) {
  if (!Avx512Available()) GTEST_SKIP() << "this CPU has no AVX-512F";
  ExpectSameBits<HertzNormal, false>(false);
  ExpectSameBits<HertzNormal, false>(true);
  ExpectSameBits<HookeNormal, false>(false);
  ExpectSameBits<HookeNormal, false>(true);
}

TEST(PairKernel, Avx512LoopGivesThePortableBitsWithTheLiggghtsCap) {
  if (!Avx512Available()) GTEST_SKIP() << "this CPU has no AVX-512F";
  ExpectSameBits<HertzNormal, true>(false);
  ExpectSameBits<HertzNormal, true>(true);
  ExpectSameBits<HookeNormal, true>(false);
  ExpectSameBits<HookeNormal, true>(true);
}

enum class PileOf { kDumbbells, kDiscs, kMixture };

// A pile of 61 bodies settling between walls for 3000 steps: dumbbells only or discs only
// (the one-pass drift of bodies of one or two discs runs), or both (the general loops). Every
// seventh body starts spinning fast (|w dt| >= 0.01: a rotation by libm, which takes its
// group of eight out of the AVX-512 drift); some bodies are switched off for a while, some
// for good.
World Pile(bool avx512, PileOf bodies, bool liggghts_cap, NormalModel model = NormalModel::kHertz) {
  silo::SiloGeometry g;
  g.elements = {WallSegment(-6.5, 0, 6.5, 0), WallSegment(-6.5, 0, -6.5, 60), WallSegment(6.5, 0, 6.5, 60)};
  WorldParams p;
  p.avx512_kernels = avx512;
  p.pair.liggghts_cap = p.wall.liggghts_cap = liggghts_cap;
  p.pair.normal_model = p.wall.normal_model = model;
  if (model == NormalModel::kHooke)  // a linear spring as stiff at the start's overlaps as Hertz
    for (ContactParams* c : {&p.pair, &p.wall}) {
      c->kn = 2.0e4;
      c->kt = 2.45e4;
    }
  World w(p, {silo::MakeTemplate(DumbbellSpecies(), 1.0, 0), silo::MakeTemplate(DiscSpecies(1.0), 1.0, 1)}, g);
  for (int k = 0; k < 61; ++k) {
    const bool disc = bodies == PileOf::kDiscs || (bodies == PileOf::kMixture && k % 3 == 2);
    w.AddBody(disc ? 1 : 0, -4.2 + 2.1 * (k % 5), 0.6 + 1.05 * (k / 5), 0.3 * (k % 7));
  }
  for (int k = 0; k < 61; k += 7) w.SetVelocity(k, 0.5, -1.0, 150.0);
  w.ComputeForces();
  for (int s = 0; s < 3000; ++s) {
    if (s == 1000)
      for (int k = 5; k < 61; k += 11) w.Deactivate(k);
    if (s == 1500)
      for (int k = 5; k < 61; k += 11) w.PlaceBody(k, -4.2 + 2.1 * (k % 5), 40.0 + k, 0.1 * k, 0.0, -1.0, 120.0);
    if (s == 2000)
      for (int k = 3; k < 61; k += 13) w.Deactivate(k);
    w.Step();
  }
  return w;
}

TEST(Avx512Kernels, APileStepsToTheSameBitsWithAndWithout) {
  if (!Avx512Available()) GTEST_SKIP() << "this CPU has no AVX-512F";
  for (const PileOf bodies : {PileOf::kDumbbells, PileOf::kDiscs, PileOf::kMixture})
    for (const bool cap : {false, true})
      for (const NormalModel model : {NormalModel::kHertz, NormalModel::kHooke}) {
        const World simd = Pile(true, bodies, cap, model), portable = Pile(false, bodies, cap, model);
        const int what = static_cast<int>(bodies) + 10 * static_cast<int>(model);
        for (const auto member : {&World::body_x_, &World::body_y_, &World::body_angle_, &World::body_cos_,
                                  &World::body_sin_, &World::body_vx_, &World::body_vy_, &World::body_spin_,
                                  &World::body_fx_, &World::body_fy_, &World::body_torque_, &World::disc_x_,
                                  &World::disc_y_, &World::disc_fx_, &World::disc_fy_, &World::disc_torque_})
          EXPECT_TRUE(SameBits(simd.*member, portable.*member)) << "bodies " << what << " cap " << cap;
        // The bodies fell onto each other (free fall alone: 0.045 d in the 3000 steps).
        double fell = 0.0;
        for (int b = 0; b < simd.BodyCount(); ++b)
          if (b % 11 != 5 && b % 13 != 3) fell = std::max(fell, 0.6 + 1.05 * (b / 5) - simd.body_y_[b]);
        EXPECT_GT(fell, 0.1) << "bodies " << what;
      }
}

}  // namespace
}  // namespace granary::engine
