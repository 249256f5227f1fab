// Silo walls, outlet gaps, plug and obstacles as segment/point/circle elements.
#include "silo/geometry.h"

#include <algorithm>
#include <utility>

namespace granary::silo {
namespace {

void AddSegment(SiloGeometry& g, double ax, double ay, double bx, double by, WallGroup group) {
  WallElement e;
  e.kind = ElementKind::kSegment;
  e.group = group;
  e.ax = ax;
  e.ay = ay;
  e.bx = bx;
  e.by = by;
  g.elements.push_back(e);
}

void AddPoint(SiloGeometry& g, double x, double y) {
  WallElement e;
  e.kind = ElementKind::kPoint;
  e.group = WallGroup::kOpen;
  e.ax = x;
  e.ay = y;
  g.elements.push_back(e);
}

// A straight wall from `from` to `to` (coordinate along it) with gaps [lo, hi]; `at` maps a
// coordinate along the wall to a point.
template <typename At>
void AddWallWithGaps(SiloGeometry& g, double from, double to, std::vector<std::pair<double, double>> gaps, At at) {
  std::sort(gaps.begin(), gaps.end());
  double cur = from;
  for (const auto& [lo, hi] : gaps) {
    auto [ax, ay] = at(cur);
    auto [bx, by] = at(lo);
    if (lo > cur) AddSegment(g, ax, ay, bx, by, WallGroup::kAlways);
    auto [cx, cy] = at(hi);
    AddSegment(g, bx, by, cx, cy, WallGroup::kPlug);
    if (lo > from) AddPoint(g, bx, by);
    if (hi < to) AddPoint(g, cx, cy);
    cur = hi;
  }
  if (to > cur) {
    auto [ax, ay] = at(cur);
    auto [bx, by] = at(to);
    AddSegment(g, ax, ay, bx, by, WallGroup::kAlways);
  }
}

}  // namespace

SiloGeometry BuildGeometry(const Silo& silo, double wall_height) {
  SiloGeometry g;
  const double hw = silo.width / 2;
  g.half_width = hw;
  g.wall_height = wall_height;
  std::vector<std::pair<double, double>> base_gaps, left_gaps, right_gaps;
  for (const BaseOutlet& o : silo.base_outlets) {
    base_gaps.emplace_back(o.center - o.width / 2, o.center + o.width / 2);
    OutletFrame f;
    f.cx = o.center;
    f.cy = 0;
    f.ax = 1;
    f.ay = 0;
    f.nx = 0;
    f.ny = 1;
    f.width = o.width;
    g.outlets.push_back(f);
  }
  for (const SideOutlet& o : silo.side_outlets) {
    (o.wall == Wall::kLeft ? left_gaps : right_gaps).emplace_back(o.bottom, o.bottom + o.width);
    OutletFrame f;
    f.cx = o.wall == Wall::kLeft ? -hw : hw;
    f.cy = o.bottom + o.width / 2;
    f.ax = 0;
    f.ay = 1;
    f.nx = o.wall == Wall::kLeft ? 1 : -1;
    f.ny = 0;
    f.width = o.width;
    g.outlets.push_back(f);
  }
  AddWallWithGaps(g, -hw, hw, base_gaps, [](double x) { return std::pair{x, 0.0}; });
  AddWallWithGaps(g, 0.0, wall_height, left_gaps, [hw](double y) { return std::pair{-hw, y}; });
  AddWallWithGaps(g, 0.0, wall_height, right_gaps, [hw](double y) { return std::pair{hw, y}; });
  for (const Obstacle& o : silo.obstacles) {
    WallElement e;
    e.kind = ElementKind::kCircle;
    e.group = WallGroup::kAlways;
    e.ax = o.x;
    e.ay = o.y;
    e.radius = o.diameter / 2;
    g.elements.push_back(e);
  }
  return g;
}

Closest ClosestPoint(const WallElement& e, double px, double py) {
  if (e.kind != ElementKind::kSegment) return {e.ax, e.ay, true};
  const double dx = e.bx - e.ax, dy = e.by - e.ay;
  const double t = ((px - e.ax) * dx + (py - e.ay) * dy) / (dx * dx + dy * dy);
  // Only the interior of a segment acts; its ends are separate point elements where they
  // matter (outlet edges), so a disc over the joint of two collinear segments (base and
  // plug) has exactly one contact.
  if (t < 0.0 || t > 1.0) return {0.0, 0.0, false};
  return {e.ax + t * dx, e.ay + t * dy, true};
}

int SideOf(const SiloGeometry& g, int element) {
  const WallElement& e = g.elements[static_cast<std::size_t>(element)];
  if (e.kind != ElementKind::kSegment || e.group != WallGroup::kAlways) return -1;
  if (e.ay == 0.0 && e.by == 0.0) return static_cast<int>(Side::kBase);
  if (e.ax == -g.half_width && e.bx == -g.half_width) return static_cast<int>(Side::kLeft);
  if (e.ax == g.half_width && e.bx == g.half_width) return static_cast<int>(Side::kRight);
  return -1;
}

int SegmentUnder(const SiloGeometry& g, Side side, double px, double py) {
  for (std::size_t k = 0; k < g.elements.size(); ++k) {
    if (SideOf(g, static_cast<int>(k)) != static_cast<int>(side)) continue;
    if (ClosestPoint(g.elements[k], px, py).valid) return static_cast<int>(k);
  }
  return -1;
}

}  // namespace granary::silo
