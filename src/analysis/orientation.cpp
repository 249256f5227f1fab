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

BodyAxis axis_of(const std::vector<const rundir::Disc*>& discs) {
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

std::vector<BodyAxis> body_axes(const std::vector<rundir::Disc>& discs) {
  std::vector<const rundir::Disc*> sorted(discs.size());
  for (std::size_t i = 0; i < discs.size(); ++i) sorted[i] = &discs[i];
  std::stable_sort(sorted.begin(), sorted.end(), [](const rundir::Disc* a, const rundir::Disc* b) { return a->mol < b->mol; });
  std::vector<BodyAxis> axes;
  std::vector<const rundir::Disc*> body;
  for (std::size_t i = 0; i < sorted.size(); ++i) {
    body.push_back(sorted[i]);
    if (i + 1 == sorted.size() || sorted[i + 1]->mol != sorted[i]->mol) {
      axes.push_back(axis_of(body));
      body.clear();
    }
  }
  return axes;
}

double acute(double axis_angle) {
  const double a = Wrap(axis_angle, kPi);
  return a > kPi / 2 ? kPi - a : a;
}

double order_parameter(const std::vector<double>& axis_angles, double director) {
  if (axis_angles.empty()) return kNaN;
  double sum = 0;
  for (double a : axis_angles) {
    const double c = std::cos(a - director);
    sum += c * c;
  }
  return 2 * sum / static_cast<double>(axis_angles.size()) - 1;
}

double angular_position(double s, double h) { return std::atan2(h, s); }

}  // namespace granary::analysis
