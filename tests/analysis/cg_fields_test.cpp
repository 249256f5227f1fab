// Coarse-grained fields against constructed frames with exact answers: the kernel's line
// integral against its erf closed form, phi integrating to the discs' area, a uniform lattice,
// a rigid rotation, a hand-made contact network (Love-Weber stress), a stacked static pile
// carrying its weight, streaming sums, region means and series, and the same bits at any
// thread count.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <numbers>
#include <random>

#include "analysis/cg_fields.h"

namespace granary::analysis {
namespace {

using rundir::ContactFrame;
using rundir::ContactRow;
using rundir::Disc;

// Square lattice of discs of radius r with spacing a covering [x0, x1] x [y0, y1], one body
// per disc; velocity and omega from `motion(x, y, disc)`.
template <class Motion>
std::vector<Disc> Lattice(double x0, double x1, double y0, double y1, double a, double r, Motion motion) {
  std::vector<Disc> discs;
  std::int64_t id = 0;
  for (double y = y0; y <= y1 + 1e-9; y += a)
    for (double x = x0; x <= x1 + 1e-9; x += a) {
      Disc d;
      d.id = id + 1;
      d.mol = id++;
      d.x = x;
      d.y = y;
      d.radius = r;
      d.mass = std::numbers::pi * r * r;
      motion(x, y, d);
      discs.push_back(d);
    }
  return discs;
}

CgOptions OptionsOver(Rect window, double cutoff = 3.0, double spacing = 1.0) {
  CgOptions o;
  o.window = window;
  o.cutoff = cutoff;
  o.spacing = spacing;
  o.threads = 1;
  return o;
}

double ClosedFormLineIntegral(double rx, double ry, double ax, double ay, double bx, double by, double w) {
  const double ux = bx - ax, uy = by - ay, L = std::hypot(ux, uy);
  const double ex = ux / L, ey = uy / L;
  const double t = (rx - ax) * ex + (ry - ay) * ey;
  const double n = -(rx - ax) * ey + (ry - ay) * ex;
  return std::exp(-n * n / (w * w)) * w * std::sqrt(std::numbers::pi) / (2.0 * L) *
         (std::erf(t / w) - std::erf((t - L) / w)) / (std::numbers::pi * w * w);
}

TEST(CgFields, LineIntegralAgreesWithTheErfClosedForm) {
  CgOptions o;
  o.cutoff = 8.0;  // the cut changes the integral by < exp(-64)
  const double peak = 1.0 / (std::numbers::pi * o.width * o.width);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-3.0, 3.0), len(0.05, 3.0), ang(0.0, 2.0 * std::numbers::pi);
  double worst = 0.0;
  for (int k = 0; k < 2000; ++k) {
    const double ax = u(rng), ay = u(rng), L = len(rng), phi = ang(rng);
    const double bx = ax + L * std::cos(phi), by = ay + L * std::sin(phi);
    const double rx = u(rng), ry = u(rng);
    worst = std::max(worst, std::abs(CgLineIntegral(rx, ry, ax, ay, bx, by, o) -
                                     ClosedFormLineIntegral(rx, ry, ax, ay, bx, by, o.width)));
  }
  EXPECT_LT(worst, 3e-8 * peak);
}

// Sum over nodes of phi h^2 = total disc area, for discs whose kernel lies inside the window.
double PhiIntegralError(const CgOptions& base, int n_discs, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> ux(-10.0, 10.0), uy(10.0, 30.0), ur(0.3, 0.8);
  std::vector<Disc> discs(static_cast<std::size_t>(n_discs));
  double area = 0.0;
  for (std::size_t i = 0; i < discs.size(); ++i) {
    discs[i].mol = static_cast<std::int64_t>(i);
    discs[i].x = ux(rng);
    discs[i].y = uy(rng);
    discs[i].radius = ur(rng);
    area += std::numbers::pi * discs[i].radius * discs[i].radius;
  }
  CgOptions o = base;
  o.window = {-25.0, 25.0, -5.0, 45.0};  // 15 d around the discs: more than the cutoff
  CgAccumulator acc(o);
  acc.AddFrame(0.0, discs, nullptr);
  const CgMaps maps = acc.Maps();
  double sum = 0.0;
  for (std::size_t n = 0; n < maps.Grid().size(); ++n) sum += maps.Value(CgField::kPhi, n);
  return std::abs(sum * o.spacing * o.spacing - area) / area;
}

TEST(CgFields, PhiIntegratesToTheDiscsArea) {
  CgOptions wide;
  wide.cutoff = 5.0;
  wide.spacing = 0.5;
  EXPECT_LT(PhiIntegralError(wide, 300, 1), 1e-12);  // measured 7e-14
  // The thesis' kernel (cut at 3w) on a 1 d grid: the stated discretisation error is 1e-5
  // (docs/analyses.md; measured 4e-7..3e-6), from the nodes that enter and leave the cut disc
  // as a disc moves.
  CgOptions thesis;
  for (unsigned seed = 1; seed <= 5; ++seed) EXPECT_LT(PhiIntegralError(thesis, 300, seed), 1e-5) << seed;
}

TEST(CgFields, UniformLatticeGivesUniformPhi) {
  const double a = 1.1, r = 0.5, phi0 = std::numbers::pi * r * r / (a * a);
  const auto discs = Lattice(-30.0, 30.0, -30.0, 30.0, a, r, [](double, double, Disc&) {});
  for (double cutoff : {3.0, 5.0}) {
    CgOptions o = OptionsOver({-10.37, 10.0, -9.81, 10.0}, cutoff, 0.7);  // nodes off the lattice
    CgAccumulator acc(o);
    acc.AddFrame(0.0, discs, nullptr);
    const CgMaps maps = acc.Maps();
    double worst = 0.0;
    for (std::size_t n = 0; n < maps.Grid().size(); ++n)
      worst = std::max(worst, std::abs(maps.Value(CgField::kPhi, n) - phi0));
    // Cut at 3w the lattice points crossing the cut circle make ripples (measured 6e-5); at 5w
    // only the lattice's aliasing is left, ~exp(-pi^2 w^2 / a^2) (measured 2e-7).
    EXPECT_LT(worst, cutoff == 3.0 ? 1e-4 : 1e-6) << "cutoff " << cutoff;
    const CgRegionMean mean = MeanOverRegion(maps, CgField::kPhi, {-5.0, 5.0, -5.0, 5.0});
    EXPECT_NEAR(mean.value, phi0, cutoff == 3.0 ? 1e-4 : 1e-6);
    EXPECT_GT(mean.nodes, 150);
  }
}

TEST(CgFields, RigidRotationGivesItsVelocityAndOmegaAndNoTemperature) {
  const double omega = 0.7, vx0 = 0.3, vy0 = -0.2, xc = 1.0, yc = -2.0;
  const auto discs = Lattice(-30.0, 30.0, -30.0, 30.0, 1.0, 0.5, [&](double x, double y, Disc& d) {
    d.vx = vx0 - omega * (y - yc);
    d.vy = vy0 + omega * (x - xc);
    d.omega = omega;
  });
  CgOptions o = OptionsOver({-10.3, 10.0, -10.2, 10.0}, 5.0, 0.5);
  CgAccumulator acc(o);
  acc.AddFrame(0.0, discs, nullptr);
  const CgMaps maps = acc.Maps();
  const CgGrid& g = maps.Grid();
  const double w2 = o.width * o.width;
  for (int j = 0; j < g.ny; ++j)
    for (int i = 0; i < g.nx; ++i) {
      const std::size_t n = static_cast<std::size_t>(j) * g.nx + i;
      const double x = g.X(i), y = g.Y(j);
      ASSERT_NEAR(maps.Value(CgField::kVx, n), vx0 - omega * (y - yc), 1e-6) << x << "," << y;
      ASSERT_NEAR(maps.Value(CgField::kVy, n), vy0 + omega * (x - xc), 1e-6) << x << "," << y;
      ASSERT_NEAR(maps.Value(CgField::kOmega, n), omega, 1e-13);
      ASSERT_NEAR(maps.Value(CgField::kOmegaFl2, n), 0.0, 1e-13);
      ASSERT_NEAR(maps.Value(CgField::kTg, n), 0.0, 1e-12 * omega * omega * w2);
      ASSERT_NEAR(maps.Value(CgField::kKineticPressure, n), 0.0, 1e-12 * omega * omega * w2);
      // Eq. 4.6 as written counts the rotation inside the kernel: omega^2 <|r - r_p|^2> / 2
      // = omega^2 w^2 / 2 for the Gaussian.
      ASSERT_NEAR(maps.Value(CgField::kTgEq46, n), 0.5 * omega * omega * w2, 1e-6 * omega * omega * w2);
      ASSERT_EQ(maps.NFrames(CgField::kTg, n), 1);
    }
}

// A square lattice of discs held by contact forces: horizontal contacts push with f_h (and
// shear t), vertical ones with f_v (and shear t, so torques balance). Love-Weber: per unit
// cell of area a^2 with branch length a, sigma = -(1/a) [[f_h, t], [t, f_v]].
TEST(CgFields, HandMadeContactNetworkGivesItsPressureAndShearStress) {
  const double a = 1.0, f_h = 3.0, f_v = 5.0, t = 0.8;
  const auto discs = Lattice(-20.0, 20.0, -20.0, 20.0, a, 0.5, [](double, double, Disc&) {});
  ContactFrame contacts;
  const int side = 41;  // discs per row
  for (int row = 0; row < side; ++row)
    for (int col = 0; col < side; ++col) {
      const std::int64_t me = row * side + col;
      const Disc& d = discs[static_cast<std::size_t>(me)];
      if (col > 0) {  // with the left neighbour: force on me (the right disc) pushes right
        const Disc& l = discs[static_cast<std::size_t>(me - 1)];
        contacts.contacts.push_back({me, me - 1, d.x, d.y, l.x, l.y, d.x - 0.5 * a, d.y, f_h, t});
      }
      if (row > 0) {  // with the disc below: force on me (the upper disc) pushes up
        const Disc& b = discs[static_cast<std::size_t>(me - side)];
        contacts.contacts.push_back({me, me - side, d.x, d.y, b.x, b.y, d.x, d.y - 0.5 * a, t, f_v});
      }
    }
  CgOptions o = OptionsOver({-8.3, 8.0, -8.2, 8.0}, 5.0, 0.5);
  CgAccumulator acc(o);
  acc.AddFrame(0.0, discs, &contacts);
  const CgMaps maps = acc.Maps();
  const double p = 0.5 * (f_h + f_v) / a, tau = std::hypot(0.5 * (f_v - f_h), t) / a;
  for (std::size_t n = 0; n < maps.Grid().size(); ++n) {
    ASSERT_NEAR(maps.Value(CgField::kSigmaXX, n), -f_h / a, 1e-6 * f_v);
    ASSERT_NEAR(maps.Value(CgField::kSigmaYY, n), -f_v / a, 1e-6 * f_v);
    ASSERT_NEAR(maps.Value(CgField::kSigmaXY, n), -t / a, 1e-6 * f_v);
    ASSERT_NEAR(maps.Value(CgField::kPressure, n), p, 1e-6 * p);
    ASSERT_NEAR(maps.Value(CgField::kShear, n), tau, 1e-6 * p);
    ASSERT_NEAR(maps.Value(CgField::kFriction, n), tau / p, 1e-6);
    // At rest: no kinetic stress, so the total is the contact stress.
    ASSERT_EQ(maps.Value(CgField::kKineticPressure, n), 0.0);
    ASSERT_NEAR(maps.Value(CgField::kTotalPressure, n), p, 1e-6 * p);
    ASSERT_EQ(maps.NFrames(CgField::kPressure, n), 1);
  }
  const CgRegionMean mu = MeanOverRegion(maps, CgField::kFriction, {-4.0, 4.0, -4.0, 4.0});
  EXPECT_NEAR(mu.value, tau / p, 1e-6);
}

// Columns of discs stacked on the base (y = 0) between frictionless walls: the disc of row k
// carries the weight of the rows k..K-1 above it through its contact below (the base for
// row 0). Integrated across the width, sigma_yy at height y is minus the weight above y.
struct Pile {
  std::vector<Disc> discs;
  ContactFrame contacts;
  double weight_per_row = 0;
  int rows = 0;
};
Pile StackedPile(int columns, int rows, double g) {
  Pile p;
  p.rows = rows;
  const double r = 0.5, m = std::numbers::pi * r * r;
  p.weight_per_row = columns * m * g;
  for (int k = 0; k < rows; ++k)
    for (int c = 0; c < columns; ++c) {
      Disc d;
      d.mol = k * columns + c;
      d.id = d.mol + 1;
      d.x = -0.5 * columns + 0.5 + c;
      d.y = 0.5 + k;
      d.radius = r;
      d.mass = m;
      p.discs.push_back(d);
      const double load = (rows - k) * m * g;  // on this disc from below, upwards
      if (k == 0)
        p.contacts.contacts.push_back({d.mol, -1, d.x, d.y, d.x, 0.0, d.x, 0.0, 0.0, load});
      else
        p.contacts.contacts.push_back({d.mol, d.mol - columns, d.x, d.y, d.x, d.y - 1.0, d.x, d.y - 0.5, 0.0, load});
    }
  return p;
}

// int sigma_yy dx over the window's row j (nodes h apart).
double IntegratedSyy(const CgMaps& maps, int j) {
  double sum = 0.0;
  for (int i = 0; i < maps.Grid().nx; ++i)
    sum += maps.Value(CgField::kSigmaYY, static_cast<std::size_t>(j) * maps.Grid().nx + i);
  return sum * maps.Grid().spacing;
}

TEST(CgFields, StackedPileCarriesItsWeight) {
  const int columns = 20, rows = 40;
  const Pile pile = StackedPile(columns, rows, 1.0);
  for (double cutoff : {5.0, 3.0}) {
    // The window spans the pile's width and the kernel's reach on both sides.
    CgOptions o = OptionsOver({-25.0, 25.0, 8.0, 32.0}, cutoff, cutoff == 5.0 ? 0.5 : 1.0);
    CgAccumulator acc(o);
    acc.AddFrame(0.0, pile.discs, &pile.contacts);
    const CgMaps maps = acc.Maps();
    double worst = 0.0;
    for (int j = 0; j < maps.Grid().ny; ++j) {
      const double y = maps.Grid().Y(j);
      const double weight_above = pile.weight_per_row * (rows - y);  // rows are 1 d tall, the top at y = rows
      worst = std::max(worst, std::abs(IntegratedSyy(maps, j) + weight_above) / weight_above);
    }
    // Stated discretisation error (docs/analyses.md): 2e-4 of the load at the thesis' 3w on a
    // 1 d grid (measured 8.5e-5: the cut kernel's edge, each branch's line integral cut at 3w
    // from its segment, exp(-9) = 1.2e-4 of the peak); at 5w the quadrature along the
    // branches is all that is left (measured 8e-13).
    EXPECT_LT(worst, cutoff == 5.0 ? 1e-10 : 2e-4) << "cutoff " << cutoff;
  }
}

// The same with rigid two-disc bodies lying flat (horizontal dumbbells), one on another:
// each disc rests on the disc below it with half the load, and the branch vectors run from
// the contact points to the bodies' centres (not through the discs' centres), so the
// stress balances the bodies' weights however their discs are loaded.
TEST(CgFields, PileOfDumbbellsCarriesItsWeight) {
  const int columns = 10, rows = 40;
  const double r = 0.5, m = std::numbers::pi * r * r;  // per disc
  std::vector<Disc> discs;
  ContactFrame contacts;
  for (int k = 0; k < rows; ++k)
    for (int c = 0; c < columns; ++c) {
      const std::int64_t body = k * columns + c;
      for (int side = 0; side < 2; ++side) {
        Disc d;
        d.mol = body;
        d.id = 2 * body + side + 1;
        d.x = -2.0 * columns / 2 + 2.0 * c + 0.5 + side;
        d.y = 0.5 + k;
        d.radius = r;
        d.mass = m;
        discs.push_back(d);
        const double load = (rows - k) * m;  // this disc's half of the body's load (g = 1)
        if (k == 0)
          contacts.contacts.push_back({body, -1, d.x, d.y, d.x, 0.0, d.x, 0.0, 0.0, load});
        else
          contacts.contacts.push_back({body, body - columns, d.x, d.y, d.x, d.y - 1.0, d.x, d.y - 0.5, 0.0, load});
      }
    }
  CgOptions o = OptionsOver({-20.0, 20.0, 8.0, 32.0}, 5.0, 0.5);
  CgAccumulator acc(o);
  acc.AddFrame(0.0, discs, &contacts);
  const CgMaps maps = acc.Maps();
  const double weight_per_row = columns * 2 * m;
  for (int j = 0; j < maps.Grid().ny; ++j) {
    const double weight_above = weight_per_row * (rows - maps.Grid().Y(j));
    EXPECT_NEAR(IntegratedSyy(maps, j), -weight_above, 1e-9 * weight_above) << "y = " << maps.Grid().Y(j);
  }
}

TEST(CgFields, StreamingSumsAverageFramesAndAddAcrossRuns) {
  const auto still = Lattice(-20.0, 20.0, -20.0, 20.0, 1.0, 0.5, [](double, double, Disc&) {});
  const auto moving = Lattice(-20.0, 20.0, -20.0, 20.0, 1.0, 0.5, [](double, double, Disc& d) { d.vy = -2.0; });
  const CgOptions o = OptionsOver({-5.0, 5.0, -5.0, 5.0}, 5.0, 1.0);
  CgAccumulator both(o), first(o), second(o);
  both.AddFrame(0.0, still, nullptr);
  both.AddFrame(1.0, moving, nullptr);
  first.AddFrame(0.0, still, nullptr);
  second.AddFrame(1.0, moving, nullptr);
  CgSums merged = first.Sums();
  merged.Add(second.Sums());
  const CgMaps a = both.Maps(), b(merged);
  EXPECT_EQ(a.Frames(), 2);
  EXPECT_EQ(a.ContactFrames(), 0);
  EXPECT_FALSE(a.Has(CgField::kPressure));
  EXPECT_TRUE(std::isnan(a.Value(CgField::kPressure, 0)));
  for (std::size_t n = 0; n < a.Grid().size(); ++n) {
    EXPECT_NEAR(a.Value(CgField::kVy, n), -1.0, 1e-12);
    EXPECT_EQ(a.Value(CgField::kVy, n), b.Value(CgField::kVy, n));
    EXPECT_EQ(a.Value(CgField::kPhi, n), b.Value(CgField::kPhi, n));
    EXPECT_EQ(a.NFrames(CgField::kVy, n), 2);
  }
  CgSums other;
  other.Resize(GridOver({0, 1, 0, 1}, 1.0));
  EXPECT_THROW(merged.Add(other), std::invalid_argument);
}

TEST(CgFields, SeriesOfARegionMeanFollowsTheFrames) {
  const CgOptions o = OptionsOver({-5.0, 5.0, -5.0, 5.0}, 5.0, 1.0);
  CgAccumulator acc(o, {{"speed above", {-2.0, 2.0, -2.0, 2.0}, CgField::kSpeed},
                        {"pressure", {-2.0, 2.0, -2.0, 2.0}, CgField::kPressure}});
  for (int f = 0; f < 3; ++f) {
    const auto discs = Lattice(-20.0, 20.0, -20.0, 20.0, 1.0, 0.5, [&](double, double, Disc& d) { d.vx = 0.5 * f; });
    acc.AddFrame(10.0 + f, discs, nullptr);
  }
  ASSERT_EQ(acc.Series().size(), 2u);
  const CgSeries& s = acc.Series()[0];
  ASSERT_EQ(s.time.size(), 3u);
  for (int f = 0; f < 3; ++f) {
    EXPECT_EQ(s.time[static_cast<std::size_t>(f)], 10.0 + f);
    EXPECT_NEAR(s.value[static_cast<std::size_t>(f)], 0.5 * f, 1e-12);
    EXPECT_TRUE(std::isnan(acc.Series()[1].value[static_cast<std::size_t>(f)]));  // no contacts
  }
}

// Pile frames with random velocities: 1 and 2 threads give the same bits.
TEST(CgFields, SameBitsAtAnyThreadCount) {
  Pile pile = StackedPile(30, 60, 1.0);
  std::mt19937_64 rng(3);
  std::normal_distribution<double> n01;
  for (Disc& d : pile.discs) {
    d.x += 0.05 * n01(rng);
    d.vx = n01(rng);
    d.vy = n01(rng);
    d.omega = n01(rng);
  }
  CgOptions o = OptionsOver(CgDefaultWindow(30.0, 60.0));
  std::vector<CgSums> sums;
  for (int threads : {1, 2, 3}) {
    o.threads = threads;
    CgAccumulator acc(o);
    acc.AddFrame(0.0, pile.discs, &pile.contacts);
    acc.AddFrame(1.0, pile.discs, nullptr);
    sums.push_back(acc.Sums());
  }
  for (std::size_t k = 1; k < sums.size(); ++k)
    for (const auto member : {&CgSums::phi, &CgSums::vx, &CgSums::tg, &CgSums::omega_fl2, &CgSums::sxx, &CgSums::syy,
                              &CgSums::sxy, &CgSums::kxx, &CgSums::kyy}) {
      const auto& x = sums[0].*member;
      const auto& y = sums[k].*member;
      ASSERT_EQ(x.size(), y.size());
      EXPECT_EQ(std::memcmp(x.data(), y.data(), x.size() * sizeof(double)), 0);
    }
}

TEST(CgFields, BadOptionsAreRefusedWithWhatIsAllowed) {
  CgOptions o = OptionsOver({-5, 5, 0, 10});
  o.width = 0.0;
  EXPECT_THROW(CgAccumulator{o}, std::invalid_argument);
  o = OptionsOver({-5, 5, 0, 10});
  o.spacing = 3.0;
  try {
    CgAccumulator acc(o);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "grid spacing must be > 0 and <= half the cutoff radius 2.121000 (got 3.000000)");
  }
  o = OptionsOver({5, -5, 0, 10});
  EXPECT_THROW(CgAccumulator{o}, std::invalid_argument);
}

TEST(CgFields, FieldTableNamesEveryField) {
  CgField f;
  for (const CgFieldInfo& info : CgFieldTable()) {
    ASSERT_TRUE(CgFieldByName(info.name, f));
    EXPECT_EQ(f, info.field);
  }
  EXPECT_FALSE(CgFieldByName("presure", f));
  const Rect w = CgDefaultWindow(100.0, 290.0);
  EXPECT_EQ(w.x0, -48.5);
  EXPECT_EQ(w.x1, 48.5);
  EXPECT_EQ(w.y0, 1.5);
  EXPECT_EQ(w.y1, 148.5);
  EXPECT_EQ(CgDefaultWindow(30.0, 26.0).y1, 26.0);
}

}  // namespace
}  // namespace granary::analysis
