// Small statistics used by every analysis: mean with standard error, straight-line least
// squares with parameter errors, histograms and the exponential (geometric) tail fit of
// avalanche-size distributions. Pure functions; NaN marks "not available".
#pragma once

#include <cstddef>
#include <limits>
#include <span>
#include <vector>

namespace granary::analysis {

inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// A replica average: mean, standard error of the mean (sample sd / sqrt(n)) and n.
// n = 1 gives se = NaN (unknown), n = 0 gives mean = NaN.
struct MeanSe {
  double mean = kNaN;
  double se = kNaN;
  int n = 0;
};
MeanSe MeanAndSe(std::span<const double> values);
// Ignores NaN entries (runs where the quantity is not defined).
MeanSe MeanSeFinite(std::span<const double> values);

// Ordinary least squares y = intercept + slope x with the textbook standard errors
// (residual variance / (n - 2)). Needs n >= 3 distinct x for errors; fewer gives NaNs.
struct LineFit {
  double slope = kNaN;
  double intercept = kNaN;
  double slope_se = kNaN;
  double intercept_se = kNaN;
  int n = 0;
};
LineFit FitLine(std::span<const double> x, std::span<const double> y);

// Equal-width bins over [lo, hi); values outside are counted in `below`/`above`.
struct Histogram {
  double lo = 0.0;
  double hi = 1.0;
  std::vector<double> counts;
  double below = 0.0;
  double above = 0.0;
  double BinWidth() const { return counts.empty() ? kNaN : (hi - lo) / static_cast<double>(counts.size()); }
  double Center(std::size_t i) const { return lo + (static_cast<double>(i) + 0.5) * BinWidth(); }
  double Total() const;
  // Probability density of bin i (counts / (total * width)), total including below/above.
  double Density(std::size_t i) const;
};
Histogram MakeHistogram(std::span<const double> values, int bins, double lo, double hi);
// Range from the data (min..max, widened a little so the maximum falls inside).
Histogram MakeHistogram(std::span<const double> values, int bins);

// Counts on a fixed grid (bin k = [(k - 1/2) width, (k + 1/2) width)), kept from the first to
// the last occupied bin: histograms of different runs merge exactly, so a run's histogram can
// be cached and the replicas' pooled afterwards.
struct GridHistogram {
  double width = 0.05;
  long long first = 0;  // grid index of counts[0]
  std::vector<double> counts;
  void Add(double value);
  void Merge(const GridHistogram& other);  // same width
  double Total() const;
  // As a Histogram of at most `max_bins` bins (adjacent grid bins merged by a whole factor).
  Histogram Coarse(int max_bins) const;
};

// Exponential tail of a distribution of integer sizes s (avalanche sizes, ch. 4 and 6):
// P(s) ~ q^s for s >= s_min, i.e. exp(-s / s_decay), s_decay = -1/ln q. Maximum likelihood
// for the geometric distribution of s - s_min: q = m / (1 + m), m = <s - s_min> over the tail.
// se of s_decay from the delta method on se(m) = sd / sqrt(n_tail).
struct ExpTailFit {
  double s_min = kNaN;
  double q = kNaN;
  double s_decay = kNaN;
  double s_decay_se = kNaN;
  int n_tail = 0;
};
ExpTailFit FitExponentialTail(std::span<const double> sizes, double s_min);

double Median(std::vector<double> values);

}  // namespace granary::analysis
