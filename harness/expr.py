"""A small, safe expression language for scene fields.

Scene files give fields such as ``v0 = "1e-3*sin(2*pi*x/L)"`` or
``f = "1e-2*sum(cos(10*l*t/T - l**3) for l in (1, 3, 10))"``.  The text is
parsed with :mod:`ast` and compiled into a tree of closures over numpy
functions; nothing is ever passed to ``eval``.  Only these constructs exist:

* numbers, the variables a field allows (``x``, ``t``, ``L``, ``T``) and the
  constants ``pi`` and ``e``;
* ``+ - * / ** %``, unary ``-``/``+``, comparisons (chains allowed),
  ``and``/``or``/``not`` on comparisons, ``a if cond else b``;
* calls of whitelisted numpy functions (:data:`FUNCTIONS`) and
  ``piecewise(cond1, value1, cond2, value2, ..., default)``;
* ``sum(<expr> for l in range(a, b[, s]))`` or ``... for l in (1, 3, 10)``
  with integer bounds, at most :data:`MAX_TERMS` terms.

Every constant is a float, so ``10**10**10`` gives ``inf`` (caught as a
non-finite field by the caller) instead of a huge integer.
"""

from __future__ import annotations

import ast
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from .errors import UserError

MAX_LENGTH = 4000
MAX_TERMS = 1000


def _piecewise(*args):
    """``piecewise(c1, v1, c2, v2, ..., default)``: first true condition wins."""
    if len(args) < 3 or len(args) % 2 == 0:
        raise ValueError("piecewise takes cond, value pairs and a default")
    result = np.asarray(args[-1], dtype=float)
    for cond, value in reversed(list(zip(args[:-1:2], args[1:-1:2]))):
        result = np.where(cond, value, result)
    return result


FUNCTIONS: dict[str, Callable] = {
    "sin": np.sin, "cos": np.cos, "tan": np.tan,
    "arcsin": np.arcsin, "arccos": np.arccos, "arctan": np.arctan, "arctan2": np.arctan2,
    "sinh": np.sinh, "cosh": np.cosh, "tanh": np.tanh,
    "exp": np.exp, "log": np.log, "log10": np.log10, "sqrt": np.sqrt,
    "abs": np.abs, "sign": np.sign, "floor": np.floor, "ceil": np.ceil,
    "minimum": np.minimum, "maximum": np.maximum, "mod": np.mod,
    "heaviside": np.heaviside, "where": np.where, "piecewise": _piecewise,
}
CONSTANTS = {"pi": float(np.pi), "e": float(np.e)}

_BINOPS = {
    ast.Add: np.add, ast.Sub: np.subtract, ast.Mult: np.multiply,
    ast.Div: np.divide, ast.Pow: np.power, ast.Mod: np.mod,
}
_CMPOPS = {
    ast.Lt: np.less, ast.LtE: np.less_equal, ast.Gt: np.greater,
    ast.GtE: np.greater_equal, ast.Eq: np.equal, ast.NotEq: np.not_equal,
}


@dataclass(frozen=True)
class Expr:
    """A compiled field expression.

    Attributes
    ----------
    text : str
        The source text.
    names : frozenset of str
        The free variables it uses (a subset of the allowed ones), e.g.
        ``{"x", "L"}``.  A field whose names lack ``x`` is uniform in space.
    """

    text: str
    names: frozenset
    _fn: Callable = field(repr=False, compare=False)

    def __call__(self, **values) -> np.ndarray:
        with np.errstate(all="ignore"):
            return np.asarray(self._fn(values), dtype=float)

    def depends_on(self, name: str) -> bool:
        return name in self.names


def compile_expr(text, allowed, where="expression") -> Expr:
    """Compile ``text`` into an :class:`Expr`.

    Parameters
    ----------
    text : str or float
        The expression (a bare number is accepted too).
    allowed : iterable of str
        Variable names the expression may use, e.g. ``("x", "L", "T")``.
    where : str
        Where the expression comes from, for error messages, e.g.
        ``"scene.toml: field 'v0'"``.

    Raises
    ------
    UserError
        For a syntax error, a name or function that is not allowed, or a
        construct outside the language.
    """
    if isinstance(text, bool) or not isinstance(text, (str, int, float)):
        raise UserError(f"{where}: expected an expression string or a number, got {type(text).__name__}")
    text = str(text)
    if len(text) > MAX_LENGTH:
        raise UserError(f"{where}: expression longer than {MAX_LENGTH} characters")
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as exc:
        raise UserError(f"{where}: syntax error in {text!r} at column {exc.offset}") from None
    allowed = frozenset(allowed)
    used: set = set()
    fn = _Compiler(allowed, where, text, used).visit(tree.body, frozenset())
    return Expr(text=text, names=frozenset(used), _fn=fn)


class _Compiler:
    def __init__(self, allowed, where, text, used):
        self.allowed = allowed
        self.where = where
        self.text = text
        self.used = used

    def fail(self, what):
        allowed = ", ".join(sorted(self.allowed | set(CONSTANTS)))
        raise UserError(f"{self.where}: {what} in {self.text!r} (allowed names: {allowed}; "
                        f"functions: {', '.join(sorted(FUNCTIONS))}, sum(... for l in range(a, b)))")

    def visit(self, node, local):
        method = getattr(self, "visit_" + type(node).__name__, None)
        if method is None:
            self.fail(f"'{type(node).__name__}' is not allowed")
        return method(node, local)

    def visit_Constant(self, node, local):
        if isinstance(node.value, bool) or not isinstance(node.value, (int, float)):
            self.fail(f"constant {node.value!r} is not a number")
        value = float(node.value)
        return lambda env: value

    def visit_Name(self, node, local):
        name = node.id
        if name in local:
            return lambda env: env[name]
        if name in self.allowed:
            self.used.add(name)
            return lambda env: env[name]
        if name in CONSTANTS:
            value = CONSTANTS[name]
            return lambda env: value
        self.fail(f"name '{name}' is not allowed")

    def visit_BinOp(self, node, local):
        op = _BINOPS.get(type(node.op))
        if op is None:
            self.fail(f"operator '{type(node.op).__name__}' is not allowed")
        a, b = self.visit(node.left, local), self.visit(node.right, local)
        return lambda env: op(a(env), b(env))

    def visit_UnaryOp(self, node, local):
        a = self.visit(node.operand, local)
        if isinstance(node.op, ast.USub):
            return lambda env: np.negative(a(env))
        if isinstance(node.op, ast.UAdd):
            return a
        if isinstance(node.op, ast.Not):
            return lambda env: np.logical_not(a(env))
        self.fail(f"operator '{type(node.op).__name__}' is not allowed")

    def visit_Compare(self, node, local):
        ops = [_CMPOPS.get(type(o)) for o in node.ops]
        if None in ops:
            self.fail("comparison operator is not allowed")
        terms = [self.visit(node.left, local)] + [self.visit(c, local) for c in node.comparators]

        def compare(env):
            values = [t(env) for t in terms]
            result = ops[0](values[0], values[1])
            for op, a, b in zip(ops[1:], values[1:], values[2:]):
                result = np.logical_and(result, op(a, b))
            return result
        return compare

    def visit_BoolOp(self, node, local):
        fn = np.logical_and if isinstance(node.op, ast.And) else np.logical_or
        terms = [self.visit(v, local) for v in node.values]

        def boolop(env):
            result = terms[0](env)
            for t in terms[1:]:
                result = fn(result, t(env))
            return result
        return boolop

    def visit_IfExp(self, node, local):
        cond, a, b = (self.visit(n, local) for n in (node.test, node.body, node.orelse))
        return lambda env: np.where(cond(env), a(env), b(env))

    def visit_Call(self, node, local):
        if not isinstance(node.func, ast.Name):
            self.fail("only plain function calls are allowed")
        name = node.func.id
        if node.keywords:
            self.fail(f"keyword arguments to '{name}' are not allowed")
        if name == "sum":
            return self._sum(node, local)
        fn = FUNCTIONS.get(name)
        if fn is None:
            self.fail(f"function '{name}' is not allowed")
        args = [self.visit(a, local) for a in node.args]

        def call(env):
            try:
                return fn(*[a(env) for a in args])
            except (TypeError, ValueError) as exc:
                raise UserError(f"{self.where}: {name}(...) in {self.text!r}: {exc}") from None
        return call

    def _sum(self, node, local):
        if len(node.args) != 1 or not isinstance(node.args[0], ast.GeneratorExp):
            self.fail("sum takes one generator, e.g. sum(sin(l*x) for l in range(1, 4))")
        gen = node.args[0]
        if len(gen.generators) != 1:
            self.fail("sum allows a single 'for'")
        comp = gen.generators[0]
        if comp.ifs or comp.is_async or not isinstance(comp.target, ast.Name):
            self.fail("sum allows 'for NAME in range(...)' or 'for NAME in (1, 2, ...)' only")
        var = comp.target.id
        if var in self.allowed or var in CONSTANTS or var in FUNCTIONS:
            self.fail(f"loop variable '{var}' shadows a reserved name")
        values = self._iteration_values(comp.iter)
        body = self.visit(gen.elt, local | {var})

        def total(env):
            acc = 0.0
            for value in values:
                acc = acc + body({**env, var: value})
            return acc
        return total

    def _int_const(self, node):
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub):
            return -self._int_const(node.operand)
        if isinstance(node, ast.Constant) and isinstance(node.value, int) and not isinstance(node.value, bool):
            return node.value
        self.fail("range bounds and loop values must be integer literals")

    def _iteration_values(self, node):
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "range":
            if not 1 <= len(node.args) <= 3 or node.keywords:
                self.fail("range takes 1 to 3 integer arguments")
            values = range(*[self._int_const(a) for a in node.args])
        elif isinstance(node, (ast.Tuple, ast.List)):
            values = [self._int_const(a) for a in node.elts]
        else:
            self.fail("sum iterates over range(...) or a tuple of integers only")
        if len(values) > MAX_TERMS:
            self.fail(f"sum has {len(values)} terms (at most {MAX_TERMS})")
        return [float(v) for v in values]
