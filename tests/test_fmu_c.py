"""The FMU's C side: warning-free build, exported symbols, the C test driver
(release and -fsanitize=address,undefined), the core loader's checks, the
resources format, rebuilding from sources/ with fmpy, and the core benchmark.
"""

import concurrent.futures
import json
import os
import re
import shutil
import struct
import subprocess
import sys
import zipfile
import zlib
from pathlib import Path

import fmpy
import numpy as np
import pytest

from conftest import small_scene
from sphrom.fmu.make.build import ensure_binaries
from sphrom.fmu.run.core import Core, CoreError
from sphrom.fmu.run.driver import FMU
from sphrom.fmu.make.package import package_fmu
from sphrom.fmu import layout
from sphrom.fmu.resources import pack, unpack

SCENARIOS = ["basic", "state", "bad", "resources", "cycles", "threads", "edge", "bound"]


@pytest.fixture(scope="session")
def binaries():
    return ensure_binaries()


@pytest.fixture(scope="session")
def packaged(binaries, tmp_path_factory):
    """FMI 2 and 3 FMUs of a forced damped scene and an unforced undamped one, with their resources folders;
    ``exact-forced`` and ``exact-unforced``: the same scenes with the exact linear model (FMI 2 and resources);
    ``parametric``: the exact model of the unforced scene over c and d (its error bounds' planes assembled at
    the parameters)."""
    from sphrom.rom.parametric import Range
    folder = tmp_path_factory.mktemp("c-fmus")
    out = {}
    forced, unforced = small_scene("damped_forced", T=0.5, n=32), small_scene("multimode", T=0.5, n=32)
    vary = [Range("c", 0.05, 0.2), Range("d", 0.0, 5.0)]
    for case, scene, model, versions in (("forced", forced, "frozen", (2, 3)), ("unforced", unforced, "frozen", (2, 3)),
                                         ("exact-forced", forced, "exact", (2,)),
                                         ("exact-unforced", unforced, "exact", (2,)),
                                         ("parametric", unforced, "exact", (2,))):
        for fmi in versions:
            path = folder / f"{case}{fmi}.fmu"
            package_fmu(scene, path, k=6, fmi=fmi, progress=False, binaries=binaries, model=model,
                        vary=vary if case == "parametric" else ())
            out[(case, fmi)] = path
        resources = folder / f"{case}-resources"
        resources.mkdir()
        (resources / "model.bin").write_bytes(zipfile.ZipFile(out[(case, 2)]).read("resources/model.bin"))
        out[(case, "resources")] = resources
    return out


def sanitizers_available(tmp_path):
    src = tmp_path / "probe.c"
    src.write_text("int main(void) { return 0; }\n")
    cc = os.environ.get("CC", "cc")
    if shutil.which(cc) is None:
        return False
    proc = subprocess.run([cc, "-fsanitize=address,undefined", str(src), "-o", str(tmp_path / "probe")],
                          capture_output=True)
    return proc.returncode == 0 and subprocess.run([str(tmp_path / "probe")], capture_output=True).returncode == 0


# ---------------------------------------------------------------------------
# build
# ---------------------------------------------------------------------------

def test_build_is_warning_free_with_werror(binaries):
    commands = json.loads((binaries.folder / "compile_commands.json").read_text())
    sources = {os.path.basename(c["file"]) for c in commands}
    assert {"rom.c", "fmi2_cs.c", "fmi3_cs.c", "driver.c"} <= sources
    for c in commands:
        flags = c.get("command") or " ".join(c["arguments"])
        for flag in ("-Wall", "-Wextra", "-Werror", "-ffp-contract=off"):
            assert flag in flags, (c["file"], flag)
    log = (binaries.folder / "build.log").read_text()
    assert "warning:" not in log and "error:" not in log


def test_only_fmi_functions_are_exported(binaries):
    nm = shutil.which("nm")
    if nm is None:
        pytest.skip("nm not available")
    for library, prefix, count in ((binaries.fmi2, "fmi2", 34), (binaries.fmi3, "fmi3", 75)):
        out = subprocess.run([nm, "-D", "--defined-only", str(library)], capture_output=True, text=True).stdout
        names = [line.split()[-1] for line in out.splitlines() if line.strip()]
        assert names and all(n.startswith(prefix) for n in names), [n for n in names if not n.startswith(prefix)]
        assert len(names) == count


# ---------------------------------------------------------------------------
# the C driver
# ---------------------------------------------------------------------------

def run_driver(driver, resources, scratch, env=None, scenarios=SCENARIOS):
    scratch.mkdir(parents=True, exist_ok=True)
    proc = subprocess.run([str(driver), str(resources), str(scratch), *scenarios], capture_output=True, text=True,
                          env={**os.environ, **(env or {})}, timeout=300)
    return proc.returncode, proc.stdout + proc.stderr


@pytest.mark.parametrize("case", ["forced", "unforced", "exact-forced", "exact-unforced", "parametric"])
def test_c_driver_release(binaries, packaged, tmp_path, case):
    assert binaries.driver is not None
    rc, output = run_driver(binaries.driver, packaged[(case, "resources")], tmp_path / "scratch")
    assert rc == 0, output
    for name in SCENARIOS:
        assert f"scenario {name}: ok" in output


def test_c_driver_under_address_and_undefined_sanitizers(packaged, tmp_path):
    """All scenarios, the bad-input ones and 100 instantiate/free cycles included (the release run makes 1000),
    clean under ASan+UBSan+LSan, for both models (the exact one's exponentials and their cache included) and a
    parametric one (its operators and its error bounds' planes assembled)."""
    if not sanitizers_available(tmp_path):
        pytest.skip("the C compiler cannot build and run -fsanitize=address,undefined programs")
    san = ensure_binaries(sanitize=True)
    assert san.driver is not None
    env = {"ASAN_OPTIONS": "detect_leaks=1:abort_on_error=0:halt_on_error=1:detect_stack_use_after_return=1",
           "UBSAN_OPTIONS": "halt_on_error=1:print_stacktrace=1",
           "SPHROM_DRIVER_NO_TIMING": "1",      # the bound scenario's 10 s answer is timed in the release run
           "SPHROM_DRIVER_CYCLES": "100"}
    cases = ("forced", "unforced", "exact-forced", "exact-unforced", "parametric")
    # five independent processes: run side by side on the machine's cores (the sanitizers make each one slow)
    with concurrent.futures.ThreadPoolExecutor(max_workers=min(len(cases), os.cpu_count() or 1)) as pool:
        runs = pool.map(lambda case: run_driver(san.driver, packaged[(case, "resources")],
                                                tmp_path / f"scratch-{case}", env=env), cases)
    for rc, output in runs:
        assert rc == 0, output
        assert "AddressSanitizer" not in output and "LeakSanitizer" not in output and "runtime error" not in output
        for name in SCENARIOS:
            assert f"scenario {name}: ok" in output


def test_sanitizer_build_catches_a_leak(tmp_path):
    """The leak check is live here (so a clean driver run means something)."""
    if not sanitizers_available(tmp_path):
        pytest.skip("the C compiler cannot build and run -fsanitize=address,undefined programs")
    src = tmp_path / "leak.c"
    src.write_text("#include <stdlib.h>\nvoid *volatile keep;\nint main(void) { keep = malloc(77); keep = 0; "
                   "return 0; }\n")
    subprocess.run([os.environ.get("CC", "cc"), "-fsanitize=address", str(src), "-o", str(tmp_path / "leak")],
                   check=True)
    proc = subprocess.run([str(tmp_path / "leak")], capture_output=True, text=True,
                          env={**os.environ, "ASAN_OPTIONS": "detect_leaks=1"})
    assert proc.returncode != 0 and "LeakSanitizer" in proc.stderr


# ---------------------------------------------------------------------------
# resources format and the core's loader
# ---------------------------------------------------------------------------

def with_crc(body):
    return body + struct.pack("<I", zlib.crc32(body) & 0xFFFFFFFF)


def test_resources_round_trip_and_token(packaged, binaries):
    blob = zipfile.ZipFile(packaged[("forced", 2)]).read("resources/model.bin")
    data = unpack(blob)
    assert re.fullmatch(r"\{[0-9a-f]{8}-[0-9a-f]{4}-[0-9a-f]{4}-[0-9a-f]{4}-[0-9a-f]{12}\}", data.token)
    assert pack(data) == blob                          # deterministic: same numbers, same bytes, same token
    md = fmpy.read_model_description(str(packaged[("forced", 2)]))
    assert md.guid == data.token
    assert fmpy.read_model_description(str(packaged[("forced", 3)])).instantiationToken == data.token
    assert data.D is not None and data.p is not None and data.integrator == "euler"
    # the POD modes hold the uniform force profile to within 1 %, so it is projected, not appended: k_v = k = 6
    assert data.T.shape == (21, 6, 6) and data.Pv.shape == (3, 6)
    core = Core(binaries.core)
    assert core.lib.rom_crc32(blob, len(blob) - 4) == struct.unpack("<I", blob[-4:])[0]
    model = core.load(blob)
    model.close()


def test_core_loader_names_the_problem(packaged, binaries):
    blob = zipfile.ZipFile(packaged[("forced", 2)]).read("resources/model.bin")
    body = blob[:-4]
    core = Core(binaries.core)

    def u32(offset, value, source=body):
        return source[:offset] + struct.pack("<I", value) + source[offset + 4:]

    def f64(offset, value, source=body):
        return source[:offset] + struct.pack("<d", value) + source[offset + 8:]

    at = layout.HEADER.offset
    frozen = lambda name: layout.resource_offset("frozen", name)      # noqa: E731 (the frozen kind's header)
    cases = [
        (b"XXXXXXXX" + blob[8:], "bad magic"),
        (with_crc(u32(8, 5)), "format version 5"),
        (with_crc(u32(8, 3)), "format version 3 is not supported (this binary reads 4; the file was written by an "
                              "older sphrom: package the FMU again)"),
        (with_crc(u32(8, 1)), "format version 1"),
        (with_crc(u32(at("model_kind"), 3)), "model kind 3"),
        (with_crc(u32(at("model_kind"), 2)), "tagged sections"),    # read as the linear kind's body: refused
        (with_crc(u32(frozen("integrator"), 7)), "integrator 7"),
        (with_crc(u32(frozen("n_pairs"), 20)), "n_pairs"),
        (with_crc(u32(at("flags"), 8)), "flag"),
        (with_crc(u32(frozen("n_freeze_default"), 0)), "n_freeze"),
        (with_crc(u32(frozen("reserved"), 1)), "reserved = 1"),
        (with_crc(f64(frozen("dt"), -1.0)), "dt = -1"),
        (with_crc(f64(frozen("dt"), float("nan"))), "dt = nan"),
        (with_crc(f64(frozen("dt"), 1e-12)), "below the smallest internal step"),
        (with_crc(f64(layout.HEADER.size + layout.FROZEN_HEAD.size, float("inf"))), "non-finite"),
        (blob[:layout.HEADER.size + 10] + blob[-44:], "for the model kind's header"),
        (blob[:-1], "bytes"),
        (blob + b"\0", "bytes"),
        (blob[:-5] + bytes([blob[-5] ^ 1]) + blob[-4:], "checksum"),
        (b"", "truncated"),
    ]
    for bad, text in cases:
        with pytest.raises(CoreError, match=re.escape(text)):
            core.load(bad)


def test_core_loader_checks_the_tagged_sections(packaged, binaries):
    """Sections are read by tag: a model written without any loads; an unknown, repeated, malformed or oversized
    section, a count above the limit, and a section cut short are each refused with a message naming it."""
    from sphrom.fmu.resources import pack, unpack
    data = unpack(zipfile.ZipFile(packaged[("forced", 2)]).read("resources/model.bin"))
    data.sections.clear()                       # the packaged envelope's sections removed: a model without any
    blob = pack(data)
    start = len(blob) - 4 - 40 - 4              # the section count (0) before token and checksum
    assert blob[start:start + 4] == struct.pack("<I", 0)
    head, tail = blob[:start], blob[start + 4:-4]
    core = Core(binaries.core)

    def section(tag, rows, cols, values=None):
        values = [0.5] * (rows * cols) if values is None else values
        return tag.ljust(8, b"\0") + struct.pack("<2I", rows, cols) + struct.pack(f"<{len(values)}d", *values)

    def blob_with(*sections, count=None):
        n = len(sections) if count is None else count
        return with_crc(head + struct.pack("<I", n) + b"".join(sections) + tail)

    cases = [
        (blob_with(section(b"NOSUCH", 1, 2)), "unknown tag 'NOSUCH'"),
        (blob_with(section(b"A B", 1, 1)), "printable ASCII"),
        (blob_with(section(b"\0ABC", 1, 1)), "printable ASCII"),
        (blob_with(count=33), "33 tagged sections, more than the 32"),
        (blob_with(section(b"BIG", 1 << 14, 1 << 14, values=[])), "more than the 67108864"),
        (blob_with(section(b"NOSUCH", 4, 4, values=[0.5])), "bytes"),
        (blob_with(section(b"NOSUCH", 1, 1), count=2), "bytes"),
    ]
    for bad, text in cases:
        with pytest.raises(CoreError, match=re.escape(text)):
            core.load(bad)
    assert core.load(blob_with()) is not None


# ---------------------------------------------------------------------------
# rebuilding from sources/ (fmpy compile)
# ---------------------------------------------------------------------------

@pytest.mark.parametrize("fmi", [2, 3])
def test_sources_lists_agree(packaged, fmi):
    """sources/ holds the files of build.fmu_sources, and the build description fmpy compile reads
    (FMI 2: <SourceFiles> of modelDescription.xml, FMI 3: sources/buildDescription.xml) names its C files."""
    from sphrom.fmu.make.build import fmu_sources
    files = fmu_sources(fmi)
    assert all((Path(__file__).parents[1] / "fmu_src" / name).is_file() for name in files)
    zf = zipfile.ZipFile(packaged[("forced", fmi)])
    assert {f"sources/{name}" for name in files} <= set(zf.namelist())
    md = fmpy.read_model_description(str(packaged[("forced", fmi)]))
    compiled = md.buildConfigurations[0].sourceFileSets[0].sourceFiles
    assert compiled == [name for name in files if name.endswith(".c")]
    if fmi == 3:                     # the core calls log2, sin, exp, ...: the build description names libm
        import xml.etree.ElementTree as ET
        build = ET.fromstring(zf.read("sources/buildDescription.xml"))
        assert [lib.get("name") for lib in build.iter("Library")] == ["m"]


@pytest.mark.parametrize("fmi", [2, 3])
def test_fmpy_compile_rebuilds_from_sources(packaged, tmp_path, fmi):
    """A copy without binaries is rebuilt by `fmpy compile` and gives the same outputs."""
    original = packaged[("forced", fmi)]
    copy = tmp_path / f"copy{fmi}.fmu"
    with zipfile.ZipFile(original) as src, zipfile.ZipFile(copy, "w", zipfile.ZIP_DEFLATED) as dst:
        for item in src.infolist():
            if not item.filename.startswith("binaries/"):
                dst.writestr(item, src.read(item.filename))
    proc = subprocess.run([sys.executable, "-m", "fmpy.cli", "compile", str(copy)], capture_output=True, text=True,
                          timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert any(n.startswith("binaries/") for n in zipfile.ZipFile(copy).namelist())
    assert fmpy.validation.validate_fmu(str(copy)) == []
    rng = np.random.default_rng(2)
    steps, inputs = list(rng.uniform(0.3, 40, 25) * 2e-4), rng.normal(0, 0.05, 25)
    outs = []
    for path in (original, copy):
        with FMU(path) as s:
            s.initialize(initial_state_scale=1)
            outs.append(s.run(steps, inputs))
    scale = np.abs(outs[0]).max(axis=0)
    assert np.all(np.abs(outs[0] - outs[1]) <= 1e-12 * scale)


def undefined_symbols(library):
    """The symbols ``ldd -r`` cannot resolve in a shared library loaded on its own (outside Python, which
    has libm loaded already and so hides a missing -lm)."""
    proc = subprocess.run(["ldd", "-r", str(library)], capture_output=True, text=True)
    return re.findall(r"undefined symbol: (\w+)", proc.stdout + proc.stderr)


@pytest.mark.skipif(shutil.which("ldd") is None or shutil.which("cmake") is None, reason="needs ldd and cmake")
@pytest.mark.parametrize("fmi", [2, 3])
def test_rebuild_from_sources_links_the_maths_library(packaged, tmp_path, fmi):
    """fmpy 0.3.32 ignores <Library name="m"/> (its CMake project links no libm), so sources/README.txt gives
    the rebuild with CMAKE_C_STANDARD_LIBRARIES=-lm: that binary resolves every symbol on its own, like the
    binary packaged by sphrom, and gives the packaged binary's outputs."""
    from fmpy.build import build_platform_binary
    folder = tmp_path / "fmu"
    with zipfile.ZipFile(packaged[("forced", fmi)]) as zf:
        zf.extractall(folder)
    shipped = next((folder / "binaries").rglob("sphrom.so"))
    assert undefined_symbols(shipped) == []
    shutil.rmtree(folder / "binaries")
    (tmp_path / "build").mkdir()
    build_platform_binary(folder.resolve(), build_dir=tmp_path / "build",
                          cmake_options={"CMAKE_C_STANDARD_LIBRARIES:STRING": "-lm"})
    rebuilt = next((folder / "binaries").rglob("sphrom.so"))
    assert undefined_symbols(rebuilt) == []
    copy = tmp_path / "rebuilt.fmu"
    shutil.make_archive(str(copy.with_suffix("")), "zip", folder)
    copy.with_suffix(".zip").rename(copy)
    outs = []
    for path in (packaged[("forced", fmi)], copy):
        with FMU(path) as s:
            s.initialize(initial_state_scale=1)
            outs.append(s.run([0.01] * 20, np.linspace(-0.05, 0.05, 20)))
    scale = np.abs(outs[0]).max(axis=0)
    assert np.all(np.abs(outs[0] - outs[1]) <= 1e-12 * scale)


# ---------------------------------------------------------------------------
# the core benchmark (smoke) and the bench-fmu command
# ---------------------------------------------------------------------------

def test_core_benchmark_rows_do_not_depend_on_n(binaries):
    from sphrom.bench.lib.fmu import core_rows
    rows = core_rows("multimode", [48, 96], k=8, n_steps=20_000, repeats=5, core=Core(binaries.core))
    assert [r["n"] for r in rows] == [48, 96]
    for r in rows:
        assert r["k_rho"] == 8 and r["ns_per_step_cpu"] > 0
    # same k, same work: the CPU-time slopes agree within a generous factor (wall slopes carry the preemption
    # noise of a shared 2-core machine; the thread's CPU time is the cost of the work itself)
    assert max(r["ns_per_step_cpu"] for r in rows) < 3 * min(r["ns_per_step_cpu"] for r in rows)


def test_density_at_a_probe_must_stay_positive(packaged, binaries):
    """A state with negative density at the probes is an error at the communication point, naming the time."""
    data = unpack(zipfile.ZipFile(packaged[("forced", 2)]).read("resources/model.bin"))
    data.a_rho0 = -data.a_rho0
    model = Core(binaries.core).load(pack(data))
    with pytest.raises(CoreError, match=r"density at probe 1 \(x/L = 0.25\) is -.* at t = 0.001 s"):
        model.do_step(0.0, 1e-3)
    model.close()


def test_exact_model_names_a_specific_volume_at_or_below_zero(packaged, binaries):
    """J = 1 + e <= 0 at a probe (compression through zero volume) is named as such, not as a NaN density."""
    from sphrom.fmu.resources import pack_exact
    data = unpack(zipfile.ZipFile(packaged[("exact-unforced", 2)]).read("resources/model.bin"))
    row = data.Pe[0, 0]                                    # over the whole z (output rows: the block form) or b
    data.z0 = data.z0.copy()
    data.z0[data.k - row.size:] = -2.0 * row / (row @ row)  # e = -2 at probe 1's first particle
    data.bound = 1e6 * float(np.max(np.abs(data.z0)))
    model = Core(binaries.core).load(pack_exact(data))
    with pytest.raises(CoreError, match=r"specific volume J = 1 \+ e = -.* <= 0 at probe 1 \(x/L = 0.25\) at "
                                        r"t = 1e-06 s: compression beyond the model's range"):
        model.do_step(0.0, 1e-6)
    model.close()


# ---------------------------------------------------------------------------
# the C full SPH (fmu_src/sph.c) against the numba loop it repeats
# ---------------------------------------------------------------------------

NONUNIFORM = {"rho0": "1 + 0.3*sin(2*pi*x/L)", "c": "where(x/L <= 0.5, 0.1, 0.2)", "d": "10*(1 + x/L)",
              "profile": "1 + 0.5*cos(2*pi*x/L)"}


@pytest.mark.parametrize("integrator", ["euler", "symplectic"])
@pytest.mark.parametrize("case", ["damped_forced", "nonuniform", "unforced"])
def test_c_full_sph_repeats_numba_bit_for_bit(binaries, case, integrator):
    """sph.c repeats harness/sph/loops.py operation for operation: the same scene, initial state and
    force values, 2000 steps in C (harness/fmu/run/sph_c.py) and in numba (run_sph) end in the same bits.  Cases:
    damping and force with uniform fields, every field non-uniform (rho0, c, d, profile), and f = d = 0."""
    from sphrom.fmu.run.sph_c import SphC
    from sphrom.sph.solver import METHODS, build_problem, force_values, run_sph, step_count
    if case == "unforced":
        scene = small_scene("multimode", T=0.4, n=48, integrator=integrator)
    else:
        scene = small_scene("damped_forced", T=0.4, n=48, integrator=integrator,
                            **(NONUNIFORM if case == "nonuniform" else {}))
    problem = build_problem(scene)
    uniform = [problem.terms[k] for k in ("uniform_c", "uniform_rho0", "uniform_d", "uniform_profile")]
    assert problem.terms["damping"] == (case != "unforced")
    assert not any(uniform) if case == "nonuniform" else all(uniform)
    n, dt = step_count(scene.T, scene.sph.dt), scene.sph.dt
    assert n == 2000
    # numba: one chunk, so that one set of flags holds for every step as in the one C call
    ref = run_sph(scene, sample_steps=[n], progress=False, problem=problem, chunk_steps=n)
    g = force_values(scene, problem, 0, n, dt, METHODS[integrator])[:, 0]
    assert (np.any(g != 0)) == (case != "unforced")
    v, rho = problem.v0.copy(), problem.rho0.copy()
    SphC(binaries.sph).runner(problem, integrator).advance(v, rho, n, dt, g=g)
    assert v.tobytes() == ref.v[-1].tobytes() and rho.tobytes() == ref.rho[-1].tobytes(), (
        np.abs(v - ref.v[-1]).max(), np.abs(rho - ref.rho[-1]).max())
    assert not np.array_equal(v, problem.v0)          # it moved
