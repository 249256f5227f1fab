// Implementation of stats.h.
#include "analysis/stats.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace granary::analysis {

MeanSe MeanAndSe(std::span<const double> values) {
  MeanSe r;
  r.n = static_cast<int>(values.size());
  if (values.empty()) return r;
  double sum = 0.0;
  for (double v : values) sum += v;
  const double n = static_cast<double>(values.size());
  r.mean = sum / n;
  if (values.size() < 2) return r;
  double ss = 0.0;
  for (double v : values) ss += (v - r.mean) * (v - r.mean);
  r.se = std::sqrt(ss / (n - 1.0) / n);
  return r;
}

MeanSe MeanSeFinite(std::span<const double> values) {
  std::vector<double> finite;
  for (double v : values)
    if (std::isfinite(v)) finite.push_back(v);
  return MeanAndSe(finite);
}

LineFit FitLine(std::span<const double> x, std::span<const double> y) {
  if (x.size() != y.size())
    throw std::invalid_argument("fit_line: x has " + std::to_string(x.size()) + " values but y has " +
                                std::to_string(y.size()));
  LineFit f;
  f.n = static_cast<int>(x.size());
  if (x.size() < 2) return f;
  const double n = static_cast<double>(x.size());
  double mx = 0.0, my = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    mx += x[i];
    my += y[i];
  }
  mx /= n;
  my /= n;
  double sxx = 0.0, sxy = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    sxx += (x[i] - mx) * (x[i] - mx);
    sxy += (x[i] - mx) * (y[i] - my);
  }
  if (sxx <= 0.0) return f;
  f.slope = sxy / sxx;
  f.intercept = my - f.slope * mx;
  if (x.size() < 3) return f;
  double rss = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double r = y[i] - f.intercept - f.slope * x[i];
    rss += r * r;
  }
  const double s2 = rss / (n - 2.0);
  f.slope_se = std::sqrt(s2 / sxx);
  f.intercept_se = std::sqrt(s2 * (1.0 / n + mx * mx / sxx));
  return f;
}

double Histogram::Total() const {
  double t = below + above;
  for (double c : counts) t += c;
  return t;
}

double Histogram::Density(std::size_t i) const {
  const double t = Total();
  if (t <= 0.0) return 0.0;
  return counts.at(i) / (t * BinWidth());
}

Histogram MakeHistogram(std::span<const double> values, int bins, double lo, double hi) {
  if (bins < 1) throw std::invalid_argument("make_histogram: bins must be >= 1 (got " + std::to_string(bins) + ")");
  if (!(hi > lo))
    throw std::invalid_argument("make_histogram: need hi > lo (got lo=" + std::to_string(lo) +
                                ", hi=" + std::to_string(hi) + ")");
  Histogram h;
  h.lo = lo;
  h.hi = hi;
  h.counts.assign(static_cast<std::size_t>(bins), 0.0);
  const double w = (hi - lo) / bins;
  for (double v : values) {
    if (!std::isfinite(v)) continue;
    if (v < lo) {
      h.below += 1.0;
    } else if (v >= hi) {
      h.above += 1.0;
    } else {
      auto i = static_cast<std::size_t>((v - lo) / w);
      if (i >= h.counts.size()) i = h.counts.size() - 1;
      h.counts[i] += 1.0;
    }
  }
  return h;
}

Histogram MakeHistogram(std::span<const double> values, int bins) {
  double lo = std::numeric_limits<double>::infinity();
  double hi = -lo;
  for (double v : values) {
    if (!std::isfinite(v)) continue;
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  if (!std::isfinite(lo)) {
    lo = 0.0;
    hi = 1.0;
  }
  const double span = hi - lo;
  const double pad = span > 0.0 ? 1e-9 * span : std::max(1e-9, 1e-9 * std::abs(hi));
  if (span <= 0.0) {
    lo -= 0.5;
    hi += 0.5;
  }
  return MakeHistogram(values, bins, lo, hi + pad);
}

ExpTailFit FitExponentialTail(std::span<const double> sizes, double s_min) {
  ExpTailFit f;
  f.s_min = s_min;
  std::vector<double> excess;
  for (double s : sizes)
    if (std::isfinite(s) && s >= s_min) excess.push_back(s - s_min);
  f.n_tail = static_cast<int>(excess.size());
  const MeanSe m = MeanAndSe(excess);
  if (f.n_tail < 2 || !(m.mean > 0.0)) return f;
  f.q = m.mean / (1.0 + m.mean);
  // s_decay = -1 / ln(m / (1 + m)) = 1 / ln(1 + 1/m); d s_decay / d m = s_decay^2 / (m (1 + m)).
  f.s_decay = 1.0 / std::log1p(1.0 / m.mean);
  f.s_decay_se = f.s_decay * f.s_decay / (m.mean * (1.0 + m.mean)) * m.se;
  return f;
}

double Median(std::vector<double> values) {
  if (values.empty()) return kNaN;
  std::sort(values.begin(), values.end());
  const std::size_t n = values.size();
  return n % 2 == 1 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

void GridHistogram::Add(double value) {
  if (!std::isfinite(value)) return;
  const long long k = std::llround(value / width);
  if (counts.empty()) {
    first = k;
    counts.assign(1, 0.0);
  } else if (k < first) {
    counts.insert(counts.begin(), static_cast<std::size_t>(first - k), 0.0);
    first = k;
  } else if (k >= first + static_cast<long long>(counts.size())) {
    counts.resize(static_cast<std::size_t>(k - first + 1), 0.0);
  }
  counts[static_cast<std::size_t>(k - first)] += 1.0;
}

void GridHistogram::Merge(const GridHistogram& other) {
  if (other.counts.empty()) return;
  if (counts.empty()) {
    *this = other;
    return;
  }
  const long long lo = std::min(first, other.first);
  const long long hi = std::max(first + static_cast<long long>(counts.size()),
                                other.first + static_cast<long long>(other.counts.size()));
  std::vector<double> merged(static_cast<std::size_t>(hi - lo), 0.0);
  for (std::size_t i = 0; i < counts.size(); ++i) merged[static_cast<std::size_t>(first - lo) + i] += counts[i];
  for (std::size_t i = 0; i < other.counts.size(); ++i)
    merged[static_cast<std::size_t>(other.first - lo) + i] += other.counts[i];
  counts = std::move(merged);
  first = lo;
}

double GridHistogram::Total() const {
  double t = 0.0;
  for (double c : counts) t += c;
  return t;
}

Histogram GridHistogram::Coarse(int max_bins) const {
  Histogram h;
  if (counts.empty() || max_bins < 1) return h;
  const std::size_t factor =
      (counts.size() + static_cast<std::size_t>(max_bins) - 1) / static_cast<std::size_t>(max_bins);
  h.lo = (static_cast<double>(first) - 0.5) * width;
  const std::size_t bins = (counts.size() + factor - 1) / factor;
  h.hi = h.lo + static_cast<double>(bins * factor) * width;
  h.counts.assign(bins, 0.0);
  for (std::size_t i = 0; i < counts.size(); ++i) h.counts[i / factor] += counts[i];
  return h;
}

}  // namespace granary::analysis
