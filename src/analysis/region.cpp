// Implementation of region.h.
#include "analysis/region.h"

#include <algorithm>
#include <cmath>

namespace granary::analysis {

RegionSize Chapter3Region() { return {2.0, 10.0, "ch. 3: (W + 2d) x 10d"}; }
RegionSize Chapter4Region() { return RegionSize(); }
RegionSize Chapter6Region() { return {2.0, 5.0, "ch. 6: (W + 2 D_eq) x 5 D_eq", true}; }

Rect RegionAboveOutlet(double center, double width, const RegionSize& size) {
  const double half = 0.5 * (width + size.pad);
  return {center - half, center + half, 0.0, size.height};
}

namespace {

// Integral of sqrt(r^2 - x^2) from a to b (|a|, |b| <= r).
double ChordIntegral(double r, double a, double b) {
  auto g = [r](double x) {
    const double s = std::sqrt(std::max(0.0, r * r - x * x));
    return 0.5 * (x * s + r * r * std::asin(std::clamp(x / r, -1.0, 1.0)));
  };
  return g(b) - g(a);
}

// Area of the disc (centre 0, radius r) intersected with {x <= X, y <= Y}:
// integral over x in [-r, X] of the length of {y <= Y} inside the chord, which is
// 2s where s <= Y, Y + s where -s < Y < s, 0 where Y <= -s (s = sqrt(r^2 - x^2)).
double QuadrantArea(double r, double X, double Y) {
  const double u = std::clamp(X, -r, r);
  if (Y >= r) return 2.0 * ChordIntegral(r, -r, u);
  if (Y <= -r) return 0.0;
  const double c = std::sqrt(r * r - Y * Y);  // |x| < c: the chord is cut by y = Y
  double area = 0.0;
  const double a = -c, b = std::min(c, u);
  if (b > a) area += Y * (b - a) + ChordIntegral(r, a, b);
  if (Y > 0.0) {
    if (u > -r) area += 2.0 * ChordIntegral(r, -r, std::min(-c, u));
    if (u > c) area += 2.0 * ChordIntegral(r, c, u);
  }
  return area;
}

}  // namespace

double DiscRectOverlap(double cx, double cy, double r, const Rect& q) {
  if (r <= 0.0) return 0.0;
  if (q.x1 <= cx - r || q.x0 >= cx + r || q.y1 <= cy - r || q.y0 >= cy + r) return 0.0;
  if (q.x0 <= cx - r && q.x1 >= cx + r && q.y0 <= cy - r && q.y1 >= cy + r) return std::numbers::pi * r * r;
  const double x0 = q.x0 - cx, x1 = q.x1 - cx, y0 = q.y0 - cy, y1 = q.y1 - cy;
  const double area =
      QuadrantArea(r, x1, y1) - QuadrantArea(r, x0, y1) - QuadrantArea(r, x1, y0) + QuadrantArea(r, x0, y0);
  return std::max(0.0, area);
}

RegionFrame MakeRegionFrame(std::span<const rundir::Disc> discs, std::span<const rundir::Body> bodies,
                            const Rect& region) {
  RegionFrame f;
  double covered = 0.0;
  for (const rundir::Disc& d : discs) covered += DiscRectOverlap(d.x, d.y, d.radius, region);
  f.phi = covered / region.Area();
  double mvx = 0, mvy = 0, mw = 0;
  int n = 0;
  for (const rundir::Body& b : bodies) {
    if (!region.Contains(b.x, b.y)) continue;
    mvx += b.vx;
    mvy += b.vy;
    mw += b.omega;
    ++n;
  }
  f.bodies = n;
  if (n < 2) return f;
  mvx /= n;
  mvy /= n;
  mw /= n;
  double t1 = 0, t2 = 0;
  for (const rundir::Body& b : bodies) {
    if (!region.Contains(b.x, b.y)) continue;
    const double dv2 = (b.vx - mvx) * (b.vx - mvx) + (b.vy - mvy) * (b.vy - mvy);
    t1 += dv2;
    t2 += b.mass * dv2 + b.inertia * (b.omega - mw) * (b.omega - mw);
  }
  f.tg_translational = 0.5 * t1 / n;
  f.tg_full = t2 / (3.0 * n);
  return f;
}

void RegionAccumulator::Add(std::span<const rundir::Disc> discs, std::span<const rundir::Body> bodies,
                            bool velocities) {
  const RegionFrame f = MakeRegionFrame(discs, bodies, stats_.region);
  ++stats_.frames;
  phi_.push_back(f.phi);
  tg_translational_.push_back(f.tg_translational);
  tg_full_.push_back(f.tg_full);
  if (!velocities) return;
  ++stats_.velocity_frames;
  for (const rundir::Body& b : bodies) {
    if (!stats_.region.Contains(b.x, b.y)) continue;
    stats_.vx.Add(b.vx);
    stats_.vy.Add(b.vy);
  }
}

RegionStats RegionAccumulator::Result() const {
  RegionStats s = stats_;
  s.phi = MeanAndSe(phi_);
  s.tg_translational = MeanSeFinite(tg_translational_);
  s.tg_full = MeanSeFinite(tg_full_);
  return s;
}

}  // namespace granary::analysis
