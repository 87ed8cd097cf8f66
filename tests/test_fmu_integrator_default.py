"""A frozen FMU given no integrator steps with one that amplifies no reduced mode: an FMU runs for as long as its
master does, not for the scene's T (docs/fmu/ports.md, "The integrator of a port FMU"; the same own state without
ports).  The scene's explicit Euler is kept where it contracts every mode (a damped bar: the paper's model as the
paper ran it), symplectic Euler taken where explicit Euler would grow a mode step after step (an undamped bar, or a
damping too weak for the fastest mode), and a named integrator is never overridden."""

import zipfile

import pytest

from conftest import small_scene
from sphrom.fmu.kinds.frozen import EULER_GROWTH, open_ended_integrator, reduced_model
from sphrom.fmu.make.package import package_fmu
from sphrom.fmu.resources import unpack
from sphrom.rom.stepping import reduced_amplification

PROBES = (0.25, 0.5, 0.66)
LONG = 1e4                   # [s] a long co-simulation: thousands of the scenes' T


def _ops(scene, k=6):
    _, ops, _, _ = reduced_model(scene, k, 10, PROBES, "euler", progress=False)
    return ops


@pytest.mark.parametrize("case, d, expected", [("undamped", 0.0, "symplectic"), ("damped", 10.0, "euler"),
                                                ("weakly damped", 1e-3, "symplectic")])
def test_open_ended_integrator_amplifies_no_mode(case, d, expected):
    """On the shrunk multimode bar (N = 32, explicit Euler at dt = 5e-3 s, its frozen model linearised about rest):
    the integrator chosen grows no reduced mode beyond round-off over LONG seconds, and explicit Euler is replaced
    exactly where it would (its growth over LONG above 1 + EULER_GROWTH x steps)."""
    scene = small_scene("multimode", T=0.5, n=32, dt=5e-3, d=repr(d))
    ops = _ops(scene)
    dt = scene.sph.dt
    chosen = open_ended_integrator(ops, dt, "euler")
    assert chosen == expected
    euler_step = reduced_amplification(ops, dt, "euler", dt)[0]
    assert (euler_step > 1.0 + EULER_GROWTH) == (chosen != "euler")
    growth = reduced_amplification(ops, dt, chosen, LONG)[0]
    steps = LONG / dt
    assert growth <= 1.0 + 1e-9 * steps, (case, chosen, growth)
    assert open_ended_integrator(ops, dt, "symplectic") == "symplectic"    # never from symplectic to Euler


def test_named_integrator_is_kept(tmp_path):
    """`sphrom fmu --integrator euler` on an undamped bar keeps explicit Euler (the user's choice), the default takes
    symplectic Euler; both FMUs say so in their model.bin."""
    scene = small_scene("multimode", T=0.5, n=32, dt=5e-3)
    got = {}
    for integrator in (None, "euler"):
        path = tmp_path / f"mm-{integrator}.fmu"
        s = package_fmu(scene, path, model="frozen", k=6, n_freeze=10, progress=False, verify=False,
                        error_bounds=False, integrator=integrator)
        data = unpack(zipfile.ZipFile(path).read("resources/model.bin"))
        assert s.integrator == data.integrator
        got[integrator] = data.integrator
    assert got == {None: "symplectic", "euler": "euler"}
