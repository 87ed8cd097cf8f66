"""The FMU knows its training envelope: recorded at packaging (sections ENVELOPE, ENVRANGE, ENVPROBE),
read back by the C core, checked after every doStep of the frozen model, one warning per instance (never
an error), none for the linear model, none on the training run or an unseen force inside the envelope.
"""

import zipfile

import numpy as np
import pytest

from conftest import fmu_scene, model_per_kind
from sphrom.fmu.training import envelope as E
from sphrom.fmu.make.build import ensure_binaries
from sphrom.fmu.run.core import Core
from sphrom.fmu.run.driver import FMU
from sphrom.fmu.make.package import package_fmu
from sphrom.fmu.kinds import kind_of
from sphrom.rom.registry import get_model
from sphrom.fmu.resources import pack, unpack

H = 0.01
ENVELOPE_TEXT = "outside the training envelope"


@pytest.fixture(scope="session")
def envelope_fmus(tmp_path_factory):
    binaries = ensure_binaries()
    folder = tmp_path_factory.mktemp("envelope-fmus")
    made = {}

    def make(model, fmi, scale=1.0):
        key = (model, fmi, scale)
        if key not in made:
            if scale == 1.0:
                path = folder / f"forced-{model}-fmi{fmi}.fmu"
                package_fmu(fmu_scene("forced"), path, k=6, fmi=fmi, progress=False, binaries=binaries, model=model,
                            error_bounds=False)      # the envelope is the error signal of an FMU without bounds
            else:                   # a test-only FMU: the same model, its initial state scaled
                path = scaled_copy(make(model, fmi), folder / f"forced-{model}-fmi{fmi}-x{scale:g}.fmu", scale)
            made[key] = path
        return made[key]

    return make


def scaled_copy(path, out, scale):
    """A copy of the FMU at ``path`` whose initial state (a^v, or z) is scaled (density at ρ0), new token."""
    with zipfile.ZipFile(path) as z:
        data = unpack(z.read("resources/model.bin"))
        old = data.token
        name = kind_of(data).INITIAL_STATE           # what initial_state_scale multiplies: a_v0, or z0
        setattr(data, name, getattr(data, name) * scale)
        blob = pack(data)
        with zipfile.ZipFile(out, "w") as o:
            for item in z.infolist():
                content = z.read(item.filename)
                if item.filename == "resources/model.bin":
                    content = blob
                elif item.filename == "modelDescription.xml":
                    content = content.replace(old.encode(), data.token.encode())
                o.writestr(item, content)
    return out


def envelope_warnings(slave):
    return [text for status, _, text in slave.messages if status == 1 and ENVELOPE_TEXT in text]


def run_fmu(path, force, T=None, reset_and_repeat=False, scale=None):
    """The envelope warnings and the error messages of a run of ``path`` at step H under ``force``,
    initial_state_scale ``scale`` (None: the FMU's start value 0, from rest)."""
    T = T or fmu_scene("forced").T
    n = int(round(T / H))
    t = np.arange(n) * H
    with FMU(path) as s:
        s.initialize(initial_state_scale=scale)
        s.run([H] * n, force(t))
        if reset_and_repeat:
            s.reset()
            s.initialize(initial_state_scale=scale)
            s.run([H] * n, force(t))
        return envelope_warnings(s), s.errors()


def test_envelope_sections_round_trip_python_and_c(envelope_fmus):
    """The packaged sections read back by Python (unpack) and by the C core (rom_model_section) bitwise, and
    the core's check of a state agrees with the Python mirror (envelope.check): none at the start, the same
    quantity out of range at 10x the initial state."""
    core = Core(ensure_binaries().core)
    scene = fmu_scene("forced")
    for model in model_per_kind(needs_basis=True):
        linear = get_model(model).linear                          # no run-time checks
        blob = zipfile.ZipFile(envelope_fmus(model, 2)).read("resources/model.bin")
        data = unpack(blob)
        env = E.Envelope.from_sections(data.sections, data.k_v)
        assert {"ENVELOPE", "ENVRANGE", "ENVPROBE"} <= set(data.sections)   # exact: also BOUNDS, LINMODEL
        assert data.sections["ENVRANGE"].shape == (2, data.k_v + data.k_rho)
        assert env.force_amplitude == pytest.approx(np.max(np.abs(scene.force(np.arange(2501) * scene.sph.dt))))
        assert 0 < env.max_probe_strain <= env.max_strain
        assert (env.checks == 0) == linear
        cm = core.load(blob)
        for tag, values in data.sections.items():
            assert np.array_equal(cm.section(tag), values), tag
        assert cm.section("NOSUCH") is None
        assert cm.envelope_check() is None
        # a state 10x out: C and Python name the same quantity (the linear model: no check at all)
        big = envelope_fmus(model, 2, 10.0)
        data10 = unpack(zipfile.ZipFile(big).read("resources/model.bin"))
        cm10 = core.load(zipfile.ZipFile(big).read("resources/model.bin"))
        cm10.do_step(0.0, H)
        z = cm10.reduced_state()
        rho = cm10.outputs(data10.n_probes)[1]
        expected = E.check(env, z, 0.0, rho, data10.k_v)
        message = cm10.envelope_check()
        if linear:
            assert expected is None and message is None
        else:
            assert expected is not None and message is not None
            assert f"{expected[0]} = " in message and f"t = {H:.9g} s" in message


@pytest.mark.parametrize("fmi", [2, 3])
@pytest.mark.parametrize("model", model_per_kind(needs_basis=True))
def test_training_run_never_warns(envelope_fmus, fmi, model):
    """The scene's own run (its initial state, its force at the communication points, held) stays inside
    the envelope."""
    scene = fmu_scene("forced")
    warnings, errors = run_fmu(envelope_fmus(model, fmi), scene.force, scale=1.0)
    assert warnings == [] and errors == []


@pytest.mark.parametrize("fmi", [2, 3])
def test_ten_times_the_amplitude_warns_once(envelope_fmus, fmi):
    """initial_state_scale = 10: the frozen FMU logs exactly one warning (never an error) naming the quantity,
    its value, the trained range and the time; reset re-arms it; the exact FMU, exact in its state at any
    amplitude, logs none."""
    scene = fmu_scene("forced")
    warnings, errors = run_fmu(envelope_fmus("frozen", fmi), scene.force, scale=10.0)
    assert errors == []
    (text,) = warnings
    assert "reduced coordinate a_v_" in text and "trained range [" in text and "t = 0.01 s" in text
    assert "warned once per instance" in text
    warnings, errors = run_fmu(envelope_fmus("frozen", fmi), scene.force, reset_and_repeat=True, scale=10.0)
    assert len(warnings) == 2 and errors == []
    warnings, errors = run_fmu(envelope_fmus("exact", fmi), scene.force, scale=10.0)
    assert warnings == [] and errors == []


@pytest.mark.parametrize("fmi", [2, 3])
def test_force_above_the_trained_amplitude_warns_once(envelope_fmus, fmi):
    """A constant force 3x the trained max |f|: one warning naming the input |f| and its trained range."""
    path = envelope_fmus("frozen", fmi)
    env = E.Envelope.from_sections(unpack(zipfile.ZipFile(path).read("resources/model.bin")).sections, 0)
    warnings, errors = run_fmu(path, lambda t: np.full_like(t, 3 * env.force_amplitude))
    assert errors == []
    (text,) = warnings
    assert "input |f| = " in text and f"{env.margin:g} x the trained amplitude" in text


@pytest.mark.parametrize("fmi", [2, 3])
@pytest.mark.parametrize("model", model_per_kind(needs_basis=True))
def test_unseen_force_inside_the_envelope_gives_no_warning(envelope_fmus, fmi, model):
    """A force the basis never saw (one tone at another frequency, 0.6x the trained amplitude), from rest
    (initial_state_scale 0, the FMU's start value): no warning."""
    scene = fmu_scene("forced")
    amplitude = float(np.max(np.abs(scene.force(np.linspace(0, scene.T, 2001)))))
    warnings, errors = run_fmu(envelope_fmus(model, fmi), lambda t: 0.6 * amplitude * np.sin(2 * np.pi * 7.0 * t))
    assert warnings == [] and errors == []


def test_force_band_of_known_signals():
    """The 99 % energy band: a pure tone at its frequency, a constant or zero force 0."""
    dt = 1e-3
    t = np.arange(10000) * dt                      # 10 s: 3 Hz is a whole number of periods
    assert E.force_band(np.sin(2 * np.pi * 3.0 * t), dt) == pytest.approx(3.0)
    assert E.force_band(np.full_like(t, 2.0), dt) == 0.0
    assert E.force_band(np.zeros_like(t), dt) == 0.0


@pytest.mark.parametrize("fmi", [2, 3])
def test_cosim_shows_the_envelope_warning(envelope_fmus, tmp_path, capsys, fmi):
    """``sphrom cosim`` prints the FMU's envelope warning (once) at 10x, nothing at the training amplitude."""
    from sphrom.cli import main
    scene = fmu_scene("forced")
    for scale, expected in ((1.0, 0), (10.0, 1)):
        out = tmp_path / f"x{scale:g}.csv"
        assert main(["cosim", str(envelope_fmus("frozen", fmi)), "--force", scene.f.text, "--step", str(H),
                     "--t-end", str(scene.T), "--initial-state-scale", f"{scale:g}", "--out", str(out)]) == 0
        printed = [line for line in capsys.readouterr().out.splitlines() if line.startswith("FMU warning:")]
        assert len(printed) == expected and all(ENVELOPE_TEXT in line for line in printed)
        assert out.exists()


@pytest.mark.parametrize("fmi", [2, 3])
@pytest.mark.parametrize("model", model_per_kind(needs_basis=True))
def test_description_states_the_envelope_and_nominal_values(envelope_fmus, fmi, model):
    """The model description carries the envelope, and the variables' nominal values are the envelope's
    (f: the training amplitude; v_probe_j: max |v| at probe j in training; rho_probe_j: rho0 there); dt > 0,
    densities > 0, n_freeze >= 1 as min where the variables exist."""
    import fmpy
    path = envelope_fmus(model, fmi)
    data = unpack(zipfile.ZipFile(path).read("resources/model.bin"))
    env = E.Envelope.from_sections(data.sections, data.k_v)
    md = fmpy.read_model_description(str(path))
    assert "Training envelope: training force max |f| = " in md.description
    assert f"largest strain |rho0/rho - 1| in training {env.max_strain:.3g}" in md.description
    variables = {v.name: v for v in md.modelVariables}
    assert float(variables["f"].nominal) == env.force_amplitude
    for j in range(data.n_probes):
        assert float(variables[f"v_probe_{j + 1}"].nominal) == env.probe_v_max[j] > 0
        assert float(variables[f"rho_probe_{j + 1}"].nominal) == env.probe_rho0[j]
        assert float(variables[f"rho_probe_{j + 1}"].min) == 0.0
    if "dt" in variables:
        assert float(variables["dt"].min) == 0.0
    if "n_freeze" in variables:
        assert int(variables["n_freeze"].min) == 1


def test_amplitude_sweep_measures_where_the_frozen_model_fails():
    """The benchmark behind the margin and the failure strain, on a small undamped scene: the full SPH is
    linear in J (up to its time stepping of ρ), so the exact model's error hardly moves with the scale, while
    the frozen model's error and the strain grow in proportion to it, and its coordinates leave the trained
    ranges (excess above margin - 1)."""
    from sphrom.bench.envelope import failure_strain, measure
    rows = measure(fmu_scene("unforced"), scales=(1.0, 2.0, 10.0), progress=False)
    one, two, ten = rows
    assert ten["exact_v_error"] == pytest.approx(one["exact_v_error"], rel=0.05)
    assert ten["peak_strain"] == pytest.approx(10 * one["peak_strain"], rel=0.05)
    assert one["frozen_v_error"] < two["frozen_v_error"] < ten["frozen_v_error"]
    assert ten["frozen_v_error"] > 5 * one["frozen_v_error"]
    assert one["frozen_coordinate_excess"] < E.MARGIN - 1 < ten["frozen_coordinate_excess"]
    mid = 0.5 * (one["frozen_v_error"] + two["frozen_v_error"])
    assert one["peak_probe_strain"] < failure_strain(rows, one["scene"], mid) < two["peak_probe_strain"]
