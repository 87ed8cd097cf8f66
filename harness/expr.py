"""A small, sandboxed expression language for scene fields, forces and sweeps.

Scene files give fields such as ``v0 = "1e-3*sin(2*pi*x/L)"`` or
``f = "1e-2*sum(cos(10*l*t/T - l**3) for l in (1, 3, 10))"``; ``sphrom cosim
--force`` and the ``shape``/``profile`` grids of ``sphrom sweep`` take the same
language.  The text is parsed with :mod:`ast` and compiled into a tree of
closures over numpy functions; nothing is ever passed to ``eval``.

The language
------------
* numbers, the variables a field allows (``x``, ``t``, ``L``, ``T``; ``A``,
  ``F`` in sweep shapes) and the constants ``pi`` and ``e``;
* ``+ - * / ** %``, unary ``-``/``+``, comparisons (chains allowed; a
  comparison is 1.0 where true and 0.0 where false), ``and``/``or``/``not``,
  ``a if cond else b`` (a condition is true where it is non-zero);
* calls of the functions of :data:`FUNCTIONS`, each with exactly its
  arguments, positional only::

      sin cos tan arcsin arccos arctan sinh cosh tanh exp log log10 sqrt
      abs sign floor ceil                                  f(a)
      arctan2(y, x)  minimum(a, b)  maximum(a, b)  mod(a, b)  heaviside(a, h0)
      where(cond, a, b)
      piecewise(c1, v1, c2, v2, ..., default)              first true condition wins

* ``sum(<expr> for l in range(a[, b[, s]]))`` or ``... for l in (1, 3, 10)``
  with integer literal bounds; sums may nest.

The sandbox
-----------
Everything else is refused when the expression is compiled, as a
:class:`~sphrom.errors.UserError` of one line naming the field: strings,
attributes, subscripts, lambdas, comprehensions other than ``sum``'s, keyword
arguments (``out=``, ``where=``, ``dtype=`` ...), starred arguments, a
function called with other than its number of arguments, unknown names.
Limits (all checked before anything is evaluated):

* :data:`MAX_LENGTH` = 4000 characters, checked before parsing; input that the
  parser itself cannot nest (RecursionError, MemoryError) is refused too;
* :data:`MAX_DEPTH` = 100 levels of nested sub-expressions (``x+x+...+x`` of
  n terms is n levels deep), checked without recursion before compiling;
* integer literals within ``|n| <= 2**53`` (the integers a float64 holds
  exactly); number literals finite;
* a sum has 1 to :data:`MAX_TERMS` = 1000 terms (``range`` takes 1 to 3
  integer literals, its step is not 0, it is not empty);
* :data:`MAX_OPERATIONS` = 100 000 array operations per evaluation, counted
  statically with the terms of nested sums multiplied out (every range is a
  literal, so the count is exact): ``sum(sum(sum(... for k in range(1000))
  for l in range(1000)) for m in range(1000))`` is refused at once.

Evaluation never touches the caller's arrays: the values passed in are
copied first (arrays to new float64 arrays, scalars to Python floats), every
function allocates its result, and the result is a fresh float64 array.  Every number is a float, so ``10**10**10``
gives ``inf`` instead of a huge integer; division by zero and overflow give
inf or NaN, which the caller reports as a non-finite field with its name
(:meth:`sphrom.scene.Scene.field`, :meth:`~sphrom.scene.Scene.force`, the
cosim force, the sweep entry's force).
"""

from __future__ import annotations

import ast
import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from .errors import UserError

MAX_LENGTH = 4000            # characters
MAX_DEPTH = 100              # levels of nested sub-expressions
MAX_INT = 2**53              # largest |integer literal|
MAX_TERMS = 1000             # terms of one sum
MAX_OPERATIONS = 100_000     # array operations of one evaluation, nested sums multiplied out


@dataclass(frozen=True)
class Function:
    """A whitelisted function: exactly ``arity`` positional arguments.

    ``arity`` None means ``piecewise``'s odd count >= 3.  Calling it with any
    other arguments (an extra one numpy would take as ``out``, a keyword)
    raises TypeError; the result is always a new array.
    """

    name: str
    signature: str
    arity: int | None
    fn: Callable = field(repr=False, compare=False)

    def accepts(self, count):
        if self.arity is None:
            return count >= 3 and count % 2 == 1
        return count == self.arity

    def describe(self):
        if self.arity is None:
            return f"{self.name}() takes an odd number >= 3 of arguments: {self.signature}"
        return f"{self.name}() takes {self.arity} argument{'s' if self.arity != 1 else ''}: {self.signature}"

    def __call__(self, *args):
        if not self.accepts(len(args)):
            raise TypeError(f"{self.describe()}, got {len(args)}")
        return self.fn(*args)


def _piecewise(*args):
    """``piecewise(c1, v1, c2, v2, ..., default)``: first true condition wins."""
    result = np.array(args[-1], dtype=float)
    for cond, value in reversed(list(zip(args[:-1:2], args[1:-1:2]))):
        result = np.where(cond, value, result)
    return result


def _ufunc(ufunc):
    """``ufunc`` called with exactly its inputs: numpy then allocates the output."""
    n = ufunc.nin
    if n == 1:
        return lambda a: ufunc(a)
    return lambda a, b: ufunc(a, b)


def _table():
    unary = ["sin", "cos", "tan", "arcsin", "arccos", "arctan", "sinh", "cosh", "tanh",
             "exp", "log", "log10", "sqrt", "abs", "sign", "floor", "ceil"]
    binary = {"arctan2": "arctan2(y, x)", "minimum": "minimum(a, b)", "maximum": "maximum(a, b)",
              "mod": "mod(a, b)", "heaviside": "heaviside(a, h0)"}
    table = {name: Function(name, f"{name}(a)", 1, _ufunc(getattr(np, name))) for name in unary}
    table.update({name: Function(name, sig, 2, _ufunc(getattr(np, name))) for name, sig in binary.items()})
    table["where"] = Function("where", "where(cond, a, b)", 3, lambda c, a, b: np.where(c, a, b))
    table["piecewise"] = Function("piecewise", "piecewise(c1, v1, c2, v2, ..., default)", None, _piecewise)
    return table


FUNCTIONS: dict[str, Function] = _table()
CONSTANTS = {"pi": float(np.pi), "e": float(np.e)}

_BINOPS = {
    ast.Add: np.add, ast.Sub: np.subtract, ast.Mult: np.multiply,
    ast.Div: np.divide, ast.Pow: np.power, ast.Mod: np.mod,
}
_CMPOPS = {
    ast.Lt: np.less, ast.LtE: np.less_equal, ast.Gt: np.greater,
    ast.GtE: np.greater_equal, ast.Eq: np.equal, ast.NotEq: np.not_equal,
}


def shown(text):
    """The expression for a one-line message: repr, shortened."""
    text = str(text).strip()
    if len(text) > 60:
        text = f"{text[:40]}...{text[-15:]}"
    return repr(text)


def _truth(value):
    """A condition as a float: 1.0 where true, 0.0 where false."""
    return np.asarray(value, dtype=np.float64)


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
    where : str
        Where it comes from, for error messages (e.g. ``"scene.toml: fields.v0"``).
    """

    text: str
    names: frozenset
    _fn: Callable = field(repr=False, compare=False)
    where: str = "expression"

    def __call__(self, **values) -> np.ndarray:
        """Evaluate on copies of ``values`` (float64); returns a new float64 array."""
        # arrays are copied, scalars become Python floats (immutable, and the fast path of numpy)
        env = {name: float(value) if np.ndim(value) == 0 else np.array(value, dtype=np.float64)
               for name, value in values.items()}
        try:
            with np.errstate(all="ignore"):
                return np.array(self._fn(env), dtype=np.float64)
        except (TypeError, ValueError, ArithmeticError) as exc:
            reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise UserError(f"{self.where}: cannot evaluate {shown(self.text)} ({reason})") from None

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
        ``"scene.toml: fields.v0"``.

    Raises
    ------
    UserError
        One line naming ``where``: a syntax error, a name or function that is
        not allowed, a function called with the wrong arguments, a construct
        outside the language, or a limit exceeded (see the module docstring).
    """
    if isinstance(text, bool) or not isinstance(text, (str, int, float)):
        raise UserError(f"{where}: expected an expression string or a number, got {type(text).__name__}")
    if isinstance(text, int) and abs(text) > MAX_INT:
        raise UserError(f"{where}: integer of {text.bit_length()} bits is out of range "
                        f"(allowed: |n| <= 2**53 = {MAX_INT})")
    text = str(text)
    if len(text) > MAX_LENGTH:
        raise UserError(f"{where}: expression of {len(text)} characters is too long "
                        f"(allowed: at most {MAX_LENGTH})")
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as exc:
        raise UserError(f"{where}: syntax error ({exc.msg}) in {shown(text)} at column {exc.offset}") from None
    except (RecursionError, MemoryError):
        raise UserError(f"{where}: expression nested too deeply to parse "
                        f"(allowed: at most {MAX_DEPTH} levels)") from None
    except ValueError as exc:           # e.g. a NUL character
        raise UserError(f"{where}: {exc} in {shown(text)}") from None
    depth = _depth(tree.body)
    if depth > MAX_DEPTH:
        raise UserError(f"{where}: expression nested more than {MAX_DEPTH} levels deep in {shown(text)} "
                        f"(allowed: at most {MAX_DEPTH}; use sum(... for l in range(...)) for long sums)")
    used: set = set()
    fn = _Compiler(frozenset(allowed), where, text, used).visit(tree.body, frozenset())
    return Expr(text=text, names=frozenset(used), _fn=fn, where=where)


def _depth(node):
    """Nesting depth of sub-expressions, without recursion (stops once past MAX_DEPTH)."""
    deepest, stack = 0, [(node, 1)]
    while stack:
        node, depth = stack.pop()
        if depth > deepest:
            deepest = depth
            if deepest > MAX_DEPTH:
                break
        stack.extend((child, depth + 1) for child in ast.iter_child_nodes(node)
                     if isinstance(child, (ast.expr, ast.comprehension)))
    return deepest


class _Compiler:
    """AST -> closure tree, counting the operations of one evaluation as it goes."""

    def __init__(self, allowed, where, text, used):
        self.allowed = allowed
        self.where = where
        self.text = text
        self.used = used
        self.operations = 0      # array operations of one evaluation so far
        self.repeat = 1          # how often the node being compiled is evaluated (nested sums)

    def fail(self, what, hint=False):
        message = f"{self.where}: {what} in {shown(self.text)}"
        if hint:
            allowed = ", ".join(sorted(self.allowed | set(CONSTANTS)))
            message += (f" (allowed names: {allowed}; functions: {', '.join(sorted(FUNCTIONS))}, "
                        "sum(... for l in range(a, b)))")
        raise UserError(message)

    def count(self, n):
        self.operations += n
        if self.operations > MAX_OPERATIONS:
            self.fail(f"evaluation needs more than {MAX_OPERATIONS} operations (the terms of nested sums "
                      f"multiply; allowed: at most {MAX_OPERATIONS})")

    def visit(self, node, local):
        self.count(self.repeat)
        method = getattr(self, "visit_" + type(node).__name__, None)
        if method is None:
            self.fail(f"'{type(node).__name__}' is not allowed", hint=True)
        return method(node, local)

    def visit_Constant(self, node, local):
        value = node.value
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.fail(f"constant {shown(repr(value))} is not a number")
        if isinstance(value, int) and abs(value) > MAX_INT:
            self.fail(f"integer literal of {value.bit_length()} bits is out of range "
                      f"(allowed: |n| <= 2**53 = {MAX_INT})")
        value = float(value)
        if not math.isfinite(value):
            self.fail("number literal overflows to inf (allowed: a finite number, |x| < 1.8e308)")
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
        self.fail(f"name '{name}' is not allowed", hint=True)

    def visit_BinOp(self, node, local):
        op = _BINOPS.get(type(node.op))
        if op is None:
            self.fail(f"operator '{type(node.op).__name__}' is not allowed (allowed: + - * / ** %)")
        a, b = self.visit(node.left, local), self.visit(node.right, local)
        return lambda env: op(a(env), b(env))

    def visit_UnaryOp(self, node, local):
        if not isinstance(node.op, (ast.USub, ast.UAdd, ast.Not)):
            self.fail(f"operator '{type(node.op).__name__}' is not allowed (allowed: unary -, +, not)")
        a = self.visit(node.operand, local)
        if isinstance(node.op, ast.USub):
            return lambda env: np.negative(a(env))
        if isinstance(node.op, ast.UAdd):
            return a
        return lambda env: _truth(np.logical_not(a(env)))

    def visit_Compare(self, node, local):
        ops = [_CMPOPS.get(type(o)) for o in node.ops]
        if None in ops:
            self.fail("comparison operator is not allowed (allowed: < <= > >= == !=)")
        terms = [self.visit(node.left, local)] + [self.visit(c, local) for c in node.comparators]

        def compare(env):
            values = [t(env) for t in terms]
            result = ops[0](values[0], values[1])
            for op, a, b in zip(ops[1:], values[1:], values[2:]):
                result = np.logical_and(result, op(a, b))
            return _truth(result)
        return compare

    def visit_BoolOp(self, node, local):
        fn = np.logical_and if isinstance(node.op, ast.And) else np.logical_or
        terms = [self.visit(v, local) for v in node.values]

        def boolop(env):
            result = terms[0](env)
            for t in terms[1:]:
                result = fn(result, t(env))
            return _truth(result)
        return boolop

    def visit_IfExp(self, node, local):
        cond, a, b = (self.visit(n, local) for n in (node.test, node.body, node.orelse))
        return lambda env: np.where(cond(env), a(env), b(env))

    def visit_Call(self, node, local):
        if not isinstance(node.func, ast.Name):
            self.fail("only plain function calls are allowed")
        name = node.func.id
        if name == "sum":
            return self._sum(node, local)
        fn = FUNCTIONS.get(name)
        if fn is None:
            if name == "range":
                self.fail("range(...) is allowed only in sum(... for l in range(...))")
            self.fail(f"function '{name}' is not allowed", hint=True)
        if node.keywords:
            self.fail(f"keyword arguments to '{name}' are not allowed ({fn.describe()})")
        if any(isinstance(a, ast.Starred) for a in node.args):
            self.fail(f"starred arguments to '{name}' are not allowed ({fn.describe()})")
        if not fn.accepts(len(node.args)):
            self.fail(f"{fn.describe()}, got {len(node.args)}")
        args = [self.visit(a, local) for a in node.args]
        return lambda env: fn(*[a(env) for a in args])

    def _sum(self, node, local):
        if node.keywords or len(node.args) != 1 or not isinstance(node.args[0], ast.GeneratorExp):
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
        outer = self.repeat
        self.repeat = outer * len(values)
        self.count(self.repeat)              # the additions
        body = self.visit(gen.elt, local | {var})
        self.repeat = outer

        def total(env):
            acc = 0.0
            for value in values:
                acc = acc + body({**env, var: value})
            return acc
        return total

    def _int_const(self, node):
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
            value = self._int_const(node.operand)
            return -value if isinstance(node.op, ast.USub) else value
        if isinstance(node, ast.Constant) and isinstance(node.value, int) and not isinstance(node.value, bool):
            if abs(node.value) > MAX_INT:
                self.fail(f"integer literal of {node.value.bit_length()} bits is out of range "
                          f"(allowed: |n| <= 2**53 = {MAX_INT})")
            return node.value
        self.fail("range bounds and loop values must be integer literals")

    def _iteration_values(self, node):
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "range":
            if not 1 <= len(node.args) <= 3 or node.keywords:
                self.fail(f"range takes 1 to 3 integer arguments, got {len(node.args) + len(node.keywords)}")
            bounds = [self._int_const(a) for a in node.args]
            if len(bounds) == 3 and bounds[2] == 0:
                self.fail("range step is 0 (allowed: a non-zero integer)")
            values = range(*bounds)
        elif isinstance(node, (ast.Tuple, ast.List)):
            values = [self._int_const(a) for a in node.elts]
        else:
            self.fail("sum iterates over range(...) or a tuple of integers only")
        if len(values) > MAX_TERMS:
            self.fail(f"sum has {len(values)} terms (allowed: 1 to {MAX_TERMS})")
        if len(values) == 0:
            self.fail(f"sum has no terms (allowed: 1 to {MAX_TERMS}; range(a, b) counts from a up to b - 1)")
        return [float(v) for v in values]
