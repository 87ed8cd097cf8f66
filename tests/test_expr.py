"""The whitelisted expression evaluator: what it computes, what it refuses, its limits, and the same
guarantees in every place that takes an expression (scene fields, cosim --force, sweep shape/profile)."""

import hashlib
import json
import re
import time
from pathlib import Path

import numpy as np
import pytest

from sphrom.errors import UserError
from sphrom.cli import main
from sphrom.expr import FUNCTIONS, MAX_DEPTH, MAX_INT, MAX_LENGTH, MAX_OPERATIONS, MAX_TERMS, compile_expr
from sphrom.scene import dump_toml, load_scene, scene_dict


def ev(text, **values):
    return compile_expr(text, ("x", "t", "L", "T"), "test")(**values)


def test_arithmetic_functions_and_sums():
    x = np.linspace(0, 1, 7)
    np.testing.assert_allclose(ev("1e-3*sum(l*sin(2*pi*l*x/L) for l in range(1, 4))", x=x, L=1.0),
                               1e-3 * sum(l * np.sin(2 * np.pi * l * x) for l in (1, 2, 3)))
    np.testing.assert_allclose(ev("sum(cos(l*t) for l in (1, 3, 10))", t=x),
                               np.cos(x) + np.cos(3 * x) + np.cos(10 * x))
    np.testing.assert_allclose(ev("where(x/L <= 0.5, 0.1, 0.2)", x=x, L=1.0), np.where(x <= 0.5, 0.1, 0.2))
    np.testing.assert_allclose(ev("piecewise(x < 0.3, 1, x < 0.6, 2, 3)", x=x), np.select([x < .3, x < .6], [1, 2], 3))
    np.testing.assert_allclose(ev("0.2 if 0.1 < x < 0.5 else -1", x=x), np.where((x > .1) & (x < .5), .2, -1))
    assert float(ev("2**3 - 10 % 4 + -pi/pi")) == 5.0
    assert compile_expr("x*L + 1", ("x", "L"), "w").names == {"x", "L"}


@pytest.mark.parametrize("text, what", [
    ("__import__('os').system('true')", "allowed"),
    ("__import__('os')", "function '__import__' is not allowed"),
    ("x.__class__", "Attribute"),
    ("open('f')", "function 'open'"),
    ("(lambda: 1)()", "only plain function calls"),
    ("lambda: 1", "Lambda. is not allowed"),
    ("y + 1", "name 'y'"),
    ("sin(x, out=x)", "keyword"),
    ("sum(l for l in range(10**7))", "integer literals"),
    ("sum(l for l in range(100000))", "terms"),
    ("[1, 2]", "List"),
    ("'text'", "not a number"),
    ("x +", "syntax error"),
])
def test_refused(text, what):
    with pytest.raises(UserError, match=what):
        compile_expr(text, ("x", "L", "T"), "scene.toml: fields.v0")


def test_huge_powers_become_inf_not_huge_ints():
    assert np.isinf(ev("10**10**10"))



# -- the sandbox: no function writes into the caller's arrays; arity ---------------------------------

FIELD = "hostile.toml: fields.v0"
ALLOWED = ("x", "t", "L", "T")


def one_line_error(text, **values):
    """The UserError of ``text`` (compiled and evaluated) as one line naming the field."""
    with pytest.raises(UserError) as info:
        compile_expr(text, ALLOWED, FIELD)(**values)
    message = str(info.value)
    assert message.startswith(FIELD + ": ") and "\n" not in message and len(message) < 600, message
    return message


def caller_arrays():
    x = np.linspace(0.05, 0.95, 7)
    t = np.linspace(0.0, 2.0, 7)
    return {"x": x, "t": t, "L": np.array(1.0), "T": np.array(2.0)}


def snapshot(values):
    return {k: (v.dtype, v.shape, v.tobytes()) for k, v in values.items()}


def arguments(fn):
    """A valid argument list for ``fn``: x, t, x, ... (piecewise: three)."""
    n = fn.arity if fn.arity is not None else 3
    return (["x", "t"] * n)[:n]


@pytest.mark.parametrize("name", sorted(FUNCTIONS))
def test_no_whitelisted_function_can_write_into_the_callers_arrays(name):
    fn = FUNCTIONS[name]
    values = caller_arrays()
    before = snapshot(values)
    args = arguments(fn)
    # called as documented: a new array, the inputs untouched
    result = compile_expr(f"{name}({', '.join(args)})", ALLOWED, FIELD)(**values)
    assert snapshot(values) == before
    assert result.shape == (7,) and not any(np.shares_memory(result, v) for v in values.values())
    # an extra positional argument (numpy's out), output keywords: refused at compile time, one line
    # (piecewise takes any odd count: two more arguments are a valid call, still writing nothing)
    for more in (["x"], ["t"], ["x", "x"], ["t", "x", "x"]):
        text = f"{name}({', '.join(args + more)})"
        if fn.accepts(len(args + more)):
            result = compile_expr(text, ALLOWED, FIELD)(**values)
            assert not any(np.shares_memory(result, v) for v in values.values())
        else:
            message = one_line_error(text, **values)
            assert f"{name}() takes" in message and f"got {len(args + more)}" in message, message
        assert snapshot(values) == before, text
    for keyword in ("out", "where", "dtype", "casting", "order", "subok", "signature", "axis"):
        for value in ("x", "(x,)", "t"):
            message = one_line_error(f"{name}({', '.join(args)}, {keyword}={value})", **values)
            assert f"keyword arguments to '{name}'" in message and f"{name}() takes" in message, message
            assert snapshot(values) == before, keyword
    message = one_line_error(f"{name}(*x)", **values)
    assert "starred" in message
    if fn.arity != 0:
        assert f"{name}() takes" in one_line_error(f"{name}()", **values)
    # called from Python: the same arity, no keywords, never numpy's out
    x, t = values["x"], values["t"]
    operands = [x if a == "x" else t for a in args]
    with pytest.raises(TypeError):
        fn(*operands, x)
    with pytest.raises(TypeError):
        fn(*operands, out=x)
    assert snapshot(values) == before


@pytest.mark.parametrize("text", ["x", "+x", "-(-x)", "t", "L", "x if 1 else t", "where(1, x, t)",
                                  "piecewise(0, t, x)", "sum(x for l in (1,))"])
def test_the_result_is_never_an_array_the_caller_owns(text):
    values = caller_arrays()
    before = snapshot(values)
    result = compile_expr(text, ALLOWED, FIELD)(**values)
    assert not any(np.shares_memory(result, v) for v in values.values())
    result[...] = -7.0
    assert snapshot(values) == before


@pytest.mark.parametrize("text, what", [
    ("maximum(x, 0.9, x)", "maximum() takes 2 arguments: maximum(a, b), got 3"),
    ("floor(x, x)", "floor() takes 1 argument: floor(a), got 2"),
    ("where(x > 0.5)", "where() takes 3 arguments: where(cond, a, b), got 1"),
    ("sin()", "sin() takes 1 argument"),
    ("sin(x, x)", "sin() takes 1 argument"),
    ("piecewise(x < 0.5, 1)", "piecewise() takes an odd number >= 3"),
    ("piecewise(x < 0.5, 1, x < 0.7, 2)", "got 4"),
    ("heaviside(x)", "heaviside() takes 2 arguments"),
    ("sum(x)", "sum takes one generator"),
    ("sum((x for l in range(3)), x)", "sum takes one generator"),
    ("range(3)", "range(...) is allowed only in sum"),
])
def test_wrong_arity_is_a_one_line_error_naming_field_function_and_arity(text, what):
    values = caller_arrays()
    before = snapshot(values)
    assert what in one_line_error(text, **values)
    assert snapshot(values) == before


@pytest.mark.parametrize("text, what", [
    ("x[0]", "Subscript"), ("x.real", "Attribute"), ("(lambda y: y)(x)", "only plain function calls"),
    ("[l for l in range(3)]", "ListComp"), ("{l for l in range(3)}", "SetComp"),
    ("(l for l in range(3))", "GeneratorExp"), ("{1: x}", "Dict"), ("'x'", "not a number"),
    ("b'x'", "not a number"), ("f'{x}'", "JoinedStr"), ("(y := x)", "NamedExpr"), ("1j*x", "not a number"),
    ("x @ x", "operator 'MatMult'"), ("x // 2", "operator 'FloorDiv'"), ("x & 1", "operator 'BitAnd'"),
    ("~x", "operator 'Invert'"), ("x is x", "comparison operator"), ("x in (1, 2)", "comparison operator"),
    ("...", "not a number"), ("None", "not a number"), ("True", "not a number"), ("sin", "name 'sin'"),
    ("__builtins__", "name '__builtins__'"), ("sum(l for l in range(3) if l)", "for NAME in range"),
    ("sum(l for l in range(3) for k in range(3))", "a single 'for'"), ("sum(x for x in range(3))", "shadows"),
    ("sum(l for l in x)", "range(...) or a tuple"), ("x\0", "null"), ("x if", "syntax error"),
])
def test_outside_the_language_is_refused(text, what):
    assert what in one_line_error(text, **caller_arrays())


def test_evaluation_errors_are_one_line_user_errors():
    values = caller_arrays()
    values["t"] = np.linspace(0.0, 1.0, 5)             # x (7,) and t (5,) do not broadcast
    assert "cannot evaluate" in one_line_error("x + t", **values)
    # a comparison is a number: the boolean arithmetic numpy refuses works
    x = caller_arrays()["x"]
    np.testing.assert_array_equal(ev("-(x < 0.5) + (x > 0.2) - (x > 0.7)", x=x),
                                  -(x < 0.5).astype(float) + (x > 0.2) - (x > 0.7))



def _random_expression(rng, depth):
    """A random, mostly well-formed expression mixing the language with what lies outside it."""
    leaves = ["x", "t", "L", "T", "pi", "e", "l", "y", "sum", "range", "0", "1", "2.5", "-3", "1e308", "1e-320",
              "9007199254740992", "9007199254740993", "10**10**10", "0x10", "1" + "0" * 30]
    if depth <= 0 or rng.random() < 0.25:
        return rng.choice(leaves)
    sub = lambda: _random_expression(rng, depth - 1)      # noqa: E731
    kind = rng.randrange(9)
    if kind == 0:
        return f"({sub()} {rng.choice(['+', '-', '*', '/', '**', '%', '//', '@', '&'])} {sub()})"
    if kind == 1:
        return f"{rng.choice(['-', '+', 'not ', '~'])}{sub()}"
    if kind == 2:
        return f"({sub()} {rng.choice(['<', '<=', '==', '!=', '>', 'is', 'in'])} {sub()})"
    if kind == 3:
        return f"({sub()} if {sub()} else {sub()})"
    if kind in (4, 5):
        args = [sub() for _ in range(rng.randrange(0, 6))]
        if rng.random() < 0.2:
            args.append(f"{rng.choice(['out', 'where', 'dtype', 'casting', 'axis'])}={sub()}")
        if rng.random() < 0.05:
            args.append("*x")
        return f"{rng.choice(sorted(FUNCTIONS) + ['open', 'eval', 'sum', 'range'])}({', '.join(args)})"
    if kind == 6:
        bounds = ", ".join(rng.choice(leaves + ["1000", "-1000"]) for _ in range(rng.randrange(0, 5)))
        values = ", ".join(rng.choice(leaves) for _ in range(rng.randrange(0, 4)))
        iterable = rng.choice([f"range({bounds})", f"({values},)", "x", "[1, 2]"])
        return f"sum({sub()} for {rng.choice(['l', 'k', 'x', 'pi'])} in {iterable})"
    if kind == 7:
        return f"({sub()} {rng.choice(['and', 'or'])} {sub()})"
    return rng.choice(["x[0]", "x.T", "(lambda: x)()", "[x]", "'s'", "{x}", "f'{x}'", "(y := 1)", "...", "None"])


def test_random_expressions_give_a_value_or_a_one_line_error_and_never_write():
    """3000 random expressions (seeded): each is a value or a one-line UserError, quickly, inputs untouched.
    (The evaluator before the sandbox, on these 3000: 2 tracebacks and 2 overwrote x or t; on the first
    20 000 of the same seed: 19 tracebacks, 12 overwrote x or t.)"""
    import random
    rng = random.Random(1)
    outcomes = {"value": 0, "refused": 0}
    for _ in range(3000):
        text = _random_expression(rng, rng.randrange(1, 8))
        values = caller_arrays()
        before = snapshot(values)
        t0 = time.perf_counter()
        try:
            compile_expr(text, ALLOWED, FIELD)(**values)
            outcomes["value"] += 1
        except UserError as exc:
            assert str(exc).startswith(FIELD + ": ") and "\n" not in str(exc), text
            outcomes["refused"] += 1
        assert time.perf_counter() - t0 < 0.5, text
        assert snapshot(values) == before, text
    assert min(outcomes.values()) > 300, outcomes


# -- limits -----------------------------------------------------------------------------------------

def test_budget_refuses_a_billion_evaluations_before_starting():
    x = np.linspace(0, 1, 400)
    text = "sum(sum(sum(k*l*m*x for k in range(1000)) for l in range(1000)) for m in range(1000))"
    t0 = time.perf_counter()
    message = one_line_error(text, x=x, L=1.0)
    elapsed = time.perf_counter() - t0
    assert f"more than {MAX_OPERATIONS} operations" in message and "nested sums" in message
    assert elapsed < 0.1, elapsed                       # refused at compile time, nothing evaluated
    # two nested sums of 1000 (10^6 terms) are refused too; 100 x 100 of a small body is allowed
    assert "operations" in one_line_error("sum(sum(k*l for k in range(1000)) for l in range(1000))")
    got = ev("sum(sum(k*l*x for k in range(100)) for l in range(100))", x=x)
    np.testing.assert_allclose(got, sum(k * l for k in range(100) for l in range(100)) * x, rtol=1e-12)
    # the largest sum a single range allows, with a realistic body, evaluates quickly
    t0 = time.perf_counter()
    got = ev(f"sum(sin(2*pi*l*x/L)/l**2 for l in range(1, {MAX_TERMS + 1}))", x=x, L=1.0)
    assert time.perf_counter() - t0 < 2.0 and np.all(np.isfinite(got))


@pytest.mark.parametrize("text, what", [
    ("-" * 10_000 + "x", "characters is too long"),
    ("+".join(["x"] * 50_000), "characters is too long"),
    ("(" * 2000 + "x" + ")" * 2000, "characters is too long"),
    ("sin(" * 1000 + "x" + ")" * 1000, "characters is too long"),
    ("-" * (MAX_LENGTH - 1) + "x", "nested"),                  # the parser's own recursion guard
    ("not " * 999 + "x", "nested"),
    ("+".join(["x"] * 1999), "nested"),
    ("x**" * 1300 + "x", "nested"),
    ("x if x else " * 300 + "x", "nested"),
    ("-(" * 150 + "x" + ")" * 150, "nested"),
    ("(" * 250 + "x" + ")" * 250, "too many nested parentheses"),
    ("sin(" * 120 + "x" + ")" * 120, "nested"),
    ("+".join(["x"] * (MAX_DEPTH + 1)), f"nested more than {MAX_DEPTH} levels"),
])
def test_deep_or_long_expressions_are_refused_quickly_without_recursion_error(text, what):
    t0 = time.perf_counter()
    message = one_line_error(text, x=np.ones(3))
    assert what in message and time.perf_counter() - t0 < 1.0, message


def test_depth_limit_admits_what_it_documents():
    x = np.linspace(0, 1, 5)
    np.testing.assert_array_equal(ev("(" * 150 + "x" + ")" * 150, x=x), x)     # parentheses are no nesting
    np.testing.assert_array_equal(ev("+".join(["x"] * (MAX_DEPTH - 1)), x=x), sum([x] * (MAX_DEPTH - 1)))


@pytest.mark.parametrize("text, what", [
    ("1" + "0" * 400, "out of range (allowed: |n| <= 2**53"),
    (str(MAX_INT + 1) + "*x", "out of range"),
    ("-" + str(MAX_INT + 1), "out of range"),
    ("0x" + "f" * 1000, "out of range"),
    ("1e999", "overflows to inf"),
    ("sum(l for l in range(10**30))", "integer literals"),
    ("sum(l for l in range(1000000000000000000000000000000))", "out of range"),
    ("sum(l for l in range(1, 2, 0))", "range step is 0"),
    ("sum(l for l in range(-5))", "sum has no terms"),
    ("sum(l for l in range(5, 1))", "sum has no terms"),
    ("sum(l for l in ())", "sum has no terms"),
    ("sum(l for l in range(1, 2, 3, 4))", "range takes 1 to 3 integer arguments, got 4"),
    ("sum(l for l in range())", "range takes 1 to 3"),
    ("sum(l for l in range(stop=3))", "range takes 1 to 3"),
    ("sum(l for l in range(1.5))", "integer literals"),
    ("sum(l for l in range(x))", "integer literals"),
    (f"sum(l for l in range(-{MAX_INT}, {MAX_INT}))", f"terms (allowed: 1 to {MAX_TERMS})"),
    (f"sum(l for l in range({MAX_TERMS + 1}))", "terms"),
])
def test_literal_and_range_limits(text, what):
    assert what in one_line_error(text, x=np.ones(3))


def test_literals_at_the_limits_are_exact():
    assert float(ev(str(MAX_INT))) == 2.0**53 and float(ev("-" + str(MAX_INT))) == -2.0**53
    assert float(ev(f"sum(l for l in range({MAX_INT - 2}, {MAX_INT}))")) == 2 * 2.0**53 - 3
    assert float(ev(f"sum(1 for l in range({MAX_TERMS}))")) == MAX_TERMS
    assert float(ev("sum(l for l in range(10, 0, -3))")) == 10 + 7 + 4 + 1
    with pytest.raises(UserError, match="2\\*\\*53"):
        compile_expr(10**400, ALLOWED, FIELD)


@pytest.mark.parametrize("text", ["10**10**10", "x/0", "log(x - x)", "exp(1000*x)", "0/0", "1e308*10"])
def test_overflow_and_division_by_zero_are_non_finite_values_not_errors(text):
    value = ev(text, x=np.linspace(0.1, 1, 4))
    assert not np.all(np.isfinite(value))


# -- every place that takes an expression ---------------------------------------------------------

HOSTILE = [
    ("maximum(x, 0.9, x)", "maximum() takes 2 arguments"),
    ("floor(x, x)", "floor() takes 1 argument"),
    ("sin(x, out=x)", "keyword arguments to 'sin'"),
    ("sum(sum(sum(k*l*m*x for k in range(1000)) for l in range(1000)) for m in range(1000))", "operations"),
    ("+".join(["x"] * 1500), "nested"),
    ("-" * 20_000 + "x", "too long"),
    ("1" + "0" * 400, "2**53"),
    ("sum(l*x for l in range(1, 2, 0))", "range step is 0"),
    ("x.__class__", "Attribute"),
    ("1e-3*x/(x - x)", "non-finite value"),
]


@pytest.mark.parametrize("text, what", HOSTILE)
def test_scene_file_with_a_hostile_v0_is_exit_2_one_line_no_output(tmp_path, capsys, text, what):
    data = scene_dict(load_scene("multimode"))
    data["fields"]["v0"] = text
    path = tmp_path / "hostile.toml"
    path.write_text(dump_toml(data))
    out = tmp_path / "out.h5"
    t0 = time.perf_counter()
    assert main(["sph", str(path), "--out", str(out)]) == 2
    assert time.perf_counter() - t0 < 5.0
    captured = capsys.readouterr()
    err = captured.err.strip()
    assert len(err.splitlines()) == 1 and f"{path}: fields.v0" in err and what in err, err
    assert "Traceback" not in captured.err and not out.exists() and not list(tmp_path.glob("*out*"))


def test_cosim_force_longer_than_a_file_name_is_an_expression(tmp_path):
    from sphrom.fmu.run.cosim import force_signal
    term = "1e-3*sin(2*pi*t)"
    long = " + ".join([term] * 16)                      # 300 characters: no possible file name
    assert len(long) > 255
    signal = force_signal(long, 1.0, 0.1)
    np.testing.assert_array_equal(signal["time"], np.arange(11) * 0.1)
    np.testing.assert_allclose(signal["f"], 16e-3 * np.sin(2 * np.pi * signal["time"]), rtol=1e-12, atol=1e-18)
    # anything that is not a file is an expression, with the expression's one-line errors
    for text, what in [("x" * 300, "name 'xxx"), ("t" + "\0" * 3, "null"), ("floor(t, t)" + " " * 300, "floor()"),
                       ("/".join(["t"] * 200), "nested"), ("sum(sum(sum(k*l*m*t for k in range(1000)) "
                                                          "for l in range(1000)) for m in range(1000))", "operations")]:
        with pytest.raises(UserError) as info:
            force_signal(text, 1.0, 0.1)
        message = str(info.value)
        # the library names the field; the command layer adds the option (--force)
        assert message.startswith("force: ") and "\n" not in message and what in message, message
    # a CSV named by a path longer than a file name: one line that says the system refused the name
    with pytest.raises(UserError, match=r"^force: CSV file .* cannot be read \(File name too long\)"):
        force_signal(str(tmp_path / ("f" * 300 + ".csv")), 1.0, 0.1)
    # a CSV still is a CSV
    csv = tmp_path / "force.csv"
    csv.write_text("time,f\n0,1\n1,2\n")
    assert list(force_signal(str(csv), 1.0, 0.5)["f"]) == [1.0, 2.0]


def test_cosim_command_with_a_hostile_force_is_one_line(tmp_path, capsys):
    # the FMU is checked first: a missing one is named, never an OSError from the long force
    out = tmp_path / "r.csv"
    assert main(["cosim", str(tmp_path / "none.fmu"), "--force", "maximum(t, 0.9, t)" * 20, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "not found" in err and not out.exists()
    assert main(["sph", "x" * 300, "--out", str(tmp_path / "o.h5")]) == 2      # a scene name too long for a file
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "no such built-in scene" in err


SWEEP = """
scene = "multimode"
t_end = 0.5
step = 0.01
[grid]
amplitude = [1e-3]
frequency = [1.0]
{key} = [{value}]
"""


@pytest.mark.parametrize("key", ["shape", "profile"])
@pytest.mark.parametrize("text, what", [(t, w) for t, w in HOSTILE if w != "non-finite value"])
def test_sweep_spec_with_a_hostile_expression_is_one_line(tmp_path, capsys, key, text, what):
    from sphrom.sweep.spec import parse_spec
    text = re.sub(r"\bx\b", "t", text) if key == "shape" else text
    spec = tmp_path / "spec.toml"
    spec.write_text(SWEEP.format(key=key, value=json.dumps(text)))
    with pytest.raises(UserError) as info:
        parse_spec(spec.read_text(), str(spec), spec_path=spec)
    message = str(info.value)
    assert message.startswith(f"{spec}: grid.{key}[0]: ") and "\n" not in message and what in message, message
    if key == "shape" and what == "operations":
        out = tmp_path / "r.h5"
        assert main(["sweep", str(spec), "--out", str(out)]) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and "grid.shape[0]" in err and not out.exists()


def test_sweep_profile_that_is_not_finite_is_named():
    from sphrom.sweep.spec import parse_spec
    with pytest.raises(UserError, match=r"force.profile: non-finite value"):
        parse_spec(SWEEP.format(key="profile", value='"1/(x - x)"'), "spec.toml")


# -- backwards compatibility: the values of the evaluator before the sandbox, within ulps ---------
#
# tests/data/expr_reference.npz holds, per array, up to SAMPLES evenly spaced float64 values of every
# built-in scene field and force, every sweep example's force per entry, the cosim force of the README and a
# corpus of expressions covering every function and operator.  The first reference (commit 0c45abe) stored
# sha256 digests of the whole arrays, written by the evaluator before the sandbox; the values here were
# written by ``write_reference(digests=OLD_JSON)``, which first checked that every array computed then had
# exactly the old digest (numpy on its baseline code paths, AVX-512 disabled):
#   NPY_DISABLE_CPU_FEATURES="X86_V4 AVX512_ICL AVX512_SPR" python3 -c "import sys; sys.path.insert(0, 'tests'); \
#       import test_expr; test_expr.write_reference(digests='expr_reference.json')  # git show 5d13c25:tests/data/expr_reference.json"
# Do not regenerate it to make a failing comparison pass: a difference is a change of the language.

REFERENCE = Path(__file__).parent / "data" / "expr_reference.npz"
SAMPLES = 48       # values kept per array (evenly spaced indices, the ends included)
ULPS = 4           # allowed difference, in units in the last place of the reference value

CORPUS = [
    "sin(2*pi*x/L)", "cos(x)", "tan(x)", "arcsin(x)", "arccos(x)", "arctan(x)", "arctan2(x, t - 1)",
    "sinh(x)", "cosh(x)", "tanh(x)", "exp(-x)", "log(x)", "log10(x)", "sqrt(x)", "abs(x - 0.5)",
    "sign(x - 0.5)", "floor(10*x)", "ceil(10*x)", "minimum(x, 0.5)", "maximum(x, t)", "mod(10*x, 3)",
    "heaviside(x - 0.5, 0.5)", "where(x > 0.5, x, -x)", "piecewise(x < 0.3, 1, x < 0.6, 2, 3)",
    "x**2 + 3*x - 1/x", "x % 0.3", "-x + +t", "0.2 if 0.1 < x < 0.5 else -1",
    "(x < 0.5) and (t > 1) or not (x > 0.9)", "x == 0.5", "x != 0.5", "x >= 0.5", "x <= 0.5",
    "(x < 0.5)*2", "1e-3*sum(l*sin(2*pi*l*x/L) for l in range(1, 4))", "sum(cos(l*t) for l in (1, 3, 10))",
    "sum(l for l in range(10, 0, -2))", "sum(sum(k*l*x for k in range(3)) for l in range(4))",
    "2**3 - 10 % 4 + -pi/pi", "e**x", "10**10**10", "x/0", "1e-2*cos(10*t/T)", "1e-3*sin(2*pi*t)",
    "x", "L", "t*T", "3", "0.25",
]


def _digest(value):
    """The sha256 digest the first reference (expr_reference.json, commit 0c45abe) stored per array: kept only
    to show, once, that the stored values are those of the evaluator before the sandbox (write_reference)."""
    a = np.ascontiguousarray(np.asarray(value, dtype="<f8"))
    return f"{a.shape}:{hashlib.sha256(a.tobytes()).hexdigest()}"


def _sample(value):
    """(shape, indices, values): at most SAMPLES evenly spaced entries of the flattened array."""
    a = np.asarray(value, dtype="<f8")
    flat = a.reshape(-1)
    idx = np.unique(np.linspace(0, flat.size - 1, min(SAMPLES, flat.size)).round().astype(np.int64))
    return a.shape, idx, flat[idx]


def reference_values(keep=_sample):
    """{key: keep(array)} of everything the language is used for in the repository."""
    from sphrom.fmu.run.cosim import force_signal
    from sphrom.scene import builtin_dir, builtin_names
    from sphrom.sph.operator import particle_positions
    from sphrom.sweep.spec import force_at, load_spec

    out = {}
    for name in builtin_names():
        scene = load_scene(name)
        x = particle_positions(scene.L, scene.sph.n_particles)
        for field_name in sorted(scene.fields):
            out[f"scene/{name}/{field_name}"] = keep(scene.field(field_name, x))
        out[f"scene/{name}/f/257"] = keep(scene.force(np.linspace(0.0, scene.T, 257)))
        n = int(round(scene.T / scene.sph.dt))
        out[f"scene/{name}/f/steps"] = keep(scene.force(np.arange(n + 1) * scene.sph.dt))
    for path in sorted((builtin_dir().parent / "sweeps").glob("*.toml")):
        spec = load_spec(path)
        seen = set()
        for entry in spec.entries:
            key = (entry.shape, entry.amplitude, entry.frequency)
            if key in seen:
                continue
            seen.add(key)
            times = np.arange(int(round(entry.t_end / entry.step)) + 1) * entry.step
            out[f"sweep/{path.stem}/{entry.shape}/{entry.amplitude!r}/{entry.frequency!r}"] = \
                keep(force_at(entry, times[:-1]))
    for text in ("1e-3*sin(2*pi*t)", "1e-2*cos(10*t/T)"):
        signal = force_signal(text, 10.0, 0.01)
        out[f"cosim/{text}"] = keep(np.stack([signal["time"], signal["f"]]))
    x = np.linspace(0.05, 0.95, 19)
    t = np.linspace(0.0, 2.0, 19)
    for text in CORPUS:
        out[f"corpus/{text}"] = keep(ev(text, x=x, t=t, L=1.0, T=2.0))
    return out


def write_reference(digests=None):
    """Store the sampled values; with ``digests`` (the old JSON of sha256 digests), first check that every array
    computed now has exactly the digest stored then, so the values stored are those of the old evaluator.
    Run it where numpy takes the baseline code paths (NPY_DISABLE_CPU_FEATURES, .ci/run's second pass)."""
    if digests is not None:
        old = json.loads(Path(digests).read_text())
        now = reference_values(keep=_digest)
        assert now == old, [k for k in old if now.get(k) != old[k]][:5]
    items = sorted(reference_values().items())
    shapes = [shape for _, (shape, _, _) in items]
    rank = max(len(shape) for shape in shapes)
    np.savez_compressed(REFERENCE, keys=np.array([key for key, _ in items]),
                        shapes=np.array([(len(sh),) + tuple(sh) + (0,) * (rank - len(sh)) for sh in shapes]),
                        values=np.concatenate([values for _, (_, _, values) in items]))


def load_reference():
    """{key: (shape, indices, values)} from REFERENCE."""
    ref = np.load(REFERENCE)
    out, start = {}, 0
    for key, row in zip(ref["keys"], ref["shapes"]):
        shape = tuple(int(d) for d in row[1:1 + row[0]])
        idx = _sample(np.zeros(shape))[1]
        out[str(key)] = (shape, idx, ref["values"][start:start + idx.size])
        start += idx.size
    assert start == ref["values"].size
    return out


def within_ulps(got, ref, ulps=ULPS, scale=0.0):
    """True where ``got`` equals ``ref`` to ``ulps`` units in the last place of ``ref``, or of ``scale`` (the array's
    largest magnitude; NaN matching NaN and infinities matching exactly).  The second: a last-bit difference in an
    intermediate (numpy's pow, square and exp differ between versions and CPUs: numpy 1.26 against 2.x) is amplified
    by the expression's condition, exp(-200 (x - 1/2)^2) by its argument, up to 50 at the gaussian's ends, where
    the values are 1e-22 of the largest: 4 ulps of the array's scale bound what matters of such a tail."""
    got, ref = np.asarray(got, dtype=float), np.asarray(ref, dtype=float)
    finite = np.isfinite(ref)
    same = np.where(finite, False, (got == ref) | (np.isnan(got) & np.isnan(ref)))
    with np.errstate(invalid="ignore"):
        close = np.abs(got - ref) <= ulps * np.maximum(np.spacing(np.abs(ref)), np.spacing(float(scale)))
    return np.where(finite, close, same)


@pytest.mark.cpu_sensitive
def test_the_values_of_the_evaluator_before_the_sandbox_within_ulps():
    """Every value the language computes in the repository equals the evaluator's before the sandbox to ULPS
    units in the last place.  Not bit for bit: numpy picks CPU-specific code for transcendental functions
    (np.arccos(0.05) differs in its last bit with AVX-512), so a hash of the bits passes on one CPU only."""
    expected = load_reference()
    got = reference_values()
    assert sorted(got) == sorted(expected)
    changed = []
    for key, (shape, idx, values) in expected.items():
        g_shape, g_idx, g_values = got[key]
        if tuple(g_shape) != shape or not np.array_equal(g_idx, idx) or not within_ulps(
                g_values, values, scale=np.max(np.abs(values[np.isfinite(values)]), initial=0.0)).all():
            changed.append(key)
    assert not changed, f"{len(changed)} values changed beyond {ULPS} ulps, e.g. {changed[:5]}"


def test_within_ulps_counts_units_in_the_last_place():
    one = np.float64(1.0)
    assert within_ulps(one + 4 * np.spacing(one), one) and not within_ulps(one + 5 * np.spacing(one), one)
    assert within_ulps([np.nan, np.inf, -0.0], [np.nan, np.inf, 0.0]).all()
    assert not within_ulps([1.0, -np.inf], [np.nan, np.inf]).any()
