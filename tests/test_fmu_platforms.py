"""Every FMU carries the linux64 and the win64 binary (FMI 3: x86_64-linux, x86_64-windows), and the win64 one,
cross-compiled with MinGW-w64 and run under wine by the C loader fmu_src/tests/load.c, gives the linux64 one's
outputs bit for bit (tests/platforms.py drives both alike: a seeded input sequence, the scene's initial state).

Tolerance: bitwise (0 differing bits) is what is measured on every FMU here, and asserted for the serialized FMU
state; the outputs are asserted within TOLERANCE relative to each output's largest |value| (the bound asked for; the
C maths library's sin, cos, exp may differ by an ulp between glibc and MinGW's runtime), and the count of
differing output values is printed.  Skipped, saying what to install, where MinGW-w64 or wine is missing.
"""

import shutil
import subprocess
import zipfile

import pytest

from conftest import fmu_scene
from platforms import Wine, compare, runner
from sphrom.fmu.make import build
from sphrom.fmu.make.build import WIN64, ensure_binaries, ensure_cross_binaries, fmu_binaries
from sphrom.fmu.make.package import package_fmu
from sphrom.rom.parametric import parse_vary

TOLERANCE = 1e-12        # relative to each output's largest |value| over the run

# name -> (scene case, package_fmu options, FMI versions): every FMU model kind in both FMI versions, the linear
# model without damping (its free response through sin and cos), ports (inputs F_port_j) and a parametric FMU
CASES = {"frozen": ("forced", dict(model="frozen"), (2, 3)),
         "exact": ("forced", dict(model="exact"), (2, 3)),
         "balanced": ("forced", dict(model="balanced"), (2,)),
         "exact-undamped": ("unforced", dict(model="exact"), (2,)),
         "ports": ("forced", dict(model="exact", ports=[0.3, 0.7]), (3,)),
         "parametric": ("forced", dict(model="frozen", vary=[parse_vary("c=0.05:0.2"), parse_vary("d=5:15")]), (2,))}
RUNS = [(name, fmi) for name, (_, _, versions) in CASES.items() for fmi in versions]


@pytest.fixture(scope="module")
def win64():
    """The win64 build (binaries and loader) and wine; the test is skipped, saying what to install, without."""
    if shutil.which(WIN64.compiler) is None:
        pytest.skip(f"no win64 binaries: {WIN64.compiler} not found (install {WIN64.install})")
    cross = ensure_cross_binaries(WIN64)
    if runner() is None or shutil.which("winepath") is None:
        pytest.skip(f"the win64 binaries are not run: wine not found (install {WIN64.runner_install})")
    return cross


@pytest.fixture(scope="module")
def wine(win64, tmp_path_factory):
    """wine with a prefix of the module's own, its server up for the module (tests/platforms.py Wine)."""
    with Wine(tmp_path_factory.mktemp("wine-prefix")) as session:
        yield session


@pytest.fixture(scope="module")
def tally():
    """The comparisons of the module, summed up at its end (shown with ``pytest -s``)."""
    results = []
    yield results
    if results:
        worst = max(r.max_relative() for r in results)
        print(f"\nwin64 under wine against linux64: {sum(r.n_values for r in results)} output values of "
              f"{len(results)} FMUs, {sum(r.n_different for r in results)} differ in their bits, largest relative "
              f"difference {worst:.3g}; serialized states equal in "
              f"{sum(r.linux.state == r.windows.state for r in results)} of {len(results)}")


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    folder = tmp_path_factory.mktemp("platform-fmus")
    made = {}

    def make(name, fmi):
        if (name, fmi) not in made:
            case, options, _ = CASES[name]
            path = folder / f"{name}-fmi{fmi}.fmu"
            made[name, fmi] = package_fmu(fmu_scene(case), path, k=6, fmi=fmi, progress=False,
                                          binaries=ensure_binaries(), **options)
        return made[name, fmi]

    return make


@pytest.mark.parametrize("name, fmi", RUNS)
def test_win64_binary_under_wine_equals_linux64(win64, wine, fmus, tally, tmp_path, name, fmi):
    summary = fmus(name, fmi)
    names = zipfile.ZipFile(summary.path).namelist()
    folders = ("linux64", "win64") if fmi == 2 else ("x86_64-linux", "x86_64-windows")
    assert f"binaries/{folders[0]}/sphrom.so" in names and f"binaries/{folders[1]}/sphrom.dll" in names
    assert summary.platforms.startswith("linux64") and "win64 (x86-64 Windows" in summary.platforms
    assert summary.missing_platforms == []
    result = compare(summary.path, ensure_binaries().loader, win64.loader, tmp_path, wine)
    print(result.line())
    tally.append(result)
    assert len(result.linux.words) == len(result.windows.words) > 0
    # both ran the same steps (the time column is bitwise the same sum)
    assert (result.linux.words[:, 0] == result.windows.words[:, 0]).all()
    assert result.max_relative() <= TOLERANCE, result.line()
    assert result.linux.state == result.windows.state and result.linux.state


def test_win64_dll_needs_only_windows_and_exports_only_fmi(win64):
    """The DLLs import only what Windows has (KERNEL32.dll, msvcrt.dll: libgcc linked in) and export only the
    FMI functions (34 FMI 2, 75 FMI 3, the counts of the linux64 binaries in test_fmu_c.py)."""
    objdump = shutil.which("x86_64-w64-mingw32-objdump")
    if objdump is None:
        pytest.skip("x86_64-w64-mingw32-objdump not found (binutils-mingw-w64-x86-64)")
    for library, prefix, count in ((win64.fmi2, "fmi2", 34), (win64.fmi3, "fmi3", 75)):
        text = subprocess.run([objdump, "-p", str(library)], capture_output=True, text=True, check=True).stdout
        imports = {line.split(":", 1)[1].strip() for line in text.splitlines() if "DLL Name:" in line}
        assert imports <= {"KERNEL32.dll", "msvcrt.dll"}, imports
        table = text.split("[Ordinal/Name Pointer] Table", 1)[1].split("\n\n", 1)[0]
        exported = [line.split()[-1] for line in table.splitlines() if line.strip().startswith("[")]
        assert exported and all(n.startswith(prefix) for n in exported), exported
        assert len(exported) == count


def test_cross_build_is_warning_free_with_werror(win64):
    log = (win64.fmi2.parents[1] / "build.log").read_text()
    assert "-Werror" in (win64.fmi2.parents[1] / "compile_commands.json").read_text()
    assert "warning:" not in log and "error:" not in log


def test_a_missing_cross_compiler_is_one_line_and_the_fmu_carries_this_platform(tmp_path, monkeypatch):
    """Without the compiler, the platform is named in one line with what to install, the FMU is packaged with
    this platform's binary, and its page says which it carries and which not."""
    absent = build.Platform("win64", "x86-64 Windows", ("win64", "x86_64-windows"), compiler="sphrom-no-such-gcc",
                            install="MinGW-w64, e.g. apt-get install gcc-mingw-w64-x86-64", library=".dll")
    monkeypatch.setattr(build, "CROSS", (absent,))
    carried = fmu_binaries(ensure_binaries())
    assert carried.names == ["linux64"]
    assert carried.missing_lines() == ["no win64 binary (x86-64 Windows): sphrom-no-such-gcc not found on PATH "
                                       "(install MinGW-w64, e.g. apt-get install gcc-mingw-w64-x86-64)"]
    path = tmp_path / "one.fmu"
    summary = package_fmu(fmu_scene("forced"), path, k=6, fmi=3, progress=False, binaries=ensure_binaries())
    assert summary.missing_platforms == carried.missing_lines()
    with zipfile.ZipFile(path) as zf:
        assert [n for n in zf.namelist() if n.startswith("binaries/")] == ["binaries/x86_64-linux/sphrom.so"]
        page = zf.read("documentation/index.html").decode()
    assert "<h2>Platforms</h2>" in page and "binaries/x86_64-linux" in page
    assert "Packaged without: no win64 binary" in page


def test_a_failed_cross_build_names_its_log_and_is_not_retried(tmp_path, monkeypatch):
    """A cross compiler that is there but fails leaves the platform out with the log's path, once per sources and
    compiler: the next packaging does not try again."""
    fake = tmp_path / "bin" / "sphrom-broken-gcc"
    fake.parent.mkdir()
    fake.write_text("#!/bin/sh\nif [ \"$1\" = --version ]; then echo 'broken 1.0'; exit 0; fi\necho 'no' >&2; exit 1\n")
    fake.chmod(0o755)
    monkeypatch.setenv("PATH", f"{fake.parent}:{__import__('os').environ['PATH']}")
    broken = build.Platform("win64", "x86-64 Windows", ("win64", "x86_64-windows"), compiler=fake.name,
                            cmake=("-DCMAKE_SYSTEM_NAME=Windows",), library=".dll")
    with pytest.raises(build.PlatformUnavailable, match=r"failed \(log: .*\.failed\.log\)") as first:
        ensure_cross_binaries(broken, cache_root=tmp_path / "cache")
    log = next((tmp_path / "cache").glob("win64-*.failed.log"))
    assert "sphrom-broken-gcc" in log.read_text()
    with pytest.raises(build.PlatformUnavailable) as again:
        ensure_cross_binaries(broken, cache_root=tmp_path / "cache")
    assert str(log) in str(again.value) and str(log) in str(first.value)
