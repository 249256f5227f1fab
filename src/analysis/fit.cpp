// Implementation of fit.h over gsl_multifit_nlinear.
#include "analysis/fit.h"

#include <gsl/gsl_blas.h>
#include <gsl/gsl_cdf.h>
#include <gsl/gsl_errno.h>
#include <gsl/gsl_multifit_nlinear.h>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <memory>
#include <sstream>
#include <stdexcept>

#include "analysis/expression.h"

namespace granary::analysis {

FitModel Beverloo2d() { return {"beverloo_2d", "C * (x - k)^1.5", "x", {{"C", 1.0}, {"k", 0.0}}, "2-D Beverloo"}; }
FitModel BeverlooFree() {
  return {"beverloo_free", "C * (x - k)^b", "x", {{"C", 1.0}, {"k", 0.0}, {"b", 1.5}}, "Beverloo, free exponent"};
}
FitModel Mankoc() {
  return {"mankoc", "C * (1 - exp(-b * (x - 1)) / 2) * (x - 1)^1.5", "x", {{"C", 1.0}, {"b", 1.0}}, "Mankoc"};
}

FitModel WithDataGuess(FitModel model, std::span<const double> x, std::span<const double> y) {
  if (x.empty() || x.size() != y.size()) return model;
  std::size_t imax = 0;
  for (std::size_t i = 1; i < x.size(); ++i)
    if (x[i] > x[imax]) imax = i;
  const double xm = x[imax];
  const double ym = y[imax];
  if (!(xm > 1.0) || !(ym > 0.0)) return model;
  if (model.name == "mankoc") {
    model.initial["C"] = ym / std::pow(xm - 1.0, 1.5);
  } else if (model.name == "beverloo_2d" || model.name == "beverloo_free") {
    model.initial["C"] = ym / std::pow(xm, 1.5);
  }
  return model;
}

bool FitParameter::Determined() const { return std::isfinite(value) && std::isfinite(se); }

bool FitParameter::CiSpansZero() const {
  return std::isfinite(ci_low) && std::isfinite(ci_high) && ci_low <= 0.0 && ci_high >= 0.0;
}

std::string ToString(FitQuality quality) {
  switch (quality) {
    case FitQuality::kNotFitted: return "not fitted";
    case FitQuality::kFailed: return "failed";
    case FitQuality::kIllDetermined: return "ill-determined";
    case FitQuality::kGood: return "good";
  }
  return "?";
}

double FitResult::MisfitP() const {
  if (sigma.empty() || dof <= 0 || !std::isfinite(chi2) || quality == FitQuality::kNotFitted ||
      quality == FitQuality::kFailed)
    return kNaN;
  return gsl_cdf_chisq_Q(chi2, dof);
}

std::string FitResult::Rating() const {
  const double p = MisfitP();
  return quality == FitQuality::kGood && p < kMisfitP ? "poor" : ToString(quality);
}

std::string FitResult::Verdict() const {
  switch (quality) {
    case FitQuality::kNotFitted: return status;
    case FitQuality::kFailed:
      return "failed: " + status + " (" + convergence + ", " + std::to_string(iterations) + " it.)";
    case FitQuality::kIllDetermined:
    case FitQuality::kGood: break;
  }
  std::string undetermined, spans;
  for (const FitParameter& p : parameters) {
    if (!p.Determined())
      undetermined += (undetermined.empty() ? "" : ", ") + p.name;
    else if (p.CiSpansZero())
      spans += (spans.empty() ? "" : ", ") + p.name;
  }
  std::string v = Rating();
  if (!undetermined.empty()) v += ": " + undetermined + " not determined by the data";
  if (!spans.empty())
    v += std::string(undetermined.empty() ? ": " : "; ") + "95% CI of " + spans + " include" +
         (spans.find(',') == std::string::npos ? "s" : "") + " 0";
  if (dof == 1) v += std::string(v.find(':') == std::string::npos ? ": " : "; ") + "1 degree of freedom";
  if (!status.empty() && status.rfind("covariance", 0) == 0) v += "; " + status;
  // Weighted by the points' errors, a chi2 far above its degrees of freedom says the law misses
  // the points by more than those errors: the parameters' errors are scaled up to cover it, but
  // the verdict must not read "good" (its parameters are determined, the law is not borne out).
  if (const double p = MisfitP(); p < kMisfitP) {
    std::ostringstream text;
    text << std::setprecision(3) << "chi2/dof = " << chi2 / dof << " (p = " << p
         << "): the law misses the points by more than their errors";
    v += std::string(v.find(':') == std::string::npos ? ": " : "; ") + text.str();
  }
  return v;
}

const FitParameter* FitResult::Parameter(const std::string& name) const {
  for (const auto& p : parameters)
    if (p.name == name) return &p;
  return nullptr;
}

namespace {

// The data: n points of `nv` variables each, row-major in `x`.
struct FitData {
  const Expression* expression;
  std::span<const double> x, y, sigma;
  std::size_t nv = 1;
};

double ModelValue(const Expression& e, std::span<const double> vars, const gsl_vector* p) {
  std::vector<double> pars(p->size);
  for (std::size_t i = 0; i < p->size; ++i) pars[i] = gsl_vector_get(p, i);
  return e.Evaluate(vars, pars);
}

// Residual vector. A parameter step into a region where the model is undefined (e.g. a
// negative base under a fractional power) gets a huge residual instead of NaN, so the
// trust-region method rejects the step and shrinks the radius rather than aborting.
int ResidualsF(const gsl_vector* p, void* params, gsl_vector* f) {
  const auto* d = static_cast<const FitData*>(params);
  for (std::size_t i = 0; i < d->y.size(); ++i) {
    double r = d->y[i] - ModelValue(*d->expression, d->x.subspan(i * d->nv, d->nv), p);
    if (!d->sigma.empty()) r /= d->sigma[i];
    if (!std::isfinite(r)) r = 1e150;
    gsl_vector_set(f, i, r);
  }
  return GSL_SUCCESS;
}

struct WorkspaceDeleter {
  void operator()(gsl_multifit_nlinear_workspace* w) const { gsl_multifit_nlinear_free(w); }
};
struct VectorDeleter {
  void operator()(gsl_vector* v) const { gsl_vector_free(v); }
};
struct MatrixDeleter {
  void operator()(gsl_matrix* m) const { gsl_matrix_free(m); }
};

}  // namespace

double FitResult::Evaluate(double x_value) const {
  const double xv[1] = {x_value};
  return EvaluateAt(xv);
}

double FitResult::EvaluateAt(std::span<const double> values) const {
  if (parameters.empty()) return kNaN;
  try {
    const Expression e =
        Expression::Parse(expression, variables.empty() ? std::vector<std::string>{variable} : variables);
    if (values.size() != e.Variables().size()) return kNaN;
    std::vector<double> pars;
    for (const auto& name : e.Parameters()) {
      const FitParameter* p = Parameter(name);
      pars.push_back(p ? p->value : kNaN);
    }
    return e.Evaluate(values, pars);
  } catch (const ExpressionError&) {
    return kNaN;
  }
}

namespace {

// The fit of `e` to n = y.size() points of nv = e.variables().size() variables (`x`, row-major).
FitResult FitCore(const std::string& name, const Expression& e, std::span<const double> x, std::span<const double> y,
                  std::span<const double> sigma, const std::map<std::string, double>& initial) {
  const std::size_t nv = e.Variables().size();
  FitResult r;
  r.model_name = name;
  r.expression = e.Text();
  if (x.size() != y.size() * nv || (!sigma.empty() && sigma.size() != y.size()))
    throw std::invalid_argument("fit '" + name + "': x, y and sigma sizes differ (" +
                                std::to_string(x.size() / std::max<std::size_t>(1, nv)) + ", " +
                                std::to_string(y.size()) + ", " + std::to_string(sigma.size()) + ")");
  for (std::size_t i = 0; i < y.size(); ++i) r.x.push_back(x[i * nv]);
  r.y.assign(y.begin(), y.end());
  bool weighted = !sigma.empty();
  for (double s : sigma)
    if (!(s > 0.0) || !std::isfinite(s)) weighted = false;
  if (weighted) r.sigma.assign(sigma.begin(), sigma.end());

  const std::size_t n = y.size();
  const std::size_t p = e.Parameters().size();
  for (const auto& par : e.Parameters()) {
    FitParameter fp;
    fp.name = par;
    auto it = initial.find(par);
    fp.initial = it == initial.end() ? 1.0 : it->second;
    r.parameters.push_back(fp);
  }
  r.fitted.assign(n, kNaN);
  r.residuals.assign(n, kNaN);
  if (p == 0 || n <= p) {
    r.status = "not fitted: " + std::to_string(n) + (n == 1 ? " point" : " points") + " for " + std::to_string(p) +
               (p == 1 ? " parameter" : " parameters") + " (needs at least " + std::to_string(p + 1) + ")";
    return r;
  }

  FitData data{&e, x, y, weighted ? std::span<const double>(r.sigma) : std::span<const double>(), nv};
  gsl_multifit_nlinear_fdf fdf;
  fdf.f = ResidualsF;
  fdf.df = nullptr;  // finite-difference Jacobian
  fdf.fvv = nullptr;
  fdf.n = n;
  fdf.p = p;
  fdf.params = &data;

  gsl_multifit_nlinear_parameters fit_params = gsl_multifit_nlinear_default_parameters();
  std::unique_ptr<gsl_multifit_nlinear_workspace, WorkspaceDeleter> w(
      gsl_multifit_nlinear_alloc(gsl_multifit_nlinear_trust, &fit_params, n, p));
  std::unique_ptr<gsl_vector, VectorDeleter> p0(gsl_vector_alloc(p));
  for (std::size_t i = 0; i < p; ++i) gsl_vector_set(p0.get(), i, r.parameters[i].initial);

  // GSL's default handler aborts the program; errors must come back as status codes.
  gsl_error_handler_t* old_handler = gsl_set_error_handler_off();
  int status = gsl_multifit_nlinear_init(p0.get(), &fdf, w.get());
  int info = 0;
  if (status == GSL_SUCCESS) {
    constexpr double kTol = 1e-10;
    constexpr std::size_t kMaxIter = 500;
    status = gsl_multifit_nlinear_driver(kMaxIter, kTol, kTol, kTol, nullptr, nullptr, &info, w.get());
  }
  r.gsl_status = status;
  r.status = gsl_strerror(status);
  r.convergence = info == 1 ? "small step" : info == 2 ? "small gradient" : "not converged";
  r.iterations = static_cast<int>(gsl_multifit_nlinear_niter(w.get()));

  const gsl_vector* best = gsl_multifit_nlinear_position(w.get());
  const gsl_vector* fvec = gsl_multifit_nlinear_residual(w.get());
  double chi2 = 0.0;
  gsl_blas_ddot(fvec, fvec, &chi2);
  r.chi2 = chi2;
  r.dof = static_cast<int>(n - p);

  std::unique_ptr<gsl_matrix, MatrixDeleter> covar(gsl_matrix_alloc(p, p));
  // epsrel > 0: a parameter the data do not determine (a Jacobian column ~ 0, e.g. Mankoc's b
  // when exp(-b (x - 1)) vanishes at every x) gets a zero row instead of a meaningless number.
  constexpr double kCovarEpsRel = 1e-10;
  const int cov_status = gsl_multifit_nlinear_covar(gsl_multifit_nlinear_jac(w.get()), kCovarEpsRel, covar.get());
  gsl_set_error_handler(old_handler);
  if (r.gsl_status != GSL_SUCCESS) {
    // The solver's last step is not an estimate: values stay NaN.
    r.quality = FitQuality::kFailed;
    return r;
  }
  // Without a covariance the estimates stand, but none of them has an error.
  if (cov_status != GSL_SUCCESS) r.status = std::string("covariance: ") + gsl_strerror(cov_status);
  const double reduced = chi2 / r.dof;
  const double scale = weighted ? std::max(1.0, reduced) : reduced;
  const double t = gsl_cdf_tdist_Pinv(0.975, static_cast<double>(r.dof));
  for (std::size_t i = 0; i < p; ++i) {
    auto& fp = r.parameters[i];
    fp.value = gsl_vector_get(best, i);
    const double variance = cov_status == GSL_SUCCESS ? gsl_matrix_get(covar.get(), i, i) : kNaN;
    if (!(variance > 0.0) || !std::isfinite(variance)) {
      r.warning += (r.warning.empty() ? "" : "; ") + fp.name + " not determined by the data";
      continue;  // se and the interval stay NaN
    }
    fp.se = std::sqrt(variance * scale);
    fp.ci_low = fp.value - t * fp.se;
    fp.ci_high = fp.value + t * fp.se;
  }
  for (std::size_t i = 0; i < n; ++i) {
    r.fitted[i] = ModelValue(e, x.subspan(i * nv, nv), best);
    r.residuals[i] = y[i] - r.fitted[i];
  }
  const bool all_good = std::all_of(r.parameters.begin(), r.parameters.end(),
                                    [](const FitParameter& q) { return q.Determined() && !q.CiSpansZero(); });
  r.quality = all_good ? FitQuality::kGood : FitQuality::kIllDetermined;
  return r;
}

}  // namespace

FitResult MakeFitModel(const FitModel& model, std::span<const double> x, std::span<const double> y,
                       std::span<const double> sigma) {
  const Expression e = Expression::Parse(model.expression, {model.variable});
  FitResult r = FitCore(model.name, e, x, y, sigma, model.initial);
  r.model_title = model.Shown();
  r.variable = model.variable;
  return r;
}

FitResult FitModelMulti(const std::string& name, const std::string& expression,
                        const std::vector<std::string>& variables, const std::vector<std::vector<double>>& points,
                        std::span<const double> y, std::span<const double> sigma,
                        const std::map<std::string, double>& initial) {
  const Expression e = Expression::Parse(expression, variables);
  std::vector<double> flat;
  for (const auto& pt : points) {
    if (pt.size() != variables.size())
      throw std::invalid_argument("fit '" + name + "': a data point has " + std::to_string(pt.size()) + " values for " +
                                  std::to_string(variables.size()) + " variables");
    flat.insert(flat.end(), pt.begin(), pt.end());
  }
  if (points.size() != y.size())
    throw std::invalid_argument("fit '" + name + "': " + std::to_string(points.size()) + " points for " +
                                std::to_string(y.size()) + " values");
  FitResult r = FitCore(name, e, flat, y, sigma, initial);
  r.model_title = name;
  r.variable = variables.empty() ? std::string() : variables.front();
  r.variables = variables;
  r.points = points;
  return r;
}

}  // namespace granary::analysis
