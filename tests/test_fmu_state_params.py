"""FMU states carry the parameters an instance can differ in (state format 4, harness/fmu/layout.py).

A state saved at (c1, d1) and restored in an instance set to (c2, d2) must continue bitwise as the instance that
saved it (the parameters come back and the operators are assembled again), likewise the area of a port FMU;
get/set and serialize/deserialize round trips are bitwise, FMI 2 and 3; blobs of an older state format (format 2,
stored from the code then, tests/data/make_state_v2_reference.py) can never be restored: a state restores only
into the FMU whose token it carries, the token hashes model.bin, and an FMU of today's model.bin format has another
token than the FMU that wrote it; they are refused naming their version and why; corrupted parameter fields and
unknown versions are refused with a message naming them.
"""

import struct
import zipfile
import zlib
from pathlib import Path

import numpy as np
import pytest
from fmpy.fmi1 import FMICallException

from conftest import fmu_scene
from old_formats import from_format_3
from sphrom.fmu import layout
from sphrom.fmu.make.build import ensure_binaries
from sphrom.fmu.make.describe import model_description
from sphrom.fmu.run.driver import FMU
from sphrom.fmu.make.package import package_fmu
from sphrom.fmu.make.archive import write_fmu
from sphrom.fmu.resources import unpack
from sphrom.fmu.variables import vr
from sphrom.rom import parametric as par

DATA = Path(__file__).resolve().parent / "data"
K = 6
PROBES = (0.25, 0.5, 0.66)
RANGES = [par.Range("c", 0.05, 0.2), par.Range("d", 5.0, 15.0)]
VR_C, VR_D, VR_AREA, VR_F_PORT = vr("c"), vr("d"), vr("area"), vr("F_port_j", 1)
H = 0.01
C1, D1, C2, D2 = 0.13, 7.5, 0.06, 14.0
BOUND_VRS = [vr(name, j) for name in ("v_probe_j_error_bound", "rho_probe_j_error_bound") for j in (1, 2, 3)]


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    """make(kind, fmi) -> path; kind: frozen / exact (parametric in c and d), d-only (frozen, parametric in d),
    plain (no parameters), ports."""
    folder = tmp_path_factory.mktemp("state-fmus")
    binaries = ensure_binaries()
    made = {}

    def make(kind, fmi=2):
        if (kind, fmi) not in made:
            path = folder / f"{kind}-{fmi}.fmu"
            model = "exact" if kind == "exact" else "frozen"
            vary = {"frozen": RANGES, "exact": RANGES, "d-only": RANGES[1:]}.get(kind, ())
            package_fmu(fmu_scene("forced"), path, k=K, fmi=fmi, probes=PROBES, progress=False, binaries=binaries,
                        model=model, vary=vary,
                        ports=(0.3,) if kind == "ports" else None, bounds=False)
            made[kind, fmi] = path
        return made[kind, fmi]

    return make


def inputs(n, seed=3):
    return np.random.default_rng(seed).normal(0.0, 0.02, n)


def start(s, values):
    """Set the parameters {vr: value}, initialize from the scene's state."""
    vrs = sorted(values)
    s.set_real(vrs, [values[vr] for vr in vrs])
    s.initialize(initial_state_scale=1)


def with_crc(blob: bytes) -> bytes:
    return blob[:-4] + struct.pack("<I", zlib.crc32(blob[:-4]))


def put_double(blob: bytes, offset: int, value: float) -> bytes:
    out = bytearray(blob)
    out[offset:offset + 8] = struct.pack("<d", value)
    return with_crc(bytes(out))


def param_offset(blob: bytes, n_ports=0) -> int:
    """Byte offset of initial_state_scale in a state blob (then c, d; then the ports' block)."""
    return len(blob) - 4 - 8 * (2 * (1 + n_ports) if n_ports else 0) - 24


@pytest.mark.parametrize("fmi", [2, 3])
@pytest.mark.parametrize("kind", ["frozen", "exact"])
def test_state_at_c1_d1_restored_at_c2_d2_continues_as_the_original(fmus, kind, fmi):
    """Instance A runs at (c1, d1) and saves its state; B, set to (c2, d2) and run (its operators and, exact
    model, its exponential cache at (c2, d2)), restores A's state, through a serialized blob too: it reads c1, d1
    and continues bitwise as A, its certified error bounds too.  A fresh, not yet initialized instance restoring
    it does the same."""
    path = fmus(kind, fmi)
    f = inputs(30)
    with FMU(path) as a:
        start(a, {VR_C: C1, VR_D: D1})
        a.run([H] * 15, f[:15])
        state = a.get_state()
        blob = a.serialize(state)
        a.free_state(state)
        original = a.run([H] * 15, f[15:], t0=15 * H)
        bounds = a.get_real(BOUND_VRS)              # the certified bounds' shadow, assembled at (c1, d1)
    assert struct.unpack_from("<I", blob, 8)[0] == layout.STATE_VERSION
    scale, c, d = struct.unpack_from("<3d", blob, param_offset(blob))
    assert (scale, c, d) == (1.0, C1, D1)
    with FMU(path) as b:
        start(b, {VR_C: C2, VR_D: D2})
        b.run([H] * 7, f[:7])
        restored = b.deserialize(blob)
        assert b.serialize(restored) == blob                      # deserialize -> serialize: the same bytes
        b.set_state(restored)
        assert np.array_equal(b.get_real([VR_C, VR_D]), [C1, D1])
        continued = b.run([H] * 15, f[15:], t0=15 * H)
        assert np.array_equal(b.get_real(BOUND_VRS), bounds)   # its planes re-assembled at (c1, d1) too
        b.free_state(restored)
    assert np.array_equal(continued, original)
    with FMU(path) as b:                                       # at B's own (c2, d2) it would have differed
        start(b, {VR_C: C2, VR_D: D2})
        other = b.run([H] * 30, f)
    assert not np.allclose(other[15:], original, rtol=1e-6, atol=0)
    with FMU(path) as fresh:                                   # never initialized: the state brings everything
        fresh.set_real([VR_C, VR_D], [C2, D2])
        fresh.set_state(fresh.deserialize(blob))
        assert np.array_equal(fresh.get_real([VR_C, VR_D]), [C1, D1])
        assert np.array_equal(fresh.run([H] * 15, f[15:], t0=15 * H), original)


@pytest.mark.parametrize("kind", ["frozen", "exact"])
def test_states_round_trip_bitwise_and_fmi2_and_fmi3_blobs_agree(fmus, kind):
    """get -> set and serialize -> deserialize -> serialize are bitwise, FMI 2 and 3, and the two versions' blobs
    of the same run are the same bytes (one state format)."""
    f = inputs(20, seed=5)
    blobs = {}
    for fmi in (2, 3):
        with FMU(fmus(kind, fmi)) as s:
            start(s, {VR_C: C1, VR_D: D1})
            s.run([H] * 10, f[:10])
            state = s.get_state()
            blobs[fmi] = s.serialize(state)
            first = s.run([H] * 10, f[10:], t0=10 * H)
            s.set_state(state)                                    # get -> set: the same run again
            assert np.array_equal(s.run([H] * 10, f[10:], t0=10 * H), first)
            again = s.deserialize(blobs[fmi])
            assert s.serialize(again) == blobs[fmi]
            s.set_state(again)
            assert np.array_equal(s.run([H] * 10, f[10:], t0=10 * H), first)
            s.free_state(state)
            s.free_state(again)
    assert blobs[2] == blobs[3]


@pytest.mark.parametrize("fmi", [2, 3])
def test_port_fmu_state_carries_the_area(fmus, fmi):
    """A port FMU's state carries area (and the held port force): restored in an instance with another area it
    reads the saved one and continues bitwise."""
    path = fmus("ports", fmi)
    f = inputs(20, seed=9)
    with FMU(path) as a:
        start(a, {VR_AREA: 2.5})
        a.set_real([VR_F_PORT], [0.05])
        a.run([H] * 10, f[:10])
        blob = a.serialize(a.get_state())
        original = a.run([H] * 10, f[10:], t0=10 * H)
    with FMU(path) as b:
        start(b, {VR_AREA: 0.4})
        b.run([H] * 3, f[:3])
        b.set_state(b.deserialize(blob))
        assert b.get_real([VR_AREA])[0] == 2.5 and b.get_real([VR_F_PORT])[0] == 0.05
        assert np.array_equal(b.run([H] * 10, f[10:], t0=10 * H), original)
    with FMU(path) as b:                                        # the area matters for these outputs
        start(b, {VR_AREA: 0.4})
        b.set_real([VR_F_PORT], [0.05])
        assert not np.allclose(b.run([H] * 20, f)[10:], original, rtol=1e-6, atol=0)


def stored_fmu(ref, case, fmi, tmp_path):
    """The stored resources of ``case`` (model.bin format 3) rewritten as today's format (the same numbers,
    tests/old_formats.py) and packaged with today's binaries."""
    blob = from_format_3(ref[f"{case}/model_bin"].tobytes())
    data = unpack(blob)
    description = model_description(fmi, token=data.token, scene=fmu_scene("forced"), data=data, k_requested=K,
                                     step_size=H, stop_time=0.5, input_error=float("nan"),
                                     model="exact" if case == "exact" else "frozen")
    binaries = ensure_binaries()
    path = tmp_path / f"{case}-{fmi}.fmu"
    write_fmu(path, fmi=fmi, blob=blob, description=description, binary=binaries.fmi2 if fmi == 2 else binaries.fmi3)
    return path, data.token


@pytest.mark.parametrize("fmi", [2, 3])
@pytest.mark.parametrize("case", ["frozen", "exact", "ports"])
def test_states_of_an_older_format_are_refused_saying_why(tmp_path, case, fmi):
    """A state of format 2 written by the code then carries the token of its FMU, whose model.bin was of an older
    format: the FMU of the same numbers in today's format has another token, so the state can never be its own.
    It is refused naming its version and why, not half-read; a state of today's layout announcing format 3 too."""
    ref = np.load(DATA / "state_v2_reference.npz")
    path, token = stored_fmu(ref, case, fmi, tmp_path)
    blob = ref[f"{case}/state"].tobytes()
    assert struct.unpack_from("<I", blob, 8)[0] == 2
    assert blob[32:72].rstrip(b"\0").decode() != token                  # the token it carries is another FMU's
    why = "a state restores only into the FMU that wrote it"
    text = refused(path, blob)
    assert f"format version 2 is not supported (this binary reads {layout.STATE_VERSION}" in text and why in text
    values = dict(zip(ref[f"{case}/vrs"].tolist(), ref[f"{case}/values"].tolist()))
    current = saved(path, values)
    text = refused(path, with_crc(current[:8] + struct.pack("<I", 3) + current[12:]))
    assert f"format version 3 is not supported (this binary reads {layout.STATE_VERSION}" in text and why in text


def refused(path, blob):
    """The FMU's error messages when deserializing ``blob``."""
    with FMU(path) as s:
        with pytest.raises(FMICallException):
            s.deserialize(blob)
        return " | ".join(s.errors())


def saved(path, values, steps=5):
    with FMU(path) as s:
        start(s, values)
        s.run([H] * steps, inputs(steps))
        return s.serialize(s.get_state())


@pytest.mark.parametrize("kind", ["frozen", "exact"])
def test_corrupted_parameter_fields_are_refused_naming_them(fmus, kind):
    """c or d non-finite or outside the trained range, a non-finite initial_state_scale (each with a valid
    checksum) are refused with a message naming the field and the range; so are unknown versions, naming them."""
    path = fmus(kind)
    blob = saved(path, {VR_C: C1, VR_D: D1})
    at = param_offset(blob)
    for offset, value, text in (
            (at + 8, float("nan"), "parameter c = nan is outside the trained range [0.05, 0.2]"),
            (at + 8, 0.3, "parameter c = 0.3 is outside the trained range [0.05, 0.2]"),
            (at + 16, float("inf"), "parameter d = inf is outside the trained range [5, 15]"),
            (at + 16, 4.0, "parameter d = 4 is outside the trained range [5, 15]"),
            (at, float("nan"), "parameter initial_state_scale = nan is out of range")):
        assert text in refused(path, put_double(blob, offset, value)), text
    for version in (1, 3, layout.STATE_VERSION + 1, 99):
        bad = with_crc(blob[:8] + struct.pack("<I", version) + blob[12:])
        assert f"format version {version} is not supported (this binary reads {layout.STATE_VERSION}" in \
            refused(path, bad)


def test_parameters_a_model_does_not_have_are_refused(fmus):
    """In an FMU without c and d the state's c and d are 0, in one varying d only its c is the scene's; anything
    else is refused naming the field; a port FMU's area must be finite and > 0."""
    plain = fmus("plain")
    blob = saved(plain, {})
    at = param_offset(blob)
    assert struct.unpack_from("<2d", blob, at + 8) == (0.0, 0.0)
    assert "this FMU has no parameter c (expected 0)" in refused(plain, put_double(blob, at + 8, 0.1))
    assert "parameter d = nan, but this FMU has no parameter d" in refused(plain, put_double(blob, at + 16, np.nan))
    d_only = fmus("d-only")                                     # c is the scene's, fixed: not a parameter
    blob = saved(d_only, {VR_D: D1})
    at = param_offset(blob)
    assert struct.unpack_from("<2d", blob, at + 8) == (0.1, D1)
    assert "parameter c = 0.15, but this FMU's c is fixed at 0.1" in refused(d_only, put_double(blob, at + 8, 0.15))
    assert "parameter d = 20 is outside the trained range [5, 15]" in refused(d_only, put_double(blob, at + 16, 20))
    ports = fmus("ports")
    blob = saved(ports, {VR_AREA: 2.5})
    area_at = param_offset(blob, n_ports=1) + 24
    assert struct.unpack_from("<d", blob, area_at)[0] == 2.5
    for value in (0.0, -1.0, float("nan")):
        assert "parameter area = " in refused(ports, put_double(blob, area_at, value))
