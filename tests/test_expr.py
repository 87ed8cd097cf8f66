"""The whitelisted expression evaluator: what it computes and what it refuses."""

import hashlib
import json
from pathlib import Path

import numpy as np
import pytest

from harness.errors import UserError
from harness.expr import compile_expr
from harness.scene import load_scene


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


# -- backwards compatibility: bitwise the values of the evaluator before the sandbox --------------
#
# tests/data/expr_reference.json holds SHA-256 digests of the float64 bytes of every built-in
# scene field and force, every sweep example's force per entry, the cosim force of the README and a
# corpus of expressions covering every function and operator.  It was written by
# ``write_reference()`` below running on the evaluator before the sandbox (commit 0c45abe):
#   python3 -c "import sys; sys.path.insert(0, 'tests'); import test_expr; test_expr.write_reference()"
# Do not regenerate it to make a failing comparison pass: a difference is a change of the language.

REFERENCE = Path(__file__).parent / "data" / "expr_reference.json"

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
    a = np.ascontiguousarray(np.asarray(value, dtype="<f8"))
    return f"{a.shape}:{hashlib.sha256(a.tobytes()).hexdigest()}"


def reference_values():
    """{key: digest} of everything the language is used for in the repository."""
    from harness.fmu.cosim import force_signal
    from harness.scene import builtin_dir, builtin_names
    from harness.sph.operator import particle_positions
    from harness.sweep.spec import force_at, load_spec

    out = {}
    for name in builtin_names():
        scene = load_scene(name)
        x = particle_positions(scene.L, scene.sph.n_particles)
        for field_name in sorted(scene.fields):
            out[f"scene/{name}/{field_name}"] = _digest(scene.field(field_name, x))
        out[f"scene/{name}/f/257"] = _digest(scene.force(np.linspace(0.0, scene.T, 257)))
        n = int(round(scene.T / scene.sph.dt))
        out[f"scene/{name}/f/steps"] = _digest(scene.force(np.arange(n + 1) * scene.sph.dt))
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
                _digest(force_at(entry, times[:-1]))
    for text in ("1e-3*sin(2*pi*t)", "1e-2*cos(10*t/T)"):
        signal = force_signal(text, 10.0, 0.01)
        out[f"cosim/{text}"] = _digest(np.stack([signal["time"], signal["f"]]))
    x = np.linspace(0.05, 0.95, 19)
    t = np.linspace(0.0, 2.0, 19)
    for text in CORPUS:
        out[f"corpus/{text}"] = _digest(ev(text, x=x, t=t, L=1.0, T=2.0))
    return out


def write_reference():
    REFERENCE.write_text(json.dumps(reference_values(), indent=1, sort_keys=True) + "\n")


def test_bitwise_the_values_of_the_evaluator_before_the_sandbox():
    expected = json.loads(REFERENCE.read_text())
    got = reference_values()
    assert sorted(got) == sorted(expected)
    changed = [key for key in expected if got[key] != expected[key]]
    assert not changed, f"{len(changed)} values changed, e.g. {changed[:5]}"
