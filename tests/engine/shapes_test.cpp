// Shape templates against hand-computed masses, centres and moments of inertia.
#include "silo/shapes.h"

#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

namespace granary::engine {
namespace {

constexpr double kPi = std::numbers::pi;

TEST(Shapes, DumbbellMassAndInertia) {
  Species s;
  s.shape = Shape::kDumbbell;
  s.diameter = 1.0;
  const silo::ShapeTemplate t = silo::MakeTemplate(s, 1.0, 0);
  const double m = kPi * 0.25;  // each disc: pi r^2
  EXPECT_DOUBLE_EQ(t.mass, 2 * m);
  // two discs at +-0.5: 2 (m 0.25 + 0.4 m 0.25)
  EXPECT_NEAR(t.inertia, 2 * (m * 0.25 + 0.4 * m * 0.25), 1e-15);
  EXPECT_DOUBLE_EQ(t.bound_radius, 1.0);
}

TEST(Shapes, SnowmanCentreOfMassAndInertia) {
  Species s;
  s.shape = Shape::kSnowman;
  s.diameter = 1.0;
  s.big_diameter = 1.5;
  const silo::ShapeTemplate t = silo::MakeTemplate(s, 1.0, 0);
  const double ms = kPi * 0.25, mb = kPi * 0.75 * 0.75;
  const double l = 1.25;  // centres (1 + 1.5) / 2 apart
  const double a = mb * l / (ms + mb), b = ms * l / (ms + mb);
  EXPECT_NEAR(t.ox[0], -a, 1e-15);
  EXPECT_NEAR(t.ox[1], b, 1e-15);
  EXPECT_NEAR(t.inertia, ms * a * a + mb * b * b + 0.4 * (ms * 0.25 + mb * 0.5625), 1e-14);
}

TEST(Shapes, RodDiscsTouchInALine) {
  Species s;
  s.shape = Shape::kRod;
  s.n = 4;
  s.diameter = 0.707;
  const silo::ShapeTemplate t = silo::MakeTemplate(s, 1.0, 0);
  ASSERT_EQ(t.r.size(), 4u);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(t.ox[k + 1] - t.ox[k], 0.707, 1e-15);
  EXPECT_NEAR(t.ox[0] + t.ox[3], 0.0, 1e-15);
}

TEST(Shapes, SpeciesCountsSumToTotal) {
  Bodies b;
  b.count = 101;
  b.species.resize(3);
  b.species[0].fraction = 1.0 / 3;
  b.species[1].fraction = 1.0 / 3;
  b.species[2].fraction = 1.0 / 3;
  const auto c = silo::SpeciesCounts(b);
  EXPECT_EQ(c[0] + c[1] + c[2], 101);
  EXPECT_EQ(c[0], 34);
  EXPECT_EQ(c[1], 33);
  EXPECT_EQ(c[2], 34);
}

}  // namespace
}  // namespace granary::engine
