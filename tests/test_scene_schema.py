"""The scene schema: one table (harness/scene_schema.py) that the loader checks with and the documentation page is
generated from; the built-in scenes load exactly as before it; hostile scene files are one line, exit status 2.
"""

import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from sphrom.cli import main
from sphrom.errors import UserError
from sphrom.scene import automatic_lines, builtin_names, load_scene, parse_scene
from sphrom.scene_page import MINIMAL_SCENE, markdown
from sphrom.scene_schema import KEYS, MAX_DEPTH, SCALE, TABLES, accepted_keys, check_nesting

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "user" / "scenes.md"
REGENERATE = "python3 -m sphrom.scene_page --write docs/user/scenes.md"
REFERENCE = Path(__file__).parent / "data" / "scenes_reference.npz"


# ---------------------------------------------------------------------------------------------------------------
# the built-in scenes: every value and every derived setting as main's loader made them
# ---------------------------------------------------------------------------------------------------------------

@pytest.mark.cpu_sensitive
def test_builtin_scenes_load_exactly_as_before_the_schema():
    """tests/data/capture_scenes.py ran with the loader before scenes had defaults (main at 31aafc9); the same
    capture now: every attribute, the cache key and file name, the error and snapshot steps and the FMU's default
    k equal; the field and force values within 4 ulps (numpy's transcendental functions may differ in the last
    bit between CPUs)."""
    sys.path.insert(0, str(Path(__file__).parent / "data"))
    try:
        import capture_scenes
    finally:
        sys.path.pop(0)
    meta, arrays = capture_scenes.capture()
    with np.load(REFERENCE) as ref:
        before = json.loads(str(ref["meta"]))
        assert sorted(before) == builtin_names() == sorted(meta)
        now = json.loads(json.dumps(meta, sort_keys=True))
        for name in before:
            for field in before[name]:
                assert now[name][field] == before[name][field], (name, field)
        assert sorted(ref.files) == sorted(["meta", *arrays])
        for name in arrays:
            a, b = ref[name], arrays[name]
            assert a.shape == b.shape and a.dtype == b.dtype, name
            if a.dtype.kind in "iu":
                np.testing.assert_array_equal(a, b, err_msg=name)
            else:   # 4 ulps, or 4 ulps of the array's largest value (a gaussian's tail: tests/test_expr.py within_ulps)
                scale = np.spacing(np.max(np.abs(a[np.isfinite(a)]), initial=0.0))
                bad = np.abs(a - b) > 4 * np.maximum(np.spacing(np.abs(a)), scale)
                assert not np.any(bad & np.isfinite(a)) and np.array_equal(np.isfinite(a), np.isfinite(b)), name
    for name in builtin_names():
        assert load_scene(name).automatic == () and automatic_lines(load_scene(name)) == []


# ---------------------------------------------------------------------------------------------------------------
# the page and the loader: one table
# ---------------------------------------------------------------------------------------------------------------

def test_the_schema_page_is_generated_from_the_table():
    from sphrom.pod.automatic import automatic_rules
    assert PAGE.read_text(encoding="utf-8") == markdown(automatic_rules()), \
        f"docs/user/scenes.md is stale: regenerate it with `{REGENERATE}`"


def _page_keys():
    """(table, key) of every row of the page's key tables."""
    found, table = [], None
    for line in PAGE.read_text(encoding="utf-8").splitlines():
        heading = re.match(r"### (The top level|`\[\[?([\w.]+)\]\]?`)", line)
        if heading:
            table = heading.group(2) or ""
        elif line.startswith("## ") and table is not None and not line.startswith("## Keys"):
            table = None
        elif table is not None:
            row = re.match(r"\| `(\w+)` \|", line)
            if row:
                found.append(f"{table}.{row.group(1)}" if table else row.group(1))
    return found


def _scene_with(path, value):
    """The minimal scene with the key ``path`` (``paper.runs.dt``) set to ``value`` (and what it needs)."""
    import tomllib

    from sphrom.scene import dump_toml
    data = tomllib.loads(MINIMAL_SCENE)
    examples = {k.path: k.example for k in KEYS}
    table, _, name = path.rpartition(".")
    needs = {"paper": ["paper.reference", "paper.sph_error_v"],
             "paper.runs": ["paper.runs.n_particles", "paper.runs.alpha", "paper.runs.dt", "paper.runs.sph_error_v"],
             "paper.snapshot_studies": ["paper.snapshot_studies.outcome", "paper.snapshot_studies.count",
                                        "paper.snapshot_studies.window"],
             "snapshots": ["snapshots.count", "snapshots.window"]}
    snapshot_kinds = {"times": [], "times_v": ["times_rho"], "times_rho": ["times_v"], "random": ["count", "window"]}
    group = needs.get(table, [])
    if table in ("snapshots", "paper.snapshot_studies") and name in snapshot_kinds:
        group = [p for p in group if p.endswith("outcome")] + [f"{table}.{n}" for n in snapshot_kinds[name]]
    if table.startswith("paper."):
        group += needs["paper"]
    wanted = {p: examples[p] for p in group}
    wanted[path] = value
    for p, v in wanted.items():
        *tables, key = p.split(".")
        node = data
        for i, t in enumerate(tables):
            if ".".join(tables[:i + 1]) in ("paper.runs", "paper.snapshot_studies"):
                node = node.setdefault(t, [{}])[0]
            else:
                node = node.setdefault(t, {})
        node[key] = v
    return dump_toml(data)


def test_the_page_lists_exactly_the_keys_the_loader_accepts():
    """Every documented key loads at its example value (and reaches the scene), every table refuses a key the page
    does not list, naming it, and the page's rows are the loader's keys."""
    assert _page_keys() == accepted_keys()
    assert len(accepted_keys()) == len(set(accepted_keys())) > 40
    for path in accepted_keys():
        k = next(k for k in KEYS if k.path == path)
        scene = parse_scene(_scene_with(path, k.example), "<example>", name="example")
        table, _, name = path.rpartition(".")
        if table in ("sph",):
            assert getattr(scene.sph, name) == k.example, path
        elif table in ("domain",):
            assert getattr(scene, name) == k.example, path
        elif table in ("snapshots", "rom", "paper"):
            assert getattr(scene, table)[name] == k.example, path
        elif table in ("paper.runs", "paper.snapshot_studies"):
            assert scene.paper[table.split(".")[1]][0][name] == k.example, path
        elif table == "":
            assert getattr(scene, name) == k.example, path
    for table in TABLES:
        path = f"{table.name}.no_such_key" if table.name else "no_such_key"
        shown = re.sub(r"^paper\.(runs|snapshot_studies)\.", r"paper.\1[0].", path)
        with pytest.raises(UserError, match=rf"<x>: {re.escape(shown)}: unknown key 'no_such_key' \(allowed: "):
            parse_scene(_scene_with(path, 1), "<x>", name="x")


def test_the_minimal_scene_of_the_page_is_the_one_that_loads():
    block = PAGE.read_text(encoding="utf-8").split("```toml\n")[1].split("```")[0]
    assert block == MINIMAL_SCENE
    assert re.findall(r"^\[(\w+)\]", block, re.M) == ["domain", "fields", "force", "sph"]
    scene = parse_scene(block, "my_bar.toml", name="my_bar")
    assert scene.name == "my_bar" and scene.sph.alpha == 1.04 and scene.sph.integrator == "symplectic"
    assert scene.automatic == ("name", "sph.integrator", "sph.every", "snapshots", "rom.modes") and scene.paper == {}


# ---------------------------------------------------------------------------------------------------------------
# hostile scene files: one line naming the file, the key and the allowed range; exit 2; nothing written
# ---------------------------------------------------------------------------------------------------------------

def _nest(n):
    return "[" * n + "]" * n


HOSTILE = {
    # the parser recursed (RecursionError) on a value nested 2,000 deep
    "deep_array": (MINIMAL_SCENE.replace("[sph]", f"x = {_nest(2000)}\n[sph]"), "x: line 15: nested more than"),
    "deep_inline": ("name = " + "{a = " * 2000 + "1" + "}" * 2000 + "\n" + MINIMAL_SCENE, "name: line 1: nested more"),
    # ZeroDivisionError in the kernel
    "tiny_L": (MINIMAL_SCENE.replace("L = 1.0", "L = 1e-300"), "domain.L: 1e-300 is out of range (allowed: a number "
                                                               "in [1e-15, 1e15])"),
    "huge_T": (MINIMAL_SCENE.replace("T = 0.5", "T = 1e300"), "domain.T: 1e+300 is out of range"),
    "tiny_dt": (MINIMAL_SCENE.replace("dt = 1e-3", "dt = 1e-300"), "sph.dt: 1e-300 is out of range (allowed: dt >= "
                                                                    "T / 1e9"),
    "huge_N": (MINIMAL_SCENE.replace("n_particles = 32", "n_particles = 99999999999999999999"),
               "sph.n_particles: 99999999999999999999 is out of range (allowed: an integer in [8, 10000000])"),
    "huge_alpha": (MINIMAL_SCENE.replace("dt = 1e-3", "dt = 1e-3\nalpha = 7.9"), "sph.alpha: 7.9 is out of range "
                                                                              "(allowed: 0.5 < alpha < N/4"),
    "huge_every": (MINIMAL_SCENE.replace("dt = 1e-3", "dt = 1e-3\nevery = 99999999999999999999"),
                   "sph.every: 99999999999999999999 is out of range (allowed: an integer in [1, 1000000000])"),
    "huge_rho0": (MINIMAL_SCENE.replace('rho0 = "1"', 'rho0 = "1e300"'), "fields.rho0: 1e+300 at x = "),
    "tiny_c": (MINIMAL_SCENE.replace('c = "0.1"', 'c = "1e-300"'), "fields.c: 1e-300 at x = "),
    "huge_v0": (MINIMAL_SCENE.replace('v0 = "1e-3*sin(2*pi*x/L)"', 'v0 = "1e16*sin(2*pi*x/L)"'), "fields.v0: "),
    "negative_d": (MINIMAL_SCENE.replace('d = "0.5"', 'd = "-1"'), "fields.d: -1.0 at x = "),
    "huge_f": (MINIMAL_SCENE.replace('f = "1e-3*cos(2*pi*t)"', 'f = "1e300*cos(2*pi*t)"'),
               "force.f: 1e+300 at t = 0 s"),
    "huge_profile": (MINIMAL_SCENE.replace('f = "1e-3', 'profile = "1e20"\nf = "1e-3'), "force.profile: 1e+20 at x"),
    # h5py refused the name after the run; the name went unescaped into the cache path
    "nul_name": ('name = "\\u0000"\n' + MINIMAL_SCENE, "name: '\\x00' is out of range (allowed: 1 to 64 characters"),
    "slash_name": ('name = "a/b"\n' + MINIMAL_SCENE, "name: 'a/b' is out of range (allowed: 1 to 64 characters"),
    "up_name": ('name = "../../x"\n' + MINIMAL_SCENE, "name: '../../x' is out of range (allowed: 1 to 64 characters"),
    "nul_title": ('title = "a\\u0000b"\n' + MINIMAL_SCENE, "title: 'a\\x00b' is out of range (allowed: at most 1000"),
    # caught only later, as an option error
    "n_freeze_0": (MINIMAL_SCENE + "\n[rom]\nn_freeze = [0]\n", "rom.n_freeze[0]: 0 is out of range (allowed: an "
                                                               "integer in [1, 2147483647])"),
    "n_freeze_neg": (MINIMAL_SCENE + "\n[rom]\nn_freeze = [-1]\n", "rom.n_freeze[0]: -1 is out of range"),
    "accel_0": (MINIMAL_SCENE + "\n[rom]\naccel_modes = [0]\n", "rom.accel_modes[0]: 0 is out of range (allowed: an "
                                                               "integer in [1, 10000000])"),
    "accel_neg": (MINIMAL_SCENE + "\n[rom]\naccel_modes = [-1]\n", "rom.accel_modes[0]: -1 is out of range"),
    "accel_above_N": (MINIMAL_SCENE + "\n[rom]\naccel_modes = [4, 33]\n", "rom.accel_modes[1]: 33 is out of range "
                                                                         "(allowed: an integer in [1, N = 32]"),
    "modes_above_N": (MINIMAL_SCENE + "\n[rom]\nmodes = 33\n", "rom.modes: 33 is out of range"),
    "empty_times": (MINIMAL_SCENE + "\n[snapshots]\ntimes = []\n", "snapshots.times: [] is out of range"),
    "window_backwards": (MINIMAL_SCENE + "\n[snapshots]\ncount = 4\nwindow = [0.3, 0.1]\n",
                         "snapshots.window: [0.3, 0.1] is out of range (allowed: [t0, t1] with 0 <= t0 < t1"),
    "seed_huge": (MINIMAL_SCENE + "\n[snapshots]\ncount = 4\nwindow = [0.0, 0.1]\nrandom = 99999999999999999999\n",
                  "snapshots.random: 99999999999999999999 is out of range"),
    "reference_dx_tiny": (MINIMAL_SCENE + '\n[paper]\nreference = "fd"\nsph_error_v = 0.1\nreference_dx = 1e-300\n',
                          "paper.reference_dx: 1e-300 is out of range (allowed: reference_dx >= L / 1e6"),
    "nested_key_value": (MINIMAL_SCENE.replace("L = 1.0", "L.a.b.c.d.e.f.g.h.i = 1"),
                         "domain.L: expected a number, got {'a': {'b': {...}}} (allowed: a number in [1e-15, 1e15])"),
    "bool_number": (MINIMAL_SCENE.replace("n_particles = 32", "n_particles = true"),
                    "sph.n_particles: expected an integer, got True (allowed: an integer in [8, 10000000])"),
}


@pytest.mark.parametrize("case", sorted(HOSTILE))
def test_hostile_scene_is_one_line_exit_2_nothing_written(tmp_path, capsys, case, monkeypatch):
    text, expected = HOSTILE[case]
    path = tmp_path / "hostile.toml"
    path.write_text(text, encoding="utf-8")
    cache = tmp_path / "cache"
    monkeypatch.setenv("SPHROM_CACHE", str(cache))
    out = tmp_path / "out.h5"
    assert main(["sph", str(path), "--out", str(out), "--quiet"]) == 2
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in captured.err + captured.out, captured.err
    assert f"{path}: " in lines[0] and expected in lines[0] and "allowed" in lines[0], lines[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["hostile.toml"]      # no output, no cache file


def test_hostile_scene_through_the_interpreter_no_traceback(tmp_path):
    """The 2,000-deep value through a fresh interpreter (the recursion limit is the interpreter's own)."""
    path = tmp_path / "deep.toml"
    path.write_text(HOSTILE["deep_array"][0])
    r = subprocess.run([sys.executable, "-m", "sphrom", "pod", str(path), "--out", str(tmp_path / "b.h5")],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "Traceback" not in r.stderr, r.stderr
    assert f"nested more than {MAX_DEPTH} levels deep (allowed: at most {MAX_DEPTH} levels" in r.stderr


def test_nesting_scan_skips_strings_and_comments():
    deep = _nest(MAX_DEPTH + 1)
    check_nesting(f'a = "{deep}"\nb = \'{deep}\'\nc = """\n{deep}\n"""\n# {deep}\nd = \'\'\'{deep}\'\'\'\n', "s")
    check_nesting('a = "\\"[[[[[[[[[[" # not a comment\n', "s")
    check_nesting(f"[[paper.runs]]\nx = {_nest(MAX_DEPTH - 2)}\n", "s")
    with pytest.raises(UserError, match=r"s: b: line 2: nested more than"):
        check_nesting(f'a = "]]]]"\nb = {deep}\n', "s")


def test_a_name_is_safe_in_the_cache_path(tmp_path):
    from sphrom.cache import run_file_name, run_key
    scene = load_scene("multimode")
    assert run_file_name(scene) == f"sph-multimode-{run_key(scene)}.h5"
    import dataclasses
    for name, shown in (("../../x", "_._.._x"), ("a/b", "a_b"), ("\x00", "_"), (".hidden", "_hidden")):
        file = run_file_name(dataclasses.replace(scene, name=name))
        assert file == f"sph-{shown}-{run_key(scene)}.h5" and "/" not in file and "\x00" not in file


def test_the_name_from_a_file_name_that_is_not_a_name(tmp_path):
    path = tmp_path / "my bar.toml"
    path.write_text(MINIMAL_SCENE)
    with pytest.raises(UserError, match=r"name: 'my bar' \(the file name\) is out of range \(allowed: 1 to 64 "
                                        r"characters.*give name = "):
        load_scene(path)
    path.write_text('name = "my_bar"\n' + MINIMAL_SCENE)
    assert load_scene(path).name == "my_bar" and load_scene(path).automatic[0] != "name"


# ---------------------------------------------------------------------------------------------------------------
# the bounds: float64 holds the physics at both ends (the equations are invariant under a change of units)
# ---------------------------------------------------------------------------------------------------------------

def _scaled(s, r):
    """The minimal scene in units where lengths and times are s times larger and densities and stiffness r times
    (same wave speed, same velocities; d and f scale as 1/s)."""
    text = (MINIMAL_SCENE.replace("L = 1.0", f"L = {1.0 * s!r}").replace("T = 0.5", f"T = {0.5 * s!r}")
            .replace("dt = 1e-3", f"dt = {1e-3 * s!r}").replace('rho0 = "1"', f'rho0 = "{1.0 * r!r}"')
            .replace('c = "0.1"', f'c = "{0.1 * r!r}"').replace('d = "0.5"', f'd = "{0.5 / s!r}"')
            .replace('f = "1e-3*cos(2*pi*t)"', f'f = "{1e-3 / s!r}*cos(2*pi*t/{1.0 * s!r})"'))
    return parse_scene(text, f"<scaled {s:g}>", name="scaled")


@pytest.mark.parametrize("s, r", [(1e-14, 1e14), (1e14, 1e-14), (1e-14, 1e-14), (1e14, 1e14)])
def test_the_ends_of_the_ranges_run_the_same_physics(s, r):
    """At L = 1e-14 m or 1e14 m with rho0 and c 1e14 times larger or smaller (inside the bounds of 1e-15 and 1e15)
    the full SPH gives the same velocities (and densities times r) as at L = 1 m, to 1e-9 relative: no overflow,
    no underflow, no division by an underflowed h^2 (L = 1e-300 raised ZeroDivisionError)."""
    from sphrom.sph.solver import run_sph
    base, scene = _scaled(1.0, 1.0), _scaled(s, r)
    assert scene.sph.every == base.sph.every and scene.snapshots["count"] == base.snapshots["count"]
    a, b = run_sph(base, progress=False), run_sph(scene, progress=False)
    assert np.all(np.isfinite(b.v)) and np.all(np.isfinite(b.rho))
    np.testing.assert_allclose(b.t / s, a.t, rtol=1e-12)
    np.testing.assert_allclose(b.v, a.v, rtol=0, atol=1e-9 * np.abs(a.v).max())
    np.testing.assert_allclose(b.rho / r, a.rho, rtol=1e-9)


def test_the_scale_bound_is_the_same_for_every_physical_number():
    physical = [k for k in KEYS if k.path in ("domain.L", "domain.T", "fields.rho0", "fields.c", "fields.v0",
                                              "fields.d", "force.f", "force.profile")]
    assert len(physical) == 8
    assert all(max(abs(k.range.lo), abs(k.range.hi)) == SCALE for k in physical)
    assert all(k.why for k in KEYS), [k.path for k in KEYS if not k.why]
