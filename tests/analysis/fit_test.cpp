// Fits recover the parameters that generated noisy synthetic data (fixed seed).
#include "analysis/fit.h"
#include "analysis/expression.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace granary::analysis {
namespace {

struct Data {
  std::vector<double> x, y, sigma;
};

Data MakeData(double (*f)(double), double noise, std::uint64_t seed) {
  Data d;
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, noise);
  for (double w = 6.0; w <= 40.0; w += 2.0) {
    d.x.push_back(w);
    d.y.push_back(f(w) + gauss(rng));
    d.sigma.push_back(noise);
  }
  return d;
}

// |fitted - true| within 4 standard errors, and the se itself is of the right size.
void ExpectRecovered(const FitResult& r, const std::string& name, double truth, double max_se) {
  const FitParameter* p = r.Parameter(name);
  ASSERT_NE(p, nullptr) << name;
  EXPECT_NEAR(p->value, truth, 4.0 * p->se) << name;
  EXPECT_GT(p->se, 0.0) << name;
  EXPECT_LT(p->se, max_se) << name;
  EXPECT_LT(p->ci_low, p->value);
  EXPECT_GT(p->ci_high, p->value);
}

TEST(Fit, Beverloo2dRecoversCAndK) {
  const Data d = MakeData([](double w) { return 0.8 * std::pow(w - 1.5, 1.5); }, 0.5, 1);
  const FitResult r = MakeFitModel(WithDataGuess(Beverloo2d(), d.x, d.y), d.x, d.y, d.sigma);
  ASSERT_TRUE(r.Ok()) << r.status;
  ExpectRecovered(r, "C", 0.8, 0.01);
  ExpectRecovered(r, "k", 1.5, 0.2);
  EXPECT_EQ(r.dof, static_cast<int>(d.x.size()) - 2);
  // chi2 of a correct model with known sigma ~ dof (within 5 sigma of chi2 spread).
  EXPECT_NEAR(r.chi2, r.dof, 5.0 * std::sqrt(2.0 * r.dof));
  ASSERT_EQ(r.residuals.size(), d.x.size());
  for (std::size_t i = 0; i < d.x.size(); ++i) EXPECT_NEAR(r.residuals[i], d.y[i] - r.fitted[i], 1e-12);
}

TEST(Fit, FreeExponentRecoversB) {
  const Data d = MakeData([](double w) { return 0.3 * std::pow(w - 1.0, 1.72); }, 0.5, 2);
  const FitResult r = MakeFitModel(WithDataGuess(BeverlooFree(), d.x, d.y), d.x, d.y, d.sigma);
  ASSERT_TRUE(r.Ok()) << r.status;
  ExpectRecovered(r, "b", 1.72, 0.05);
  ExpectRecovered(r, "C", 0.3, 0.05);
}

TEST(Fit, MankocRecoversCAndB) {
  const Data d = MakeData(
      [](double w) { return 0.9 * (1.0 - std::exp(-0.3 * (w - 1.0)) / 2.0) * std::pow(w - 1.0, 1.5); }, 0.3, 3);
  const FitResult r = MakeFitModel(WithDataGuess(Mankoc(), d.x, d.y), d.x, d.y, d.sigma);
  ASSERT_TRUE(r.Ok()) << r.status;
  ExpectRecovered(r, "C", 0.9, 0.01);
  ExpectRecovered(r, "b", 0.3, 0.1);
}

TEST(Fit, UserModelUnweighted) {
  // A user's own form: exponential decay Q/Q0 = exp(-a (L)^c) as in ch. 5b.
  std::vector<double> x, y;
  std::mt19937_64 rng(4);
  std::normal_distribution<double> gauss(0.0, 0.005);
  for (double l = 1; l <= 40; l += 3) {
    x.push_back(l);
    y.push_back(std::exp(-0.25 * std::pow(l, 0.3)) + gauss(rng));
  }
  FitModel m{"two_outlets", "exp(-a * L^c)", "L", {{"a", 0.1}, {"c", 0.5}}};
  const FitResult r = MakeFitModel(m, x, y);
  ASSERT_TRUE(r.Ok()) << r.status;
  ExpectRecovered(r, "a", 0.25, 0.05);
  ExpectRecovered(r, "c", 0.3, 0.05);
  EXPECT_NEAR(r.Evaluate(10.0), std::exp(-r.Parameter("a")->value * std::pow(10.0, r.Parameter("c")->value)), 1e-12);
}

TEST(Fit, UndeterminedParameterHasNoError) {
  // y does not depend on b where the data are (exp(-b x) ~ 0 for x >= 6 once b is large):
  // b must come back without a standard error and with a warning, not with se = 0.
  std::vector<double> x, y;
  for (double w = 6; w <= 20; w += 2) {
    x.push_back(w);
    y.push_back(2.0 * w + 0.01 * std::sin(w));
  }
  FitModel m{"flat_b", "a * x + exp(-b * x)", "x", {{"a", 1.0}, {"b", 50.0}}};
  const FitResult r = MakeFitModel(m, x, y);
  ASSERT_TRUE(r.Ok()) << r.status;
  EXPECT_NEAR(r.Parameter("a")->value, 2.0, 1e-3);
  EXPECT_GT(r.Parameter("a")->se, 0.0);
  EXPECT_TRUE(std::isnan(r.Parameter("b")->se));
  EXPECT_EQ(r.warning, "b not determined by the data");
  EXPECT_EQ(r.quality, FitQuality::kIllDetermined);
  EXPECT_EQ(r.Verdict(), "ill-determined: b not determined by the data");
}

TEST(Fit, ConfidenceIntervalsCoverTheTruth) {
  // 300 noisy data sets from Beverloo 2-D: the 95% intervals must contain the true k in about
  // 95% of them (binomial sd 1.3%), which checks the covariance scaling and the t quantile.
  int covered_c = 0, covered_k = 0, fitted = 0;
  for (std::uint64_t seed = 100; seed < 400; ++seed) {
    const Data d = MakeData([](double w) { return 0.8 * std::pow(w - 1.5, 1.5); }, 1.0, seed);
    const FitResult r = MakeFitModel(WithDataGuess(Beverloo2d(), d.x, d.y), d.x, d.y, d.sigma);
    if (!r.Ok()) continue;
    ++fitted;
    const FitParameter* c = r.Parameter("C");
    const FitParameter* k = r.Parameter("k");
    covered_c += (c->ci_low <= 0.8 && 0.8 <= c->ci_high) ? 1 : 0;
    covered_k += (k->ci_low <= 1.5 && 1.5 <= k->ci_high) ? 1 : 0;
  }
  ASSERT_EQ(fitted, 300);
  EXPECT_GT(covered_c, 0.90 * fitted);
  EXPECT_LT(covered_c, 0.995 * fitted);
  EXPECT_GT(covered_k, 0.90 * fitted);
  EXPECT_LT(covered_k, 0.995 * fitted);
}

TEST(Fit, TooFewPointsIsReportedNotFitted) {
  const std::vector<double> x = {10, 12, 14};
  const std::vector<double> y = {20, 30, 41};
  // Three widths, three parameters: nothing to fit. The start values are not results.
  const FitResult r = MakeFitModel(WithDataGuess(BeverlooFree(), x, y), x, y);
  EXPECT_FALSE(r.Ok());
  EXPECT_EQ(r.quality, FitQuality::kNotFitted);
  EXPECT_EQ(r.Verdict(), "not fitted: 3 points for 3 parameters (needs at least 4)");
  for (const FitParameter& p : r.parameters) {
    EXPECT_TRUE(std::isnan(p.value)) << p.name << " = " << p.value;
    EXPECT_TRUE(std::isfinite(p.initial)) << p.name;
  }
  EXPECT_EQ(r.Parameter("b")->initial, 1.5);
}

TEST(Fit, GoodFitSaysGood) {
  const Data d = MakeData([](double w) { return 0.8 * std::pow(w - 1.5, 1.5); }, 0.5, 1);
  const FitResult r = MakeFitModel(WithDataGuess(Beverloo2d(), d.x, d.y), d.x, d.y, d.sigma);
  EXPECT_EQ(r.quality, FitQuality::kGood);
  EXPECT_EQ(r.Verdict(), "good");
}

// A law that misses the points by far more than their errors (Beverloo's law plus a wave of 4
// errors' amplitude, errors of 0.5) keeps quality kGood (its parameters are determined) but its
// verdict reads "poor" and says why.
TEST(Fit, AWeightedFitThatMissesThePointsSaysSo) {
  Data d = MakeData([](double w) { return 0.8 * std::pow(w - 1.5, 1.5); }, 0.5, 1);
  for (std::size_t i = 0; i < d.x.size(); ++i) d.y[i] = 0.8 * std::pow(d.x[i] - 1.5, 1.5) + 2.0 * std::sin(d.x[i]);
  const FitResult r = MakeFitModel(WithDataGuess(Beverloo2d(), d.x, d.y), d.x, d.y, d.sigma);
  ASSERT_EQ(r.quality, FitQuality::kGood) << r.Verdict();
  ASSERT_GT(r.chi2 / r.dof, 4.0);  // about (2 / 0.5)^2 / 2 = 8
  EXPECT_NE(r.Verdict().find("the law misses the points by more than their errors"), std::string::npos) << r.Verdict();
  EXPECT_EQ(r.Verdict().rfind("poor: chi2/dof = ", 0), 0u) << r.Verdict();  // not "good"
  EXPECT_EQ(r.Rating(), "poor");                                            // the fit tables' "fit quality" column
  EXPECT_LT(r.MisfitP(), kMisfitP);
  // Unweighted, there are no errors to miss by: the verdict is as before.
  const FitResult u = MakeFitModel(WithDataGuess(Beverloo2d(), d.x, d.y), d.x, d.y);
  EXPECT_EQ(u.Verdict().find("misses"), std::string::npos) << u.Verdict();
  EXPECT_EQ(u.Rating(), "good");
  EXPECT_TRUE(std::isnan(u.MisfitP()));
}

// The demo's four widths (W = 5, 7, 9, 12) under the free-exponent law: GSL converges, but
// C, k and b each have a 95% interval holding 0 (C in [-20, 22]): ill-determined, not good.
TEST(Fit, FreeExponentFromFourPointsIsIllDetermined) {
  const std::vector<double> x = {5, 7, 9, 12};
  const std::vector<double> y = {1.695, 2.834, 6.472, 9.55};
  const FitResult r = MakeFitModel(WithDataGuess(BeverlooFree(), x, y), x, y);
  ASSERT_TRUE(r.Ok()) << r.status;
  EXPECT_EQ(r.quality, FitQuality::kIllDetermined);
  for (const FitParameter& p : r.parameters) EXPECT_TRUE(p.CiSpansZero()) << p.name;
  EXPECT_EQ(r.Verdict(), "ill-determined: 95% CI of C, k, b include 0; 1 degree of freedom");
  // The 2-parameter law on the same points determines C but not k's sign.
  const FitResult two = MakeFitModel(WithDataGuess(Beverloo2d(), x, y), x, y);
  EXPECT_EQ(two.quality, FitQuality::kIllDetermined);
  EXPECT_FALSE(two.Parameter("C")->CiSpansZero());
  EXPECT_EQ(two.Verdict(), "ill-determined: 95% CI of k includes 0");
}

TEST(Fit, SolverFailureShowsNoValues) {
  // No parameter step reduces the residuals (the model overflows for every a near the
  // start), so the solver stops without converging: its last step is not an estimate.
  const std::vector<double> x = {1, 2, 3, 4, 5};
  const std::vector<double> y = {1, 2, 3, 4, 5};
  const FitResult r = MakeFitModel({"overflow", "exp(exp(a * x))", "x", {{"a", 10.0}}}, x, y);
  EXPECT_FALSE(r.Ok()) << r.Verdict();
  EXPECT_EQ(r.quality, FitQuality::kFailed);
  EXPECT_TRUE(std::isnan(r.Parameter("a")->value));
  EXPECT_EQ(r.Verdict().rfind("failed: ", 0), 0u) << r.Verdict();
}

TEST(Fit, BadModelTextThrows) { EXPECT_THROW(MakeFitModel({"bad", "C*(x", "x", {}}, {}, {}), ExpressionError); }

}  // namespace
}  // namespace granary::analysis
