#include "silo/silo_outline.h"

#include <cmath>
#include <cstdio>
#include <numbers>

#include "silo/geometry.h"

namespace granary::silo {

SiloOutline OutlineOf(const Silo& silo, double wall_top) {
  const SiloGeometry g = BuildGeometry(silo, wall_top);
  SiloOutline out;
  for (std::size_t k = 0; k < g.elements.size(); ++k) {
    const WallElement& e = g.elements[k];
    if (e.kind == ElementKind::kCircle) {
      out.obstacles.push_back({e.ax, e.ay, e.radius});
      continue;
    }
    const int side = SideOf(g, static_cast<int>(k));
    if (side < 0) continue;  // plug, outlet edges
    const double ox = side == static_cast<int>(Side::kLeft) ? -1 : side == static_cast<int>(Side::kRight) ? 1 : 0;
    const double oy = side == static_cast<int>(Side::kBase) ? -1 : 0;
    out.walls.push_back({e.ax, e.ay, e.bx, e.by, ox, oy});
  }
  for (const OutletFrame& o : g.outlets) {
    const double h = o.width / 2;
    out.outlets.push_back({o.cx - o.ax * h, o.cy - o.ay * h, o.cx + o.ax * h, o.cy + o.ay * h, -o.nx, -o.ny});
  }
  return out;
}

namespace {
struct Mesh {
  std::vector<double> xy;
  std::vector<int> triangles;
  std::vector<const char*> colours;
  int Point(double x, double y) {
    xy.push_back(x);
    xy.push_back(y);
    return static_cast<int>(xy.size() / 2 - 1);
  }
  void Triangle(int a, int b, int c, const char* colour) {
    triangles.insert(triangles.end(), {a, b, c});
    colours.push_back(colour);
  }
  // The segment and its copy moved `t` along the outward normal, as two triangles.
  void Band(const OutlineSegment& s, double t, const char* colour) {
    const int a = Point(s.ax, s.ay), b = Point(s.bx, s.by);
    const int c = Point(s.bx + t * s.ox, s.by + t * s.oy), d = Point(s.ax + t * s.ox, s.ay + t * s.oy);
    Triangle(a, b, c, colour);
    Triangle(a, c, d, colour);
  }
};
constexpr char kWallColour[] = "0.55 0.55 0.55";
constexpr char kOutletColour[] = "0.85 0.15 0.1";
constexpr char kObstacleColour[] = "0.3 0.3 0.3";
constexpr int kCircleFacets = 48;
}  // namespace

std::string SiloVtk(const SiloOutline& outline, double thickness) {
  Mesh m;
  for (const auto& w : outline.walls) m.Band(w, thickness, kWallColour);
  for (const auto& o : outline.outlets) m.Band(o, thickness, kOutletColour);
  for (const auto& c : outline.obstacles) {
    const int centre = m.Point(c.x, c.y), first = m.Point(c.x + c.r, c.y);
    int prev = first;
    for (int k = 1; k <= kCircleFacets; ++k) {
      const double a = 2 * std::numbers::pi * k / kCircleFacets;
      const int next = k == kCircleFacets ? first : m.Point(c.x + c.r * std::cos(a), c.y + c.r * std::sin(a));
      m.Triangle(centre, prev, next, kObstacleColour);
      prev = next;
    }
  }
  const std::size_t points = m.xy.size() / 2, cells = m.colours.size();
  std::string s =
      "# vtk DataFile Version 3.0\nGranary silo: walls (grey), outlets (red), obstacles (dark grey)\nASCII\n"
      "DATASET UNSTRUCTURED_GRID\nPOINTS " +
      std::to_string(points) + " double\n";
  char buf[96];
  for (std::size_t i = 0; i < points; ++i) {
    std::snprintf(buf, sizeof buf, "%.10g %.10g -0.5\n", m.xy[2 * i], m.xy[2 * i + 1]);
    s += buf;
  }
  s += "CELLS " + std::to_string(cells) + " " + std::to_string(4 * cells) + "\n";
  for (std::size_t i = 0; i < cells; ++i)
    s += "3 " + std::to_string(m.triangles[3 * i]) + " " + std::to_string(m.triangles[3 * i + 1]) + " " +
         std::to_string(m.triangles[3 * i + 2]) + "\n";
  s += "CELL_TYPES " + std::to_string(cells) + "\n";
  for (std::size_t i = 0; i < cells; ++i) s += "5\n";
  s += "CELL_DATA " + std::to_string(cells) + "\nCOLOR_SCALARS colour 3\n";
  for (const char* c : m.colours) s += std::string(c) + "\n";
  return s;
}

}  // namespace granary::silo
