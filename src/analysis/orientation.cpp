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
  add1(cos2_sum, o.cos2_sum);
  add1(region_count, o.region_count);
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
  if (sums.s_sum.empty()) {
    sums.s_sum.assign(nh, std::vector<double>(static_cast<std::size_t>(sb), 0.0));
    sums.s_count = sums.s_sum;
    sums.theta_sum.assign(nr, std::vector<double>(static_cast<std::size_t>(tb), 0.0));
    sums.theta_count = sums.theta_sum;
    sums.cos2_sum.assign(regions.size(), 0.0);
    sums.region_count.assign(regions.size(), 0.0);
    sums.window_axes.assign(static_cast<std::size_t>(ab), 0.0);
    sums.s_range = range;
  }
  ++sums.frames;
  const std::vector<rundir::Body> bodies = rundir::BodiesOf(discs);
  const std::vector<BodyAxis> axes = BodyAxes(discs);
  for (std::size_t k = 0; k < bodies.size(); ++k) {
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
      const auto& g = regions[i];
      if (bodies[k].x < g.x0 || bodies[k].x > g.x1 || bodies[k].y < g.y0 || bodies[k].y > g.y1) continue;
      const double c = std::cos(axis - g.director);
      sums.cos2_sum[i] += c * c;
      sums.region_count[i] += 1;
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

std::vector<double> OrderParameters(const OrientationSums& sums, const OrientationOptions& o) {
  (void)o;
  std::vector<double> s;
  for (std::size_t i = 0; i < sums.cos2_sum.size(); ++i)
    s.push_back(sums.region_count[i] > 0 ? 2 * sums.cos2_sum[i] / sums.region_count[i] - 1 : kNaN);
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
