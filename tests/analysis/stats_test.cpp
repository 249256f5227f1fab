// Tests of stats.h against hand-computed values.
#include "analysis/stats.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace granary::analysis {
namespace {

TEST(MeanSe, HandComputed) {
  const std::vector<double> v = {1.0, 2.0, 3.0, 4.0};
  const MeanSe m = MeanAndSe(v);
  EXPECT_EQ(m.n, 4);
  EXPECT_DOUBLE_EQ(m.mean, 2.5);
  // sample variance 5/3, se = sqrt(5/3/4)
  EXPECT_NEAR(m.se, std::sqrt(5.0 / 12.0), 1e-14);
}

TEST(MeanSe, SingleValueHasUnknownError) {
  const std::vector<double> v = {7.0};
  const MeanSe m = MeanAndSe(v);
  EXPECT_EQ(m.n, 1);
  EXPECT_DOUBLE_EQ(m.mean, 7.0);
  EXPECT_TRUE(std::isnan(m.se));
  EXPECT_TRUE(std::isnan(MeanAndSe(std::vector<double>{}).mean));
}

TEST(MeanSe, FiniteSkipsNaN) {
  const std::vector<double> v = {1.0, kNaN, 3.0};
  const MeanSe m = MeanSeFinite(v);
  EXPECT_EQ(m.n, 2);
  EXPECT_DOUBLE_EQ(m.mean, 2.0);
}

TEST(FitLine, ExactLine) {
  const std::vector<double> x = {0, 1, 2, 3, 4};
  std::vector<double> y;
  for (double xi : x) y.push_back(3.0 - 2.0 * xi);
  const LineFit f = FitLine(x, y);
  EXPECT_NEAR(f.slope, -2.0, 1e-13);
  EXPECT_NEAR(f.intercept, 3.0, 1e-13);
  EXPECT_NEAR(f.slope_se, 0.0, 1e-12);
}

TEST(FitLine, StandardErrorMatchesTextbook) {
  // y = x + (+1, -1, +1, -1): slope 0.8 (by hand), residual variance and se as below.
  const std::vector<double> x = {0, 1, 2, 3};
  const std::vector<double> y = {1, 0, 3, 2};
  const LineFit f = FitLine(x, y);
  EXPECT_NEAR(f.slope, 0.6, 1e-13);  // sxy = 3, sxx = 5
  EXPECT_NEAR(f.intercept, 0.6, 1e-13);
  double rss = 0;
  for (int i = 0; i < 4; ++i) rss += std::pow(y[i] - 0.6 - 0.6 * x[i], 2);
  EXPECT_NEAR(f.slope_se, std::sqrt(rss / 2.0 / 5.0), 1e-13);
}

TEST(Histogram, CountsAndDensity) {
  const std::vector<double> v = {0.1, 0.2, 0.6, 0.9, 1.5, -1.0};
  const Histogram h = MakeHistogram(v, 2, 0.0, 1.0);
  ASSERT_EQ(h.counts.size(), 2u);
  EXPECT_EQ(h.counts[0], 2.0);
  EXPECT_EQ(h.counts[1], 2.0);
  EXPECT_EQ(h.above, 1.0);
  EXPECT_EQ(h.below, 1.0);
  EXPECT_DOUBLE_EQ(h.Density(0), 2.0 / (6.0 * 0.5));
  EXPECT_DOUBLE_EQ(h.Center(1), 0.75);
}

TEST(ExpTail, RecoversGeometricDecay) {
  // P(s) ~ q^s with q = 0.98: s_decay = -1/ln q = 49.5.
  const double q = 0.98;
  std::mt19937_64 rng(12345);
  std::geometric_distribution<int> geo(1.0 - q);
  std::vector<double> s;
  for (int i = 0; i < 20000; ++i) s.push_back(geo(rng));
  const ExpTailFit f = FitExponentialTail(s, 20.0);  // memoryless: any start gives the same q
  const double expected = -1.0 / std::log(q);
  EXPECT_NEAR(f.q, q, 0.002);
  EXPECT_NEAR(f.s_decay, expected, 4.0 * f.s_decay_se);
  EXPECT_GT(f.s_decay_se, 0.0);
  EXPECT_LT(f.s_decay_se, 1.5);
}

TEST(Median, OddAndEven) {
  EXPECT_DOUBLE_EQ(Median({3, 1, 2}), 2.0);
  EXPECT_DOUBLE_EQ(Median({4, 1, 2, 3}), 2.5);
}

}  // namespace
}  // namespace granary::analysis
