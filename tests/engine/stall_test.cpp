// A stalled silo is clogged when an arch seals an outlet from the material above, discharged when
// the crater stays open to the top (stall.h), on hand-placed configurations with known answers.
#include "engine/stall.h"

#include <gtest/gtest.h>

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
  World w(WorldParams{}, {MakeTemplate(DiscSpecies(1.0), 1.0, 0)}, BuildGeometry(silo, 30));
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
  Row(w, -5.5, 5.5, 6.0);   // material above
  EXPECT_EQ(SealedOutlets(w), std::vector<bool>{true});

  World open = OpenSilo({{0.0, 2.0}}, {{0.0, 3.0, 2.0}});
  Row(open, -5.5, -4.5, 3.0);
  Row(open, -1.5, -1.5, 3.0);  // a gap of two diameters at x = -3 ...
  Row(open, 1.5, 5.5, 3.0);
  Row(open, -5.5, 5.5, 6.0);   // ... but the row above still seals it
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

}  // namespace
}  // namespace granary::engine
