// Recursive-descent parser and tree evaluator for expression.h.
#include "analysis/expression.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>

namespace granary::analysis {
namespace {

struct FunctionInfo {
  const char* name;
  int arity;
};
// Index into this table is Node::index for Op::kFunction.
constexpr FunctionInfo kFunctions[] = {{"exp", 1}, {"log", 1}, {"sqrt", 1}, {"abs", 1},
                                       {"pow", 2}, {"min", 2}, {"max", 2}};

}  // namespace

class ExpressionParser {
 public:
  ExpressionParser(Expression& e, const std::string& text) : e_(e), s_(text) {}

  std::size_t ParseAll() {
    const std::size_t root = ParseSum();
    SkipSpace();
    if (pos_ < s_.size()) Fail(std::string("unexpected '") + s_[pos_] + "'");
    return root;
  }

 private:
  using Op = Expression::Op;

  [[noreturn]] void Fail(const std::string& what) const {
    throw ExpressionError("model '" + s_ + "': position " + std::to_string(pos_ + 1) + ": " + what);
  }
  void SkipSpace() {
    while (pos_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[pos_]))) ++pos_;
  }
  bool Accept(char c) {
    SkipSpace();
    if (pos_ < s_.size() && s_[pos_] == c) {
      ++pos_;
      return true;
    }
    return false;
  }
  std::size_t Add(Expression::Node n) {
    e_.nodes_.push_back(std::move(n));
    return e_.nodes_.size() - 1;
  }
  std::size_t Binary(Op op, std::size_t a, std::size_t b) {
    Expression::Node n;
    n.op = op;
    n.args = {a, b};
    return Add(std::move(n));
  }

  std::size_t ParseSum() {
    std::size_t left = ParseProduct();
    for (;;) {
      if (Accept('+')) {
        left = Binary(Op::kAdd, left, ParseProduct());
      } else if (Accept('-')) {
        left = Binary(Op::kSub, left, ParseProduct());
      } else {
        return left;
      }
    }
  }
  std::size_t ParseProduct() {
    std::size_t left = ParseUnary();
    for (;;) {
      if (Accept('*')) {
        left = Binary(Op::kMul, left, ParseUnary());
      } else if (Accept('/')) {
        left = Binary(Op::kDiv, left, ParseUnary());
      } else {
        return left;
      }
    }
  }
  std::size_t ParseUnary() {
    if (Accept('-')) {
      Expression::Node n;
      n.op = Op::kNeg;
      n.args = {ParseUnary()};
      return Add(std::move(n));
    }
    if (Accept('+')) return ParseUnary();
    return ParsePower();
  }
  std::size_t ParsePower() {
    const std::size_t base = ParsePrimary();
    if (Accept('^')) return Binary(Op::kPow, base, ParseUnary());
    return base;
  }
  std::size_t ParsePrimary() {
    SkipSpace();
    if (pos_ >= s_.size()) Fail("expected a number, name or '(' but the text ended");
    const char c = s_[pos_];
    if (c == '(') {
      ++pos_;
      const std::size_t inner = ParseSum();
      if (!Accept(')')) Fail("expected ')'");
      return inner;
    }
    if (std::isdigit(static_cast<unsigned char>(c)) || c == '.') return ParseNumber();
    if (std::isalpha(static_cast<unsigned char>(c)) || c == '_') return ParseName();
    Fail(std::string("expected a number, name or '(' but found '") + c + "'");
  }
  std::size_t ParseNumber() {
    const char* begin = s_.c_str() + pos_;
    char* end = nullptr;
    const double v = std::strtod(begin, &end);
    if (end == begin) Fail("malformed number");
    pos_ += static_cast<std::size_t>(end - begin);
    Expression::Node n;
    n.op = Op::kNumber;
    n.value = v;
    return Add(std::move(n));
  }
  std::size_t ParseName() {
    const std::size_t start = pos_;
    while (pos_ < s_.size() && (std::isalnum(static_cast<unsigned char>(s_[pos_])) || s_[pos_] == '_')) ++pos_;
    const std::string name = s_.substr(start, pos_ - start);
    SkipSpace();
    if (pos_ < s_.size() && s_[pos_] == '(') {
      const std::size_t name_pos = start;
      ++pos_;
      std::size_t f = 0;
      while (f < std::size(kFunctions) && name != kFunctions[f].name) ++f;
      if (f == std::size(kFunctions)) {
        pos_ = name_pos;
        Fail("unknown function '" + name + "' (known: exp, log, sqrt, abs, pow, min, max)");
      }
      Expression::Node n;
      n.op = Op::kFunction;
      n.index = f;
      if (!Accept(')')) {
        do {
          n.args.push_back(ParseSum());
        } while (Accept(','));
        if (!Accept(')')) Fail("expected ',' or ')' in the arguments of " + name + "()");
      }
      if (static_cast<int>(n.args.size()) != kFunctions[f].arity)
        Fail(name + "() takes " + std::to_string(kFunctions[f].arity) + " argument(s), got " +
             std::to_string(n.args.size()));
      return Add(std::move(n));
    }
    Expression::Node n;
    const auto& vars = e_.variables_;
    if (auto it = std::find(vars.begin(), vars.end(), name); it != vars.end()) {
      n.op = Op::kVariable;
      n.index = static_cast<std::size_t>(it - vars.begin());
    } else {
      auto& pars = e_.parameters_;
      auto pt = std::find(pars.begin(), pars.end(), name);
      if (pt == pars.end()) {
        pars.push_back(name);
        pt = pars.end() - 1;
      }
      n.op = Op::kParameter;
      n.index = static_cast<std::size_t>(pt - pars.begin());
    }
    return Add(std::move(n));
  }

  Expression& e_;
  const std::string& s_;
  std::size_t pos_ = 0;
};

Expression Expression::Parse(const std::string& text, const std::vector<std::string>& variables) {
  Expression e;
  e.text_ = text;
  e.variables_ = variables;
  ExpressionParser parser(e, e.text_);
  e.root_ = parser.ParseAll();
  return e;
}

double Expression::Evaluate(std::span<const double> vars, std::span<const double> pars) const {
  if (vars.size() != variables_.size() || pars.size() != parameters_.size())
    throw ExpressionError("model '" + text_ + "': evaluated with " + std::to_string(vars.size()) + " variable(s) and " +
                          std::to_string(pars.size()) + " parameter(s), expected " + std::to_string(variables_.size()) +
                          " and " + std::to_string(parameters_.size()));
  return EvalNode(root_, vars, pars);
}

double Expression::EvalNode(std::size_t i, std::span<const double> vars, std::span<const double> pars) const {
  const Node& n = nodes_[i];
  auto arg = [&](std::size_t k) { return EvalNode(n.args[k], vars, pars); };
  switch (n.op) {
    case Op::kNumber: return n.value;
    case Op::kVariable: return vars[n.index];
    case Op::kParameter: return pars[n.index];
    case Op::kAdd: return arg(0) + arg(1);
    case Op::kSub: return arg(0) - arg(1);
    case Op::kMul: return arg(0) * arg(1);
    case Op::kDiv: return arg(0) / arg(1);
    case Op::kPow: return std::pow(arg(0), arg(1));
    case Op::kNeg: return -arg(0);
    case Op::kFunction:
      switch (n.index) {
        case 0: return std::exp(arg(0));
        case 1: return std::log(arg(0));
        case 2: return std::sqrt(arg(0));
        case 3: return std::abs(arg(0));
        case 4: return std::pow(arg(0), arg(1));
        case 5: return std::min(arg(0), arg(1));
        case 6: return std::max(arg(0), arg(1));
        default: break;
      }
      break;
  }
  return std::nan("");
}

}  // namespace granary::analysis
