"""The expressions of a campaign spec's derived axes (`/axes`, docs/campaign-spec.md): numbers,
names, + - * / ^ (right-associative, binding tighter than unary minus: -x^2 = -(x^2)),
parentheses and exp, log, sqrt, abs, pow, min, max. The grammar and the arithmetic of
analysis::Expression (src/analysis/expression.cpp), so that a derived axis has here the value
the export gives it: IEEE doubles throughout (log(-1) is NaN, 1/0 is inf, never an exception)."""

import re

import numpy as np

_FUNCTIONS = {"exp": (1, np.exp), "log": (1, np.log), "sqrt": (1, np.sqrt), "abs": (1, np.abs),
              "pow": (2, np.power), "min": (2, lambda a, b: b if b < a else a),
              "max": (2, lambda a, b: b if a < b else a)}
_NUMBER = re.compile(r"(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?")
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


class ExpressionError(ValueError):
    """"model 'C*(x-k': position 8: expected ')'": the text and where it went wrong."""


class Expression:
    """A parsed expression; `names` the names it uses, in order; `evaluate({name: value})`."""

    def __init__(self, text):
        self.text = text
        self._pos = 0
        self.names = []
        self._tree = self._sum()
        self._space()
        if self._pos < len(text):
            self._fail(f"unexpected '{text[self._pos]}'")

    def evaluate(self, values):
        with np.errstate(all="ignore"):
            return float(self._eval(self._tree, values))

    def _eval(self, node, values):
        op = node[0]
        if op == "num":
            return node[1]
        if op == "name":
            return np.float64(values.get(node[1], np.nan))
        if op == "neg":
            return -self._eval(node[1], values)
        if op == "fn":
            return _FUNCTIONS[node[1]][1](*[self._eval(a, values) for a in node[2]])
        a, b = self._eval(node[1], values), self._eval(node[2], values)
        if op == "+":
            return a + b
        if op == "-":
            return a - b
        if op == "*":
            return a * b
        if op == "/":
            return np.divide(a, b)
        return np.power(a, b)

    def _fail(self, what):
        raise ExpressionError(f"model '{self.text}': position {self._pos + 1}: {what}")

    def _space(self):
        while self._pos < len(self.text) and self.text[self._pos].isspace():
            self._pos += 1

    def _accept(self, c):
        self._space()
        if self._pos < len(self.text) and self.text[self._pos] == c:
            self._pos += 1
            return True
        return False

    def _sum(self):
        left = self._product()
        while True:
            if self._accept("+"):
                left = ("+", left, self._product())
            elif self._accept("-"):
                left = ("-", left, self._product())
            else:
                return left

    def _product(self):
        left = self._unary()
        while True:
            if self._accept("*"):
                left = ("*", left, self._unary())
            elif self._accept("/"):
                left = ("/", left, self._unary())
            else:
                return left

    def _unary(self):
        if self._accept("-"):
            return ("neg", self._unary())
        if self._accept("+"):
            return self._unary()
        base = self._primary()
        if self._accept("^"):
            return ("^", base, self._unary())
        return base

    def _primary(self):
        self._space()
        if self._pos >= len(self.text):
            self._fail("expected a number, name or '(' but the text ended")
        c = self.text[self._pos]
        if c == "(":
            self._pos += 1
            inner = self._sum()
            if not self._accept(")"):
                self._fail("expected ')'")
            return inner
        if c.isdigit() or c == ".":
            m = _NUMBER.match(self.text, self._pos)
            if not m:
                self._fail("malformed number")
            self._pos = m.end()
            return ("num", np.float64(m.group(0)))
        m = _NAME.match(self.text, self._pos)
        if not m:
            self._fail(f"expected a number, name or '(' but found '{c}'")
        start, name = self._pos, m.group(0)
        self._pos = m.end()
        if self._accept("("):
            if name not in _FUNCTIONS:
                self._pos = start
                self._fail(f"unknown function '{name}' (known: exp, log, sqrt, abs, pow, min, max)")
            args = []
            if not self._accept(")"):
                args.append(self._sum())
                while self._accept(","):
                    args.append(self._sum())
                if not self._accept(")"):
                    self._fail(f"expected ',' or ')' in the arguments of {name}()")
            if len(args) != _FUNCTIONS[name][0]:
                self._fail(f"{name}() takes {_FUNCTIONS[name][0]} argument(s), got {len(args)}")
            return ("fn", name, args)
        if name not in self.names:
            self.names.append(name)
        return ("name", name)


def derived_axes(block):
    """[(name, Expression)] of a campaign spec's /axes, in order (each over the sweep axes'
    short names and the derived axes before it; plan has checked them)."""
    if not isinstance(block, dict):
        return []
    return [(name, Expression(text)) for name, text in block.items() if isinstance(text, str)]
