// The silo outline (walls with their outer side, outlets, obstacles) and silo.vtk, the mesh of
// it that OVITO reads: legacy ASCII VTK, triangles only, one colour per triangle.
#include "silo/silo_outline.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <map>
#include <sstream>
#include <string>
#include <vector>

namespace granary::engine {
namespace {

Silo TestSilo() {
  Silo s;
  s.width = 20;
  s.base_outlets = {{0.0, 4.0}};
  s.side_outlets = {{Wall::kRight, 3.0, 2.0}};
  s.obstacles = {{0.0, 5.0, 2.0}};
  return s;
}

TEST(SiloOutline, WallsOutletsAndObstaclesWithTheirOuterSides) {
  const silo::SiloOutline o = silo::OutlineOf(TestSilo(), 30.0);
  // Base left and right of the outlet; left wall whole; right wall below and above its outlet.
  ASSERT_EQ(o.walls.size(), 5u);
  double base = 0, left = 0, right = 0;
  for (const auto& w : o.walls) {
    const double len = std::hypot(w.bx - w.ax, w.by - w.ay);
    if (w.oy == -1) base += len;
    if (w.ox == -1) left += len;
    if (w.ox == 1) right += len;
  }
  EXPECT_DOUBLE_EQ(base, 20 - 4);
  EXPECT_DOUBLE_EQ(left, 30);
  EXPECT_DOUBLE_EQ(right, 30 - 2);
  ASSERT_EQ(o.outlets.size(), 2u);
  EXPECT_DOUBLE_EQ(o.outlets[0].ax, -2);
  EXPECT_DOUBLE_EQ(o.outlets[0].bx, 2);
  EXPECT_DOUBLE_EQ(o.outlets[0].oy, -1);
  EXPECT_DOUBLE_EQ(o.outlets[1].ax, 10);
  EXPECT_DOUBLE_EQ(o.outlets[1].ay, 3);
  EXPECT_DOUBLE_EQ(o.outlets[1].by, 5);
  EXPECT_DOUBLE_EQ(o.outlets[1].ox, 1);
  ASSERT_EQ(o.obstacles.size(), 1u);
  EXPECT_DOUBLE_EQ(o.obstacles[0].r, 1);
}

TEST(SiloOutline, VtkIsATriangleMeshWithAColourPerTriangleOutsideTheSilo) {
  const std::string vtk = silo::SiloVtk(silo::OutlineOf(TestSilo(), 30.0), 0.5);
  std::istringstream in(vtk);
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "# vtk DataFile Version 3.0");
  std::getline(in, line);  // title
  std::getline(in, line);
  EXPECT_EQ(line, "ASCII");
  std::getline(in, line);
  EXPECT_EQ(line, "DATASET UNSTRUCTURED_GRID");
  std::string word, type;
  std::size_t points = 0, cells = 0, size = 0;
  in >> word >> points >> type;
  ASSERT_EQ(word, "POINTS");
  std::vector<std::array<double, 3>> p(points);
  for (auto& q : p) in >> q[0] >> q[1] >> q[2];
  in >> word >> cells >> size;
  ASSERT_EQ(word, "CELLS");
  // 7 bands of 2 triangles (5 walls, 2 outlets), a 48-gon for the obstacle.
  EXPECT_EQ(cells, 7u * 2 + 48);
  EXPECT_EQ(size, 4 * cells);
  std::vector<std::array<int, 3>> tri(cells);
  for (auto& t : tri) {
    int n = 0;
    in >> n >> t[0] >> t[1] >> t[2];
    ASSERT_EQ(n, 3);
    for (int v : t) ASSERT_LT(static_cast<std::size_t>(v), points);
  }
  in >> word >> size;
  ASSERT_EQ(word, "CELL_TYPES");
  for (std::size_t k = 0; k < cells; ++k) {
    int t = 0;
    in >> t;
    EXPECT_EQ(t, 5) << "VTK_TRIANGLE";
  }
  in >> word >> size;
  EXPECT_EQ(word, "CELL_DATA");
  std::getline(in, line);
  std::getline(in, line);
  EXPECT_EQ(line, "COLOR_SCALARS colour 3");
  std::map<std::string, int> colours;
  for (std::size_t k = 0; k < cells; ++k) {
    double r, g, b;
    in >> r >> g >> b;
    ++colours[std::to_string(r) + " " + std::to_string(g) + " " + std::to_string(b)];
    // Walls and outlets lie outside the silo (left of -10, right of 10, or below the base);
    // the obstacle's triangles inside its circle.
    const auto centroid = [&](int c) { return (p[tri[k][0]][c] + p[tri[k][1]][c] + p[tri[k][2]][c]) / 3; };
    const double x = centroid(0), y = centroid(1);
    if (r == g)
      EXPECT_TRUE(x < -10 || x > 10 || y < 0 || std::hypot(x, y - 5) < 1) << x << " " << y;
    else
      EXPECT_TRUE(y < 0 || x > 10) << "outlet band at " << x << " " << y;
    for (int v : tri[k]) EXPECT_EQ(p[v][2], -0.5);
  }
  EXPECT_EQ(colours.size(), 3u) << "walls, outlets, obstacles";
  std::getline(in, line);
  EXPECT_FALSE(std::getline(in, line) && !line.empty()) << "nothing after the colours: " << line;
}

}  // namespace
}  // namespace granary::engine
