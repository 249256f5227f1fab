// The shape table against closed forms: every Shape has a row whose name the spec reads back,
// and each row's disc layout gives the body's length, disc area, disc count and default name
// the thesis' shapes have (dumbbell: two touching discs of d; snowman: D_s and D_b touching;
// rod: n touching discs in a line).
#include "rundir/shape_table.h"

#include <gtest/gtest.h>

#include <numbers>
#include <set>

#include <nlohmann/json.hpp>

namespace granary {
namespace {

Species Of(Shape shape, double d, double big = 1.0, int n = 2) {
  Species s;
  s.shape = shape;
  s.diameter = d;
  s.big_diameter = big;
  s.n = n;
  return s;
}

TEST(ShapeTable, EveryShapeHasOneRowWhoseNameTheSpecReads) {
  std::set<Shape> seen;
  for (const ShapeRow& row : ShapeTable()) {
    EXPECT_TRUE(seen.insert(row.shape).second) << row.name;
    EXPECT_EQ(&ShapeRowOf(row.shape), &row);
    EXPECT_EQ(FindShapeRow(row.name), &row);
    EXPECT_EQ(ToString(row.shape), row.name);
    const nlohmann::json spec = {{"bodies", {{"species", {{{"shape", row.name}, {"big_diameter", 1.5}}}}}}};
    EXPECT_EQ(RunSpec::FromJson(spec).bodies.species.at(0).shape, row.shape) << row.name;
  }
  for (Shape s : {Shape::kDisc, Shape::kDumbbell, Shape::kSnowman, Shape::kRod}) EXPECT_TRUE(seen.count(s));
  EXPECT_EQ(FindShapeRow("ellipse"), nullptr);
}

TEST(ShapeTable, LayoutsGiveTheClosedFormLengthAreaAndDiscs) {
  const double q = std::numbers::pi / 4;
  EXPECT_DOUBLE_EQ(BodyLength(Of(Shape::kDisc, 1.4)), 1.4);
  EXPECT_DOUBLE_EQ(BodyArea(Of(Shape::kDisc, 1.4)), q * 1.4 * 1.4);
  EXPECT_DOUBLE_EQ(BodyLength(Of(Shape::kDumbbell, 1.0)), 2.0);
  EXPECT_DOUBLE_EQ(BodyArea(Of(Shape::kDumbbell, 1.0)), 2 * q);
  EXPECT_DOUBLE_EQ(BodyLength(Of(Shape::kSnowman, 1.0, 1.5)), 2.5);
  EXPECT_DOUBLE_EQ(BodyArea(Of(Shape::kSnowman, 1.0, 1.5)), q * (1.0 + 2.25));
  EXPECT_DOUBLE_EQ(BodyLength(Of(Shape::kRod, 1.0, 1.0, 5)), 5.0);
  EXPECT_DOUBLE_EQ(BodyArea(Of(Shape::kRod, 1.0, 1.0, 5)), 5 * q);
  EXPECT_EQ(DiscsOf(Of(Shape::kRod, 1.0, 1.0, 5)).r.size(), 5u);
  // Neighbouring discs touch: centre distance = sum of radii.
  for (const ShapeRow& row : ShapeTable()) {
    const DiscLayout l = row.layout(Of(row.shape, 1.0, 1.5, 3));
    for (std::size_t k = 1; k < l.x.size(); ++k) EXPECT_DOUBLE_EQ(l.x[k] - l.x[k - 1], l.r[k] + l.r[k - 1]) << row.name;
  }
}

TEST(ShapeTable, DefaultNamesAndTheSnowmansBound) {
  const nlohmann::json rods = {{"bodies", {{"species", {{{"shape", "rod"}, {"n", 4}}}}}}};
  EXPECT_EQ(RunSpec::FromJson(rods).bodies.species.at(0).name, "rod4");
  const nlohmann::json snowman = {{"bodies", {{"species", {{{"shape", "snowman"}, {"big_diameter", 2.5}}}}}}};
  try {
    RunSpec::FromJson(snowman);
    ADD_FAILURE() << "no error";
  } catch (const SpecError& e) {
    EXPECT_EQ(std::string(e.what()), "/bodies/species/0/big_diameter: D_b/D_s must be in [1, 2] (got 2.5/1.0 = 2.5)");
  }
}

}  // namespace
}  // namespace granary
