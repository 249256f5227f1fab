// Implementation of region.h.
#include "analysis/region.h"

#include <algorithm>
#include <cmath>

namespace granary::analysis {

RegionSize chapter3_region() { return {2.0, 10.0, "ch. 3: (W + 2d) x 10d"}; }
RegionSize chapter4_region() { return RegionSize(); }

Rect region_above_outlet(double center, double width, const RegionSize& size) {
  const double half = 0.5 * (width + size.pad);
  return {center - half, center + half, 0.0, size.height};
}

namespace {

// Integral of sqrt(r^2 - x^2) from a to b (|a|, |b| <= r).
double chord_integral(double r, double a, double b) {
  auto g = [r](double x) {
    const double s = std::sqrt(std::max(0.0, r * r - x * x));
    return 0.5 * (x * s + r * r * std::asin(std::clamp(x / r, -1.0, 1.0)));
  };
  return g(b) - g(a);
}

// Area of the disc (centre 0, radius r) intersected with {x <= X, y <= Y}:
// integral over x in [-r, X] of the length of {y <= Y} inside the chord, which is
// 2s where s <= Y, Y + s where -s < Y < s, 0 where Y <= -s (s = sqrt(r^2 - x^2)).
double quadrant_area(double r, double X, double Y) {
  const double u = std::clamp(X, -r, r);
  if (Y >= r) return 2.0 * chord_integral(r, -r, u);
  if (Y <= -r) return 0.0;
  const double c = std::sqrt(r * r - Y * Y);  // |x| < c: the chord is cut by y = Y
  double area = 0.0;
  const double a = -c, b = std::min(c, u);
  if (b > a) area += Y * (b - a) + chord_integral(r, a, b);
  if (Y > 0.0) {
    if (u > -r) area += 2.0 * chord_integral(r, -r, std::min(-c, u));
    if (u > c) area += 2.0 * chord_integral(r, c, u);
  }
  return area;
}

}  // namespace

double disc_rect_overlap(double cx, double cy, double r, const Rect& q) {
  if (r <= 0.0) return 0.0;
  if (q.x1 <= cx - r || q.x0 >= cx + r || q.y1 <= cy - r || q.y0 >= cy + r) return 0.0;
  if (q.x0 <= cx - r && q.x1 >= cx + r && q.y0 <= cy - r && q.y1 >= cy + r) return std::numbers::pi * r * r;
  const double x0 = q.x0 - cx, x1 = q.x1 - cx, y0 = q.y0 - cy, y1 = q.y1 - cy;
  const double area = quadrant_area(r, x1, y1) - quadrant_area(r, x0, y1) - quadrant_area(r, x1, y0) +
                      quadrant_area(r, x0, y0);
  return std::max(0.0, area);
}

RegionFrame region_frame(std::span<const rundir::Disc> discs, std::span<const rundir::Body> bodies, const Rect& region) {
  RegionFrame f;
  double covered = 0.0;
  for (const rundir::Disc& d : discs) covered += disc_rect_overlap(d.x, d.y, d.radius, region);
  f.phi = covered / region.area();
  double mvx = 0, mvy = 0, mw = 0;
  int n = 0;
  for (const rundir::Body& b : bodies) {
    if (!region.contains(b.x, b.y)) continue;
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
    if (!region.contains(b.x, b.y)) continue;
    const double dv2 = (b.vx - mvx) * (b.vx - mvx) + (b.vy - mvy) * (b.vy - mvy);
    t1 += dv2;
    t2 += b.mass * dv2 + b.inertia * (b.omega - mw) * (b.omega - mw);
  }
  f.tg_translational = 0.5 * t1 / n;
  f.tg_full = t2 / (3.0 * n);
  return f;
}

void RegionAccumulator::add(std::span<const rundir::Disc> discs, std::span<const rundir::Body> bodies) {
  const RegionFrame f = region_frame(discs, bodies, stats_.region);
  ++stats_.frames;
  phi_.push_back(f.phi);
  tg_translational_.push_back(f.tg_translational);
  tg_full_.push_back(f.tg_full);
  for (const rundir::Body& b : bodies) {
    if (!stats_.region.contains(b.x, b.y)) continue;
    stats_.vx.add(b.vx);
    stats_.vy.add(b.vy);
  }
}

RegionStats RegionAccumulator::result() const {
  RegionStats s = stats_;
  s.phi = mean_se(phi_);
  s.tg_translational = mean_se_finite(tg_translational_);
  s.tg_full = mean_se_finite(tg_full_);
  return s;
}

}  // namespace granary::analysis
