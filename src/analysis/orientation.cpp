// See orientation.h.
#include "analysis/orientation.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace granary::analysis {

namespace {
constexpr double kPi = std::numbers::pi;

double Wrap(double angle, double period) {
  double a = std::fmod(angle, period);
  if (a < 0) a += period;
  return a >= period ? 0.0 : a;
}
}  // namespace

BodyAxis AxisOf(const std::vector<const rundir::Disc*>& discs) {
  BodyAxis axis;
  if (discs.size() < 2) return axis;
  std::size_t a = 0, b = 1;
  double far = -1;
  for (std::size_t i = 0; i < discs.size(); ++i)
    for (std::size_t j = i + 1; j < discs.size(); ++j) {
      const double d = std::hypot(discs[j]->x - discs[i]->x, discs[j]->y - discs[i]->y);
      if (d > far) far = d, a = i, b = j;
    }
  axis.elongated = true;
  const double dx = discs[b]->x - discs[a]->x, dy = discs[b]->y - discs[a]->y;
  axis.angle = Wrap(std::atan2(dy, dx), kPi);
  const double ra = discs[a]->radius, rb = discs[b]->radius;
  if (ra != rb) {
    const rundir::Disc& big = ra > rb ? *discs[a] : *discs[b];
    const rundir::Disc& small = ra > rb ? *discs[b] : *discs[a];
    axis.head = Wrap(std::atan2(small.y - big.y, small.x - big.x), 2 * kPi);
  }
  return axis;
}

std::vector<BodyAxis> BodyAxes(const std::vector<rundir::Disc>& discs) {
  std::vector<const rundir::Disc*> sorted(discs.size());
  for (std::size_t i = 0; i < discs.size(); ++i) sorted[i] = &discs[i];
  std::stable_sort(sorted.begin(), sorted.end(),
                   [](const rundir::Disc* a, const rundir::Disc* b) { return a->mol < b->mol; });
  std::vector<BodyAxis> axes;
  std::vector<const rundir::Disc*> body;
  for (std::size_t i = 0; i < sorted.size(); ++i) {
    body.push_back(sorted[i]);
    if (i + 1 == sorted.size() || sorted[i + 1]->mol != sorted[i]->mol) {
      axes.push_back(AxisOf(body));
      body.clear();
    }
  }
  return axes;
}

double Acute(double axis_angle) {
  const double a = Wrap(axis_angle, kPi);
  return a > kPi / 2 ? kPi - a : a;
}

double OrderParameter(const std::vector<double>& axis_angles, double director) {
  if (axis_angles.empty()) return kNaN;
  double sum = 0;
  for (double a : axis_angles) {
    const double c = std::cos(a - director);
    sum += c * c;
  }
  return 2 * sum / static_cast<double>(axis_angles.size()) - 1;
}

double AngularPosition(double s, double h) { return std::atan2(h, s); }

}  // namespace granary::analysis

namespace granary::analysis {

void OrientationSums::Add(const OrientationSums& o) {
  auto add2 = [](std::vector<std::vector<double>>& a, const std::vector<std::vector<double>>& b) {
    if (a.empty()) a = std::vector<std::vector<double>>(b.size());
    for (std::size_t i = 0; i < b.size() && i < a.size(); ++i) {
      if (a[i].empty()) a[i].assign(b[i].size(), 0.0);
      for (std::size_t j = 0; j < b[i].size() && j < a[i].size(); ++j) a[i][j] += b[i][j];
    }
  };
  auto add1 = [](std::vector<double>& a, const std::vector<double>& b) {
    if (a.empty()) a.assign(b.size(), 0.0);
    for (std::size_t i = 0; i < b.size() && i < a.size(); ++i) a[i] += b[i];
  };
  frames += o.frames;
  add2(s_sum, o.s_sum);
  add2(s_count, o.s_count);
  add2(theta_sum, o.theta_sum);
  add2(theta_count, o.theta_count);
  add1(region_count, o.region_count);
  add1(cos2psi_sum, o.cos2psi_sum);
  add1(sin2psi_sum, o.sin2psi_sum);
  add1(flow_count, o.flow_count);
  add1(vx_sum, o.vx_sum);
  add1(vy_sum, o.vy_sum);
  add1(v2_sum, o.v2_sum);
  add1(window_axes, o.window_axes);
  if (s_range == 0) s_range = o.s_range;
}

std::vector<OrientationOptions::Region> OrientationRegions(const OrientationOptions& o, const silo::OutletFrame& f) {
  if (!o.regions.empty()) return o.regions;
  // |s| < 5, 0 < h < 10 in the outlet's frame, as a rectangle in the silo.
  const double xs[2] = {f.cx + 5 * f.ax, f.cx - 5 * f.ax}, ys[2] = {f.cy + 5 * f.ay, f.cy - 5 * f.ay};
  OrientationOptions::Region r;
  r.name = "above the outlet";
  r.x0 = std::min({xs[0], xs[1], xs[0] + 10 * f.nx, xs[1] + 10 * f.nx});
  r.x1 = std::max({xs[0], xs[1], xs[0] + 10 * f.nx, xs[1] + 10 * f.nx});
  r.y0 = std::min({ys[0], ys[1], ys[0] + 10 * f.ny, ys[1] + 10 * f.ny});
  r.y1 = std::max({ys[0], ys[1], ys[0] + 10 * f.ny, ys[1] + 10 * f.ny});
  r.director = std::atan2(f.ny, f.nx);  // into the silo: the flow's line
  return {r};
}

void AddOrientationFrame(const std::vector<rundir::Disc>& discs, const silo::OutletFrame& f, double half_width,
                         const OrientationOptions& o, OrientationSums& sums) {
  const std::size_t nh = o.heights.size(), nr = o.radii.size();
  const int sb = std::max(1, o.s_bins), tb = std::max(1, o.theta_bins), ab = std::max(1, o.axis_bins);
  const std::vector<OrientationOptions::Region> regions = OrientationRegions(o, f);
  const double range = o.s_range > 0 ? o.s_range : half_width;
  if (sums.frames == 0) {  // not s_sum.empty(): without heights it stays empty
    sums.s_sum.assign(nh, std::vector<double>(static_cast<std::size_t>(sb), 0.0));
    sums.s_count = sums.s_sum;
    sums.theta_sum.assign(nr, std::vector<double>(static_cast<std::size_t>(tb), 0.0));
    sums.theta_count = sums.theta_sum;
    for (auto* v : {&sums.region_count, &sums.cos2psi_sum, &sums.sin2psi_sum, &sums.flow_count, &sums.vx_sum,
                    &sums.vy_sum, &sums.v2_sum})
      v->assign(regions.size(), 0.0);
    sums.window_axes.assign(static_cast<std::size_t>(ab), 0.0);
    sums.s_range = range;
  }
  ++sums.frames;
  const std::vector<rundir::Body> bodies = rundir::BodiesOf(discs);
  const std::vector<BodyAxis> axes = BodyAxes(discs);
  auto inside = [](const OrientationOptions::Region& g, const rundir::Body& b) {
    return !(b.x < g.x0 || b.x > g.x1 || b.y < g.y0 || b.y > g.y1);
  };
  for (std::size_t k = 0; k < bodies.size(); ++k) {
    // The flow direction from every body, discs too: the director is the flow's, which the
    // mixture shares (both species move with the bulk), and at small X_db the few dumbbells
    // alone would give a noisier direction of the same flow.
    for (std::size_t i = 0; i < regions.size(); ++i) {
      if (!inside(regions[i], bodies[k])) continue;
      const double vx = bodies[k].vx, vy = bodies[k].vy;
      sums.flow_count[i] += 1;
      sums.vx_sum[i] += vx;
      sums.vy_sum[i] += vy;
      sums.v2_sum[i] += vx * vx + vy * vy;
    }
    if (!axes[k].elongated) continue;
    const double axis = axes[k].angle, a = Acute(axis);
    const double px = bodies[k].x - f.cx, py = bodies[k].y - f.cy;
    const double s = px * f.ax + py * f.ay, h = px * f.nx + py * f.ny;
    for (std::size_t i = 0; i < nh; ++i) {
      if (std::fabs(h - o.heights[i]) > o.band / 2 || std::fabs(s) >= range) continue;
      const auto bin =
          static_cast<std::size_t>(std::clamp(static_cast<int>((s + range) / (2 * range) * sb), 0, sb - 1));
      sums.s_sum[i][bin] += a;
      sums.s_count[i][bin] += 1;
    }
    const double r = std::hypot(s, h), theta = AngularPosition(s, h);
    if (h >= 0) {
      for (std::size_t i = 0; i < nr; ++i) {
        if (std::fabs(r - o.radii[i]) > o.ring / 2) continue;
        const auto bin = static_cast<std::size_t>(std::clamp(static_cast<int>(theta / kPi * tb), 0, tb - 1));
        sums.theta_sum[i][bin] += a;
        sums.theta_count[i][bin] += 1;
      }
      if (std::fabs(theta - o.window_theta) <= o.window_dtheta / 2 && std::fabs(r - o.window_radius) <= o.window_dr / 2)
        sums.window_axes[static_cast<std::size_t>(std::clamp(static_cast<int>(axis / kPi * ab), 0, ab - 1))] += 1;
    }
    for (std::size_t i = 0; i < regions.size(); ++i) {
      if (!inside(regions[i], bodies[k])) continue;
      sums.region_count[i] += 1;
      sums.cos2psi_sum[i] += std::cos(2 * axis);
      sums.sin2psi_sum[i] += std::sin(2 * axis);
    }
  }
}

namespace {
OrientationProfile Profile(const std::vector<std::vector<double>>& sum, const std::vector<std::vector<double>>& count,
                           std::vector<double> centre) {
  OrientationProfile p;
  p.centre = std::move(centre);
  p.count = count;
  for (std::size_t i = 0; i < sum.size(); ++i) {
    p.mean.emplace_back(sum[i].size(), kNaN);
    for (std::size_t j = 0; j < sum[i].size(); ++j)
      if (count[i][j] > 0) p.mean[i][j] = sum[i][j] / count[i][j];
  }
  return p;
}
}  // namespace

OrientationProfile OrientationAgainstS(const OrientationSums& sums, const OrientationOptions& o) {
  const int sb = std::max(1, o.s_bins);
  std::vector<double> centre;
  for (int j = 0; j < sb; ++j) centre.push_back(-sums.s_range + (j + 0.5) * 2 * sums.s_range / sb);
  return Profile(sums.s_sum, sums.s_count, centre);
}

OrientationProfile OrientationAgainstTheta(const OrientationSums& sums, const OrientationOptions& o) {
  const int tb = std::max(1, o.theta_bins);
  std::vector<double> centre;
  for (int j = 0; j < tb; ++j) centre.push_back((j + 0.5) * kPi / tb);
  return Profile(sums.theta_sum, sums.theta_count, centre);
}

double FlowDirection(const OrientationSums& sums, std::size_t region) {
  if (region >= sums.flow_count.size() || !(sums.flow_count[region] > 0)) return kNaN;
  const double n = sums.flow_count[region];
  const double mx = sums.vx_sum[region] / n, my = sums.vy_sum[region] / n;
  const double mean2 = mx * mx + my * my;
  const double variance = std::max(0.0, sums.v2_sum[region] / n - mean2);
  if (!(mean2 > 9 * variance / n)) return kNaN;
  return std::atan2(my, mx);
}

std::vector<double> RegionDirectors(const OrientationSums& sums,
                                    const std::vector<OrientationOptions::Region>& regions) {
  std::vector<double> d;
  for (std::size_t i = 0; i < regions.size(); ++i)
    d.push_back(regions[i].flow_director ? FlowDirection(sums, i) : regions[i].director);
  return d;
}

std::vector<double> OrderParameters(const OrientationSums& sums, const std::vector<double>& directors) {
  std::vector<double> s;
  for (std::size_t i = 0; i < sums.region_count.size(); ++i) {
    const double n = sums.region_count[i], d = i < directors.size() ? directors[i] : kNaN;
    s.push_back(n > 0 && std::isfinite(d)
                    ? (std::cos(2 * d) * sums.cos2psi_sum[i] + std::sin(2 * d) * sums.sin2psi_sum[i]) / n
                    : kNaN);
  }
  return s;
}

std::vector<double> AxisDensity(const std::vector<double>& counts) {
  double total = 0;
  for (double c : counts) total += c;
  std::vector<double> d(counts.size(), kNaN);
  if (total <= 0 || counts.empty()) return d;
  const double width = kPi / static_cast<double>(counts.size());
  for (std::size_t i = 0; i < counts.size(); ++i) d[i] = counts[i] / (total * width);
  return d;
}

}  // namespace granary::analysis
