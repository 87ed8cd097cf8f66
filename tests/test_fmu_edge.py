"""FMU edge cases through fmpy, FMI 2 and 3: an internal step dt far above the
communication step h is one step of length h (warned once, never a no-op), a
serialized state of other sizes names the field, an unknown log category is a
warning that leaves the instance usable.
"""

import struct

import numpy as np
import pytest
from fmpy.fmi1 import FMICallException

from conftest import fmu_scene
from sphrom.fmu.make.build import ensure_binaries
from sphrom.fmu.run.driver import FMU
from sphrom.fmu.make.package import package_fmu

H = 0.01


@pytest.fixture(scope="session")
def edge_fmus(tmp_path_factory):
    binaries = ensure_binaries()
    folder = tmp_path_factory.mktemp("edge-fmus")
    made = {}

    def make(fmi, k=6):
        if (fmi, k) not in made:
            path = folder / f"forced-fmi{fmi}-k{k}.fmu"
            package_fmu(fmu_scene("forced"), path, k=k, fmi=fmi, probes=(0.25, 0.5, 0.66), progress=False,
                        binaries=binaries)
            made[(fmi, k)] = path
        return made[(fmi, k)]

    return make


def warnings_of(slave):
    return [text for status, _, text in slave.messages if status == 1]


@pytest.mark.parametrize("fmi", [2, 3])
@pytest.mark.parametrize("factor", [1e9, 1e12, 3.0])
def test_dt_above_the_communication_step_is_one_step_of_h(edge_fmus, fmi, factor):
    """dt = factor h: each doStep is one internal step of length h, equal to a run with dt = h, warned once."""
    path = edge_fmus(fmi)
    steps, inputs = [H] * 4, [0.0125, -0.005, 0.0075, 0.0025]   # inside the training envelope: only the dt warning
    runs = {}
    for name, dt in (("big", factor * H), ("same", H)):          # one after the other: fmpy's FMI 2 log proxy is
        with FMU(path) as s:                                    # one per process
            # error_tolerance 0: the error bound's warning (a dt of h is far from the scene's) is not this test's
            s.initialize(dt=dt, initial_state_scale=1, error_tolerance=0.0)
            runs[name] = (s.run(steps, inputs), s.time(), warnings_of(s), s.messages)
    (out_big, t_big, warn_big, messages), (out_same, _, warn_same, _) = runs["big"], runs["same"]
    assert np.all(np.any(out_big[1:] != out_big[:-1], axis=1)), "a step left the outputs untouched"
    assert np.array_equal(out_big, out_same)
    assert t_big == pytest.approx(4 * H, rel=1e-15)
    warned = [w for w in warn_big if "larger than the communication step" in w]
    assert len(warned) == 1, messages
    assert f"dt = {factor * H:g} s" in warned[0] and f"h = {H:g} s" in warned[0] and "t = 0 s" in warned[0]
    assert not warn_same


@pytest.mark.parametrize("fmi", [2, 3])
def test_state_of_other_sizes_names_the_field(edge_fmus, fmi):
    with FMU(edge_fmus(fmi, k=5)) as s:
        s.initialize(initial_state_scale=1)
        s.do_step(0.0, H)
        blob = s.serialize(s.get_state())
    k_v_theirs = struct.unpack_from("<I", blob, 16)[0]
    with FMU(edge_fmus(fmi)) as o:
        o.initialize(initial_state_scale=1)
        k_v_mine = struct.unpack_from("<I", o.serialize(o.get_state()), 16)[0]
        assert k_v_mine != k_v_theirs
        with pytest.raises(FMICallException):
            o.deserialize(blob)
        assert any(f"k_v is {k_v_theirs} in the state, {k_v_mine} in this FMU" in e for e in o.errors()), o.errors()


@pytest.mark.parametrize("fmi", [2, 3])
def test_unknown_log_category_is_a_warning(edge_fmus, fmi):
    with FMU(edge_fmus(fmi)) as s:
        s.fmu.setDebugLogging(True, ["logBogus", "logEvents"])
        assert not s.errors()
        (text,) = warnings_of(s)
        assert "'logBogus'" in text and "logEvents, logStatusWarning, logStatusError" in text
        s.initialize(initial_state_scale=1)
        s.do_step(0.0, H)                                      # still usable, and logEvents was honoured
        assert any(cat == "logEvents" for _, cat, _ in s.messages)


# ---------------------------------------------------------------------------
# sphrom cosim: a bad FMU or force CSV is one line on stderr, exit 2, no output file
# ---------------------------------------------------------------------------

def corrupted_copy(path, folder):
    """A copy of the FMU with one byte of resources/model.bin flipped."""
    import zipfile
    bad = folder / f"corrupt-{path.name}"
    with zipfile.ZipFile(path) as src, zipfile.ZipFile(bad, "w") as dst:
        for info in src.infolist():
            data = src.read(info.filename)
            if info.filename == "resources/model.bin":
                data = data[:200] + bytes([data[200] ^ 1]) + data[201:]
            dst.writestr(info, data)
    return bad


def one_error_line(capsys):
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    return lines[0]


@pytest.mark.parametrize("fmi", [2, 3])
def test_cosim_fmu_that_fails_to_instantiate(edge_fmus, tmp_path, capsys, fmi):
    from sphrom.cli import main
    bad, out = corrupted_copy(edge_fmus(fmi), tmp_path), tmp_path / "result.csv"
    for extra in ([], ["--force", "0.01*t"]):
        assert main(["cosim", str(bad), "--t-end", "0.05", "--out", str(out)] + extra) == 2
        line = one_error_line(capsys)
        assert line.startswith("sphrom cosim: error: FILE.fmu: ") and "cannot be instantiated" in line
        assert "checksum mismatch" in line                        # the FMU's own logged reason
        import re
        from pathlib import Path
        extracted = re.search(r"cannot load the model: '(.*)/resources/model\.bin'", line)
        assert extracted and not Path(extracted.group(1)).exists()   # no extracted folder left behind
        assert not out.exists() and not list(tmp_path.glob("result*"))


def test_cosim_force_csv_must_cover_the_run(edge_fmus, tmp_path, capsys):
    from sphrom.cli import main
    out = tmp_path / "result.csv"
    cases = {
        "one row": ("time,f\n0,0.01\n", "has 1 row"),
        "short": ("time,f\n0,0.01\n0.02,0.0\n", "covers [0, 0.02] s, not [0, 0.05] s"),
        "late start": ("time,f\n0.01,0.01\n0.1,0.0\n", "covers [0.01, 0.1] s, not [0, 0.05] s"),
        "negative": ("time,f\n-2,0.01\n-1,0.0\n", "only negative times"),
    }
    for name, (text, expected) in cases.items():
        csv = tmp_path / f"{name.replace(' ', '_')}.csv"
        csv.write_text(text)
        assert main(["cosim", str(edge_fmus(2)), "--force", str(csv), "--t-end", "0.05", "--step", "0.01",
                     "--out", str(out)]) == 2, name
        line = one_error_line(capsys)
        assert line.startswith("sphrom cosim: error: --force: ") and expected in line, (name, line)
        assert "allowed: at least two rows whose times cover [0, 0.05] s" in line
        assert not out.exists()
    csv = tmp_path / "covering.csv"                               # the boundary: exactly [0, t_end] is fine
    csv.write_text("time,f\n0,0.01\n0.05,0.0\n")
    assert main(["cosim", str(edge_fmus(2)), "--force", str(csv), "--t-end", "0.05", "--step", "0.01",
                 "--out", str(out)]) == 0
    assert out.exists()
