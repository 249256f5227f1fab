// Tests of the model expression parser and evaluator.
#include "analysis/expression.h"

#include <gtest/gtest.h>

#include <cmath>

namespace granary::analysis {
namespace {

double Eval(const std::string& text, double x = 0.0, std::vector<double> pars = {}) {
  const Expression e = Expression::Parse(text, {"x"});
  const double v[1] = {x};
  return e.Evaluate(v, pars);
}

TEST(Expression, PrecedenceAndAssociativity) {
  EXPECT_DOUBLE_EQ(Eval("1 + 2 * 3"), 7.0);
  EXPECT_DOUBLE_EQ(Eval("(1 + 2) * 3"), 9.0);
  EXPECT_DOUBLE_EQ(Eval("8 / 4 / 2"), 1.0);
  EXPECT_DOUBLE_EQ(Eval("10 - 4 - 3"), 3.0);
  EXPECT_DOUBLE_EQ(Eval("2 ^ 3 ^ 2"), 512.0);  // right-associative
  EXPECT_DOUBLE_EQ(Eval("-2 ^ 2"), -4.0);      // unary minus binds looser than ^
  EXPECT_DOUBLE_EQ(Eval("2 ^ -1"), 0.5);
  EXPECT_DOUBLE_EQ(Eval("1.5e1 + .5"), 15.5);
}

TEST(Expression, FunctionsAndVariable) {
  EXPECT_NEAR(Eval("exp(log(x))", 3.7), 3.7, 1e-14);
  EXPECT_DOUBLE_EQ(Eval("sqrt(x) + abs(-x)", 4.0), 6.0);
  EXPECT_DOUBLE_EQ(Eval("pow(x, 2) - min(x, 1) + max(x, 10)", 3.0), 9.0 - 1.0 + 10.0);
}

TEST(Expression, ParametersInOrderOfAppearance) {
  const Expression e = Expression::Parse("C * (x - k)^b + C", {"x"});
  ASSERT_EQ(e.Parameters(), (std::vector<std::string>{"C", "k", "b"}));
  const double x[1] = {5.0};
  const std::vector<double> p = {2.0, 1.0, 1.5};
  EXPECT_NEAR(e.Evaluate(x, p), 2.0 * 8.0 + 2.0, 1e-13);
}

TEST(Expression, ThesisCollapseWithTwoVariables) {
  const Expression e = Expression::Parse("a * W^b / (1 + X/2)", {"W", "X"});
  ASSERT_EQ(e.Parameters(), (std::vector<std::string>{"a", "b"}));
  const double v[2] = {20.0, 0.5};
  const std::vector<double> p = {0.3, 1.72};
  EXPECT_NEAR(e.Evaluate(v, p), 0.3 * std::pow(20.0, 1.72) / 1.25, 1e-12);
}

TEST(Expression, ErrorsNameTextAndPosition) {
  try {
    Expression::Parse("C*(x-k", {"x"});
    FAIL() << "no error";
  } catch (const ExpressionError& e) {
    EXPECT_STREQ(e.what(), "model 'C*(x-k': position 7: expected ')'");
  }
  EXPECT_THROW(Expression::Parse("C*x^", {"x"}), ExpressionError);
  EXPECT_THROW(Expression::Parse("2 $ 3", {"x"}), ExpressionError);
  EXPECT_THROW(Expression::Parse("", {"x"}), ExpressionError);
  try {
    Expression::Parse("sin(x)", {"x"});
    FAIL() << "no error";
  } catch (const ExpressionError& e) {
    EXPECT_STREQ(e.what(),
                 "model 'sin(x)': position 1: unknown function 'sin' (known: exp, log, sqrt, abs, pow, min, max)");
  }
  try {
    Expression::Parse("pow(x)", {"x"});
    FAIL() << "no error";
  } catch (const ExpressionError& e) {
    EXPECT_STREQ(e.what(), "model 'pow(x)': position 7: pow() takes 2 argument(s), got 1");
  }
}

TEST(Expression, EvaluateChecksSizes) {
  const Expression e = Expression::Parse("a * x", {"x"});
  const double x[1] = {1.0};
  EXPECT_THROW(e.Evaluate(x, std::vector<double>{}), ExpressionError);
}

}  // namespace
}  // namespace granary::analysis
