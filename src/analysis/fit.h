// Nonlinear least-squares fits of a model y = f(x; p) with GSL's trust-region solver
// (gsl_multifit_nlinear, Levenberg-Marquardt, finite-difference Jacobian). Models are
// expression strings (expression.h), so the Beverloo forms of ch. 4-5 and any model a user
// writes go through the same code. A fit returns a value: parameters with standard errors
// and 95% confidence intervals, residuals, chi^2 and the GSL status, never dropped.
#pragma once

#include <map>
#include <span>
#include <string>
#include <vector>

#include "analysis/stats.h"

namespace granary::analysis {

struct FitModel {
  std::string name;                       // "beverloo_2d", or the user's label
  std::string expression;                 // e.g. "C * (x - k)^1.5"
  std::string variable = "x";             // the name of the independent variable in `expression`
  std::map<std::string, double> initial;  // starting values; missing parameters start at 1
  std::string title{};                    // in figure keys and captions ("2-D Beverloo"); "" = name
  const std::string& Shown() const { return title.empty() ? name : title; }
};

// The three forms of shared analyses.md; x = W/d.
FitModel Beverloo2d();    // Q = C (x - k)^(3/2)
FitModel BeverlooFree();  // Q = C (x - k)^b
FitModel Mankoc();        // Q = C (1 - exp(-b (x - 1)) / 2) (x - 1)^(3/2)

struct FitParameter {
  std::string name;
  double initial = kNaN;  // the start value the solver was given (never a result)
  double value = kNaN;    // the estimate; NaN when the fit was not made or failed
  double se = kNaN;       // NaN: not determined by the data (singular covariance)
  double ci_low = kNaN;   // 95% confidence interval, Student t with dof = n - p
  double ci_high = kNaN;
  bool Determined() const;   // an estimate with a finite standard error
  bool CiSpansZero() const;  // the 95% interval holds 0: the sign is not even known
};

// How far a fit can be trusted, worst first.
enum class FitQuality {
  kNotFitted,      // too few points for the parameters (or no data): nothing to show
  kFailed,         // the solver did not converge: its last step is not an estimate
  kIllDetermined,  // converged, but a parameter has no standard error or a 95% interval holding 0
  kGood,           // converged, every parameter determined, no interval holds 0
};
std::string ToString(FitQuality quality);  // "not fitted", "failed", "ill-determined", "good"

// A weighted fit whose chi2 has a smaller chance than this under the law (p of chi2 for its
// degrees of freedom) says so in its verdict: the law misses the points by more than their errors.
inline constexpr double kMisfitP = 1e-3;

struct FitResult {
  std::string model_name;
  std::string model_title;  // FitModel::Shown()
  std::string expression;
  std::string variable = "x";
  // Fits over several variables (fit_model_multi): their names and each data point's values
  // (points[i][j] = variable j of point i); `x` then holds the first variable's values.
  std::vector<std::string> variables;
  std::vector<std::vector<double>> points;
  std::vector<FitParameter> parameters;
  std::vector<double> x, y, sigma;        // the data used (sigma empty = unweighted)
  std::vector<double> fitted, residuals;  // residual = y - fitted
  double chi2 = kNaN;                     // sum of squared (weighted) residuals
  int dof = 0;
  int iterations = 0;
  int gsl_status = -1;      // GSL_SUCCESS (0) or the GSL error code
  std::string status;       // gsl_strerror(gsl_status) or why the fit was not tried
  std::string convergence;  // "small step", "small gradient", ... (GSL info)
  std::string warning;      // e.g. "b not determined by the data" (se = NaN)
  FitQuality quality = FitQuality::kNotFitted;
  // The solver converged: parameters hold estimates (perhaps ill-determined ones).
  bool Ok() const { return gsl_status == 0; }
  // One line for a table: "good", "poor: chi2/dof = 18 (p = 2e-09): the law misses ...",
  // "ill-determined: 95% CI of C, k include 0", "not fitted:
  // 3 Point(s) for 3 Parameter(s)", "failed: ..."; with the GSL details where they help.
  std::string Verdict() const;
  // The verdict's first word: ToString(quality), but "poor" for a good fit that misses its
  // points (MisfitP() < kMisfitP).
  std::string Rating() const;
  // A weighted fit's chance of a chi2 this large under the law; NaN unweighted or unfitted.
  double MisfitP() const;
  const FitParameter* Parameter(const std::string& name) const;
  double Evaluate(double x_value) const;  // the fitted model at x (NaN if it cannot be evaluated)
  // The fitted model at values of `variables` (in that order); NaN if it cannot be evaluated.
  double EvaluateAt(std::span<const double> values) const;
};

// Fits `model` to (x, y). With sigma (same size, all > 0) the residuals are weighted by
// 1/sigma; the parameter covariance is then scaled by max(1, chi2/dof) (GSL's convention),
// unweighted by chi2/dof. Needs n > number of parameters; otherwise returns a result with
// status "not fitted: ..." and gsl_status -1. Parameter values are NaN unless the solver
// converged (the start values stay in `initial`). Throws ExpressionError for a bad model text.
FitResult MakeFitModel(const FitModel& model, std::span<const double> x, std::span<const double> y,
                       std::span<const double> sigma = {});

// The same over several variables: `points[i]` holds the values of `variables` (in order) at
// data point i, so a thesis law such as "a * W^(1.5 + X/2) / (1.43 + 17 X^2)" is fitted
// across every point of a figure at once. Every other name in `expression` is a parameter.
FitResult FitModelMulti(const std::string& name, const std::string& expression,
                        const std::vector<std::string>& variables, const std::vector<std::vector<double>>& points,
                        std::span<const double> y, std::span<const double> sigma = {},
                        const std::map<std::string, double>& initial = {});

// Starting values for the built-in forms from the data (C from the largest point, k = 0,
// b = 1.5 or 1): keeps the solver away from (x - k) < 0.
FitModel WithDataGuess(FitModel model, std::span<const double> x, std::span<const double> y);

}  // namespace granary::analysis
