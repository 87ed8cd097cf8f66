"""Hostile options: each case that gave a traceback or was accepted without a word (a hostile-input battery
found them).

Every one is now exit 2, exactly one line naming the option and what is allowed, no traceback, no output file
(and no numpy RuntimeWarning before the line).
"""

import math
import sys
import warnings

import pytest

from sphrom.cli import main
from sphrom.errors import exact


def refused(capsys, argv, *words, out=None):
    with warnings.catch_warnings():
        warnings.simplefilter("error")                 # a RuntimeWarning before the line fails the test
        code = main(argv)
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "Traceback" not in err[0], (code, err)
    for word in words:
        assert word in err[0], err[0]
    if out is not None:
        assert not out.exists()
    return err[0]


@pytest.mark.parametrize("value, expect", [("99999999999999999999", "at most 2^63 - 1"),
                                           (str(2**63), "at most 2^63 - 1"),
                                           (str(2**62), "allowed: an integer in [1, 1000000000]"),   # the scene schema's bound
                                           ("1001", "allowed: 1 to 1000")])
def test_sph_every(hostile_scene, tmp_path, capsys, value, expect):
    """99999999999999999999 ran the whole simulation and failed in h5py (object dtype); 2^63 was accepted."""
    out = tmp_path / "o.h5"
    refused(capsys, ["sph", str(hostile_scene), "--every", value, "--out", str(out), "--quiet"], "--every", expect,
            out=out)
    assert main(["sph", str(hostile_scene), "--every", "1000", "--out", str(out), "--quiet"]) == 0     # all the steps


@pytest.mark.parametrize("value", ["99999999999999999999", str(2**31)])
def test_rom_n_freeze_beyond_the_fmu_integer(hostile_scene, hostile_basis, tmp_path, capsys, value):
    """99999999999999999999 was a numba typing error; n_freeze is an FMI Integer (32 bits) everywhere."""
    out = tmp_path / "o.h5"
    refused(capsys, ["rom", str(hostile_scene), "--basis", str(hostile_basis), "--model", "frozen", "--n-freeze", value,
                     "--out", str(out), "--quiet"], "--n-freeze", "[1, 2147483647]", out=out)


@pytest.mark.parametrize("step, expect", [("1e-12", "allowed: T / 1e+06"), ("1e-300", "1e-300 is out of range"),
                                          ("0.3", "step <= T = 0.2 s")])
def test_rom_step_is_bounded(hostile_scene, hostile_basis, tmp_path, capsys, step, expect):
    """--step 1e-12 asked for 1.46 TiB, 1e-300 was a ValueError; at most 1e6 communication steps now."""
    out = tmp_path / "o.h5"
    refused(capsys, ["rom", str(hostile_scene), "--basis", str(hostile_basis), "--model", "exact", "--step", step,
                     "--out", str(out), "--quiet"], "--step", expect, out=out)
    refused(capsys, ["rom", str(hostile_scene), "--model", "balanced", "--modes", "4", "--step", step, "--out",
                     str(out), "--quiet"], "--step", out=out)


def test_rom_step_applies_to_linear_models_only(hostile_scene, hostile_basis, tmp_path, capsys):
    out = tmp_path / "o.h5"
    refused(capsys, ["rom", str(hostile_scene), "--basis", str(hostile_basis), "--model", "frozen", "--step", "0.01",
                     "--out", str(out), "--quiet"], "--step", "linear models", out=out)


@pytest.mark.parametrize("probes, expect", [("0.5,0.5", "0.5 is given twice"), ("1.0", "1.0 in '1.0' is out of range"),
                                            ("0.25,1", "numbers in [0, 1)")])
def test_fmu_probes_distinct_inside_the_period(hostile_scene, tmp_path, capsys, probes, expect):
    """x/L = 1 is x = 0 on the periodic bar (the FMU's probe rows wrap): the same output twice."""
    out = tmp_path / "o.fmu"
    refused(capsys, ["fmu", str(hostile_scene), "--probes", probes, "--out", str(out), "--quiet"], "--probes", expect,
            out=out)


def test_sweep_probes_distinct_inside_the_period(tmp_path, capsys):
    spec = tmp_path / "spec.toml"
    for probes, expect in (("[0.5, 0.5]", "gives a position twice"), ("[1.0]", "in [0, 1)")):
        spec.write_text(f'scene = "multimode"\nt_end = 0.1\nstep = 0.01\nprobes = {probes}\n'
                        '[grid]\namplitude = [0.01]\n')
        refused(capsys, ["sweep", str(spec), "--out", str(tmp_path / "r.h5"), "--quiet"], "probes", expect)


def test_fmu_vary_subnormal(hostile_scene, tmp_path, capsys):
    """c = 1e-320 is a subnormal double (9.99989e-321): it keeps three of its sixteen digits."""
    out = tmp_path / "o.fmu"
    refused(capsys, ["fmu", str(hostile_scene), "--vary", "c=1e-320:1e-300", "--out", str(out), "--quiet"], "--vary",
            "1e-320", "smallest normal number", out=out)


def test_fmu_ports_closer_than_a_particle_spacing(hostile_scene, tmp_path, capsys):
    """Two ports 1e-11 L apart push the same particles with the same kernel weights: the second port's profile
    was inside the first one's span to 3e-10 and the model could not tell them apart."""
    out = tmp_path / "o.fmu"
    line = refused(capsys, ["fmu", str(hostile_scene), "--model", "exact", "--ports", "0.3,0.30000000001", "--out",
                            str(out), "--quiet"], "--ports", "0.3 and 0.30000000001", "1/N = 1/32 L", out=out)
    assert "kernel" in line
    # across the period's seam as well: 0.99 and 0.005 are 0.015 L apart, under 1/32
    refused(capsys, ["fmu", str(hostile_scene), "--model", "exact", "--ports", "0.99,0.005", "--out", str(out),
                     "--quiet"],
            "--ports", "closer than one particle spacing", out=out)


@pytest.mark.parametrize("text, expect", [
    ("time,f\n0,1\n0.1,2\n0.1,3\n0.2,1\n", "data row 3 repeats t = 0.1 s"),
    ("time,f\n0,1\n0.2,2\n0.1,3\n", "data row 3 goes back to t = 0.1 s"),
    ("time,f,g\n0,1,1\n0.2,2,2\n", "has the columns time,f,g (allowed: exactly time,f)"),
    ("time,f\n0,1,5\n0.2,2\n", "data row 1 has 3 values"),
    ("time,f\n0,1e308\n0.1,-1e308\n0.2,1e308\n", "its slope df/dt overflows"),
])
def test_force_csv(hostile_fmu, tmp_path, capsys, text, expect):
    csv = tmp_path / "force.csv"
    csv.write_text(text)
    out = tmp_path / "o.csv"
    refused(capsys, ["cosim", str(hostile_fmu), "--force", str(csv), "--out", str(out)], "--force", expect, out=out)
    refused(capsys, ["cosim", str(hostile_fmu), "--force", str(csv), "--hold-inputs", "--out", str(out)], "--force",
            out=out)


def test_force_expression_whose_slope_overflows(hostile_fmu, tmp_path, capsys):
    out = tmp_path / "o.csv"
    refused(capsys, ["cosim", str(hostile_fmu), "--force", "1e308*(-1)**floor(t/0.01)", "--out", str(out)], "--force",
            "slope df/dt overflows", out=out)


@pytest.mark.parametrize("argv, option", [(["bench-sph", "--repeats", "1001"], "--repeats"),
                                          (["bench-fmu", "--repeats", "10000"], "--repeats"),
                                          (["validate", "multimode", "--repeats", str(2**64)], "--repeats")])
def test_repeats_are_bounded(tmp_path, capsys, argv, option):
    refused(capsys, [*argv, "--out", str(tmp_path / "d")], option)


def test_exact_never_rounds_onto_a_bound():
    """A range error printed c = 0.2000001 as "c = 0.2 is outside [0.05, 0.2]"."""
    assert exact(0.2) == "0.2" and exact(0.05) == "0.05" and exact(1e-300) == "1e-300" and exact(2.0) == "2"
    assert exact(1e-320) == "1e-320"                   # %g would say 9.99989e-321
    assert exact(0.2000001) == "0.2000001" and float(exact(0.2000001)) == 0.2000001
    assert exact(0.30000000001) == "0.30000000001"
    for value in (math.pi, 1 / 3, 5e-324, sys.float_info.max, -2.5e-8):
        assert float(exact(value)) == value


def test_sweep_range_error_keeps_the_digits(tmp_path, capsys):
    spec = tmp_path / "spec.toml"
    spec.write_text('scene = "multimode"\nt_end = 0.1\nstep = 0.01\n[parametric]\nc = [0.05, 0.2000001]\n'
                    '[grid]\nc = [0.2000002]\namplitude = [0.01]\nfrequency = [1.0]\n')
    refused(capsys, ["sweep", str(spec), "--out", str(tmp_path / "r.h5"), "--quiet"],
            "0.2000002 is outside the parametric range [0.05, 0.2000001]")
    spec.write_text('scene = "multimode"\nt_end = 0.1\nstep = 0.01\n[parametric]\nc = [1e-320, 0.2]\n'
                    '[grid]\nc = [0.1]\namplitude = [0.01]\nfrequency = [1.0]\n')
    refused(capsys, ["sweep", str(spec), "--out", str(tmp_path / "r.h5"), "--quiet"], "parametric.c", "normal number")
