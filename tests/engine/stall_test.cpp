// A stalled silo is clogged when an arch seals an outlet from the material above, discharged when
// the crater stays open to the top (stall.h), on hand-placed configurations with known answers.
#include "engine/stall_world.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>

#include "world_parts.h"

namespace granary::engine {
namespace {

// A silo of width 12 (walls at x = +-6) with the outlets and obstacles given, outlets open.
World OpenSilo(std::vector<BaseOutlet> base, std::vector<Obstacle> obstacles = {}, std::vector<SideOutlet> side = {}) {
  Silo silo;
  silo.width = 12;
  silo.base_outlets = std::move(base);
  silo.obstacles = std::move(obstacles);
  silo.side_outlets = std::move(side);
  World w(WorldParams{}, {silo::MakeTemplate(DiscSpecies(1.0), 1.0, 0)}, silo::BuildGeometry(silo, 30));
  w.OpenOutlets();
  return w;
}

// A row of touching unit discs from x = from to x = to (inclusive) at height y.
void Row(World& w, double from, double to, double y) {
  for (double x = from; x <= to + 1e-9; x += 1.0) w.AddBody(0, x, y, 0);
}

// Dead zones of a flat bottom: triangular heaps against both walls down to the outlet edges.
void DeadZones(World& w, double outlet_half_width) {
  for (int layer = 0; layer < 3; ++layer) {
    const double y = 0.5 + layer * 0.87;
    Row(w, -5.5, -outlet_half_width - 0.5 - layer, y);
    Row(w, outlet_half_width + 0.5 + layer, 5.5, y);
  }
}

TEST(Stall, DischargedCraterIsOpenEvenWithABodyRestingOverTheGapEdge) {
  World w = OpenSilo({{0.0, 4.0}});
  DeadZones(w, 2.0);
  w.AddBody(0, 1.8, 0.45, 0);  // centre over the gap, resting on the outlet edge
  EXPECT_EQ(SealedOutlets(w), std::vector<bool>{false});
}

TEST(Stall, ArchOverTheOpeningSealsIt) {
  World w = OpenSilo({{0.0, 4.0}});
  DeadZones(w, 2.0);
  Row(w, -2.5, 2.5, 0.6);  // spans the gap, ends on the base beside the edges
  Row(w, -5.5, 5.5, 3.5);  // material above
  EXPECT_EQ(SealedOutlets(w), std::vector<bool>{true});
}

// The case the old rule (a body over the gap) got wrong: arches from an obstacle to the walls,
// nothing over the narrow opening below the obstacle.
TEST(Stall, ArchesBesideAnObstacleSealTheOutletAndAGapInOneOpensIt) {
  World w = OpenSilo({{0.0, 2.0}}, {{0.0, 3.0, 2.0}});
  Row(w, -5.5, -1.5, 3.0);  // obstacle surface at x = -1, wall at -6
  Row(w, 1.5, 5.5, 3.0);
  Row(w, -5.5, 5.5, 6.0);  // material above
  EXPECT_EQ(SealedOutlets(w), std::vector<bool>{true});

  World open = OpenSilo({{0.0, 2.0}}, {{0.0, 3.0, 2.0}});
  Row(open, -5.5, -4.5, 3.0);
  Row(open, -1.5, -1.5, 3.0);  // a gap of two diameters at x = -3 ...
  Row(open, 1.5, 5.5, 3.0);
  Row(open, -5.5, 5.5, 6.0);  // ... but the row above still seals it
  EXPECT_EQ(SealedOutlets(open), std::vector<bool>{true});
  World crater = OpenSilo({{0.0, 2.0}}, {{0.0, 3.0, 2.0}});
  Row(crater, -5.5, -4.5, 3.0);
  Row(crater, -1.5, -1.5, 3.0);
  Row(crater, 1.5, 5.5, 3.0);
  Row(crater, 1.5, 5.5, 6.0);  // material above the right passage only
  EXPECT_EQ(SealedOutlets(crater), std::vector<bool>{false});
}

TEST(Stall, ArchInsideASideOutletSealsIt) {
  World w = OpenSilo({}, {}, {{Wall::kRight, 2.0, 3.0}});
  for (double y = 0.5; y < 8; y += 1.0) w.AddBody(0, 5.5, y, 0);  // a column in front of the opening
  Row(w, -5.5, 4.5, 0.5);
  EXPECT_EQ(SealedOutlets(w), std::vector<bool>{true});

  World discharged = OpenSilo({}, {}, {{Wall::kRight, 2.0, 3.0}});
  Row(discharged, -5.5, 5.5, 0.5);  // what lies below the outlet's lower edge stays
  Row(discharged, -5.5, 5.5, 1.5);
  EXPECT_EQ(SealedOutlets(discharged), std::vector<bool>{false});
}

TEST(Stall, EachOutletIsJudgedOnItsOwn) {
  World w = OpenSilo({{-3.0, 2.0}, {3.0, 2.0}});
  Row(w, -4.5, -1.5, 0.6);  // an arch over the left outlet, up to the centre
  Row(w, -5.5, -1.5, 1.6);
  EXPECT_EQ(SealedOutlets(w), (std::vector<bool>{true, false}));
}

// The discs of a world as any engine's discs (stall.h), with the probe of stall_world.h.
std::vector<silo::DiscAt> DiscsOf(const World& w) {
  std::vector<silo::DiscAt> discs;
  for (int i = 0; i < w.DiscCount(); ++i) discs.push_back({w.disc_x_[i], w.disc_y_[i], w.disc_radius_[i]});
  return discs;
}

// What bounds the cavity of a sealed outlet, in order from its s < 0 end to its s > 0 end: the
// base and edge left of the opening, the arch's discs from left to right, the base on the right.
TEST(Stall, TheCavityUnderAnArchIsBoundedByTheArchFromLeftToRight) {
  // Discs 0..7, touching, on a half circle over the gap from the base left of it to the base
  // right of it (radius 0.5 / sin(pi / 14): neighbours one diameter apart).
  World w = OpenSilo({{0.0, 4.0}});
  const double radius = 0.5 / std::sin(std::numbers::pi / 14);
  for (int k = 0; k < 8; ++k) {
    const double a = std::numbers::pi * (7 - k) / 7;
    w.AddBody(0, radius * std::cos(a), 0.5 + radius * std::sin(a), 0);
  }
  Row(w, -5.5, 5.5, 4.0);  // material above
  const silo::OutletCavity c = silo::CavityUnder(w.Geometry(), DiscsOf(w), 0.5, 0);
  ASSERT_TRUE(c.sealed);
  std::vector<int> discs;
  for (const silo::CavityBound& b : c.edge) {
    if (b.kind == silo::CavityBound::Kind::kDisc) discs.push_back(b.index);
    EXPECT_NE(b.kind, silo::CavityBound::Kind::kOpen);
  }
  EXPECT_EQ(discs, (std::vector<int>{0, 1, 2, 3, 4, 5, 6, 7}));
  ASSERT_GE(c.edge.size(), 10u);
  EXPECT_EQ(c.edge.front().kind, silo::CavityBound::Kind::kElement);  // the left edge of the gap
  EXPECT_LT(c.edge.front().s, -1.5);
  EXPECT_EQ(c.edge.back().kind, silo::CavityBound::Kind::kElement);
  EXPECT_GT(c.edge.back().s, 1.5);

  // A flat arch sitting in the gap itself: the cavity is the passage below it.
  World flat = OpenSilo({{0.0, 4.0}});
  Row(flat, -2.5, 2.5, 0.45);  // discs 1..4 over the gap, 0 and 5 beside it
  Row(flat, -5.5, 5.5, 1.5);
  const silo::OutletCavity passage = silo::CavityUnder(flat.Geometry(), DiscsOf(flat), 0.5, 0);
  ASSERT_TRUE(passage.sealed);
  discs.clear();
  for (const silo::CavityBound& b : passage.edge)
    if (b.kind == silo::CavityBound::Kind::kDisc) discs.push_back(b.index);
  EXPECT_EQ(discs, (std::vector<int>{1, 2, 3, 4}));

  // Open to the top: no cavity, no edge.
  World crater = OpenSilo({{0.0, 4.0}});
  DeadZones(crater, 2.0);
  const silo::OutletCavity open = silo::CavityUnder(crater.Geometry(), DiscsOf(crater), 0.5, 0);
  EXPECT_FALSE(open.sealed);
  EXPECT_TRUE(open.edge.empty());
}

// A side outlet's cavity runs from below the opening (s < 0) to above it, whichever wall.
TEST(Stall, TheCavityOfASideOutletRunsFromBelowToAbove) {
  for (const Wall wall : {Wall::kRight, Wall::kLeft}) {
    const double x = wall == Wall::kRight ? 5.5 : -5.5, inner = wall == Wall::kRight ? 4.5 : -4.5;
    World w = OpenSilo({}, {}, {{wall, 2.0, 3.0}});
    w.AddBody(0, x, 0.5, 0);      // disc 0: under the opening
    w.AddBody(0, x, 1.5, 0);      // disc 1: at its lower edge
    w.AddBody(0, inner, 2.5, 0);  // disc 2: in front of it, in the silo
    w.AddBody(0, inner, 3.5, 0);  // disc 3
    w.AddBody(0, x, 5.5, 0);      // disc 4: at its upper edge (5)
    w.AddBody(0, inner, 4.5, 0);  // disc 5
    Row(w, -5.5, 5.5, 6.5);
    const silo::OutletCavity c = silo::CavityUnder(w.Geometry(), DiscsOf(w), 0.5, 0);
    ASSERT_TRUE(c.sealed);
    std::vector<int> discs;
    for (const silo::CavityBound& b : c.edge)
      if (b.kind == silo::CavityBound::Kind::kDisc) discs.push_back(b.index);
    SCOPED_TRACE(wall == Wall::kRight ? "right" : "left");
    ASSERT_FALSE(discs.empty());
    EXPECT_EQ(discs.front(), 1);
    EXPECT_EQ(discs.back(), 4);
    EXPECT_LT(c.edge.front().s, c.edge.back().s);
  }
}

// The probe is the narrowest gap a body could pass: each body's largest disc, the smallest of those.
TEST(Stall, ThePassageProbeIsTheSmallestOfTheBodiesLargestDiscs) {
  const std::vector<silo::DiscAt> discs{{0, 0, 0.5}, {1.25, 0, 0.75}, {5, 0, 0.5}, {6.25, 0, 0.75}};
  EXPECT_EQ(silo::PassageProbe(discs, {7, 7, 9, 9}), 0.75);  // two snowmen
  EXPECT_EQ(silo::PassageProbe(discs, {7, 7, 8, 9}), 0.5);   // a disc of d = 1 among them
  EXPECT_EQ(silo::PassageProbe({}, {}), std::numeric_limits<double>::infinity());
}

// Four upright snowmen (D_s = 1, D_b = 1.5, big disc on the base) across a silo 12 wide, gaps of
// 1.2 between their big discs and the walls, nothing above: a disc of the small size would pass
// every gap, no snowman passes any. The outlet is sealed; with the smallest disc as probe it
// would be judged open, and a stalled remove-mode run called discharged.
TEST(Stall, SnowmenWhoseGapsOnlyTheirSmallDiscFitsSealTheOutlet) {
  Silo silo;
  silo.width = 12;
  silo.base_outlets = {{0.0, 4.0}};
  Species snowman;
  snowman.shape = Shape::kSnowman;
  snowman.diameter = 1.0;
  snowman.big_diameter = 1.5;
  const silo::ShapeTemplate t = silo::MakeTemplate(snowman, 1.0, 0);
  const int big = t.r[0] > t.r[1] ? 0 : 1;
  // Rotated by theta, offset (ox, 0) lands at (ox cos theta, ox sin theta): the big disc below.
  const double theta = t.ox[big] > 0 ? -std::numbers::pi / 2 : std::numbers::pi / 2;
  World w(WorldParams{}, {t}, silo::BuildGeometry(silo, 30));
  w.OpenOutlets();
  for (double x : {-4.05, -1.35, 1.35, 4.05}) w.AddBody(0, x, 0.75 + std::fabs(t.ox[big]), theta);
  EXPECT_EQ(SealedOutlets(w), std::vector<bool>{true});
  std::vector<silo::DiscAt> discs;
  for (int i = 0; i < w.DiscCount(); ++i) discs.push_back({w.disc_x_[i], w.disc_y_[i], w.disc_radius_[i]});
  EXPECT_NEAR(discs[static_cast<std::size_t>(big)].y, 0.75, 1e-12);
  EXPECT_EQ(silo::SealedOutlets(w.Geometry(), discs, 0.5), std::vector<bool>{false});
}

// Bodies hanging into the gap from both its edges, an arch resting on them: the space under the
// arch is a pocket of the gap's passage that reaches neither side of the passage. Its edge must
// still be found (from the way out below): a clog whose arch nobody finds cannot be broken by
// remove_arch, and the run would end there.
TEST(Stall, AnArchHangingIntoTheGapFromBothEdgesBoundsItsCavity) {
  World w = OpenSilo({{0.0, 4.0}});
  w.AddBody(0, -1.7, -0.1, 0);  // over the left edge, its centre below the base
  for (double x = -1.5; x <= 1.5 + 1e-9; x += 1.0) w.AddBody(0, x, 0.9, 0);
  w.AddBody(0, 1.7, -0.1, 0);  // over the right edge
  Row(w, -5.5, 5.5, 3.0);      // material above
  EXPECT_EQ(SealedOutlets(w), std::vector<bool>{true});
  const silo::OutletCavity c = silo::CavityUnder(w.Geometry(), DiscsOf(w), 0.5, 0);
  ASSERT_TRUE(c.sealed);
  std::vector<int> discs;
  for (const silo::CavityBound& b : c.edge)
    if (b.kind == silo::CavityBound::Kind::kDisc) discs.push_back(b.index);
  // The hanging bodies and the arch's middle; the arch's end discs (1, 4) lie behind the hanging
  // ones, out of the probe's reach.
  EXPECT_EQ(discs, (std::vector<int>{0, 2, 3, 5}));
}

}  // namespace
}  // namespace granary::engine
