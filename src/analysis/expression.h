// A small, safe expression language for user-defined fit models, e.g. the thesis' collapse
// "C * x^b / (1 + X/2)" or Beverloo "C * (x - k)^1.5". Grammar: numbers, names, + - * / ^
// (right-associative, binds tighter than unary minus: -x^2 = -(x^2)), parentheses and the
// functions exp, log, sqrt, abs, pow(a, b), min(a, b), max(a, b). Names listed as variables
// are data; every other name is a fit parameter. No loops, no assignment, no I/O: parsing
// builds a tree and evaluation walks it.
#pragma once

#include <cstddef>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

namespace granary::analysis {

// "model 'C*(x-k': position 8: expected ')'" — names the text and where it went wrong.
class ExpressionError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class Expression {
 public:
  // Throws ExpressionError on a syntax error, an unknown function or a wrong argument count.
  static Expression Parse(const std::string& text, const std::vector<std::string>& variables);

  const std::string& Text() const { return text_; }
  const std::vector<std::string>& Variables() const { return variables_; }
  // Parameter names in order of first appearance.
  const std::vector<std::string>& Parameters() const { return parameters_; }

  // Values in the order of Variables() and Parameters(); sizes are checked.
  double Evaluate(std::span<const double> variables, std::span<const double> parameters) const;

 private:
  enum class Op { kNumber, kVariable, kParameter, kAdd, kSub, kMul, kDiv, kPow, kNeg, kFunction };
  struct Node {
    Op op = Op::kNumber;
    double value = 0.0;
    std::size_t index = 0;  // variable / parameter / function index
    std::vector<std::size_t> args;
  };
  friend class ExpressionParser;

  double EvalNode(std::size_t node, std::span<const double> vars, std::span<const double> pars) const;

  std::string text_;
  std::vector<std::string> variables_;
  std::vector<std::string> parameters_;
  std::vector<Node> nodes_;
  std::size_t root_ = 0;
};

}  // namespace granary::analysis
