"""sphrom installs like any other package: the wheel built from this checkout holds the import package ``sphrom``
and nothing else at the top (no ``harness``), with every subpackage, the built-in scenes, the C sources and the
modelDescription templates; installed (unpacked onto the path of a process started in a folder outside the
checkout) it finds them, gives its version, builds the binaries from its own sources and co-simulates an FMU.

The full job (a fresh venv, the dependencies from PyPI, the README's main job from another folder) runs in .ci/run;
this is what can be checked in seconds.  The wheel is built offline with this environment's setuptools (>= 70.1:
its own bdist_wheel; pyproject's test extra).
"""

import importlib.metadata
import json
import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

import sphrom
from conftest import fmu_scene
from sphrom.fmu.make.build import cmake_sources
from sphrom.fmu.make.package import package_fmu

ROOT = Path(__file__).resolve().parents[1]
# what the build reads: pyproject's package-dir folders and the readme
SOURCES = ("pyproject.toml", "README.md", "harness", "fmu_src", "validation/scenes", "modelDescription")


def _setuptools_version():
    try:
        return tuple(int(p) for p in importlib.metadata.version("setuptools").split(".")[:2])
    except (importlib.metadata.PackageNotFoundError, ValueError):
        return (0, 0)


@pytest.fixture(scope="module")
def wheel(tmp_path_factory):
    """The wheel built from a copy of this checkout's sources (the checkout gets no build/ or egg-info)."""
    if _setuptools_version() < (70, 1):
        pytest.skip("the wheel is built offline with setuptools >= 70.1 (pip install -e '.[test]')")
    tmp = tmp_path_factory.mktemp("wheel")
    src = tmp / "src"
    for name in SOURCES:
        if (ROOT / name).is_dir():
            shutil.copytree(ROOT / name, src / name, ignore=shutil.ignore_patterns("__pycache__"))
        else:
            (src / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(ROOT / name, src / name)
    proc = subprocess.run([sys.executable, "-m", "pip", "wheel", str(src), "--no-deps", "--no-build-isolation",
                           "-w", str(tmp / "dist"), "-q"], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    (path,) = (tmp / "dist").glob("sphrom-*.whl")
    return path


def test_wheel_holds_sphrom_only_with_its_data(wheel):
    names = zipfile.ZipFile(wheel).namelist()
    version = sphrom.__version__
    assert wheel.name.startswith(f"sphrom-{version}-")
    assert {n.split("/")[0] for n in names} == {"sphrom", f"sphrom-{version}.dist-info"}
    # every package of harness/ is in it (a package left out of pyproject's list was missing from installs)
    packages = {p.parent.relative_to(ROOT / "harness") for p in (ROOT / "harness").rglob("__init__.py")}
    for package in packages:
        assert f"{Path('sphrom', package).as_posix()}/__init__.py" in names, f"the wheel lacks sphrom/{package}"
    modules = {p.relative_to(ROOT / "harness").as_posix() for p in (ROOT / "harness").rglob("*.py")}
    assert {f"sphrom/{m}" for m in modules} <= set(names)
    scenes = {p.name for p in (ROOT / "validation" / "scenes").glob("*.toml")}
    assert scenes and {f"sphrom/scenes/{s}" for s in scenes} <= set(names)
    c_files = {name for files in cmake_sources(ROOT / "fmu_src").values() for name in files}
    c_files |= {"CMakeLists.txt", "fmi2_cs.c", "fmi3_cs.c", "sph.c", "sph.h", "tests/load.c"}
    assert {f"sphrom/fmu_src/{c}" for c in c_files} <= set(names)
    templates = {p.name for p in (ROOT / "modelDescription").glob("*.xml")}
    assert templates and {f"sphrom/model_description/{t}" for t in templates} <= set(names)
    with zipfile.ZipFile(wheel) as zf:
        meta = zf.read(f"sphrom-{version}.dist-info/METADATA").decode()
        entry = zf.read(f"sphrom-{version}.dist-info/entry_points.txt").decode()
        top = zf.read(f"sphrom-{version}.dist-info/top_level.txt").decode().split()
    assert f"\nVersion: {version}\n" in meta
    assert "sphrom = sphrom.cli:main" in entry and top == ["sphrom"]


INSTALLED = """
import importlib.metadata, json, os, sys
import sphrom
out = {"file": sphrom.__file__, "version": sphrom.__version__, "metadata": importlib.metadata.version("sphrom")}
try:
    import harness
    out["harness"] = harness.__file__
except ImportError:
    out["harness"] = None
from sphrom.paths import data_dir
out["data"] = [str(data_dir(kind)) for kind in ("scenes", "fmu_src", "model_description")]
out["scene"] = sphrom.load_scene("tenmode").name
from sphrom.fmu.make.build import fmu_binaries
out["platforms"] = fmu_binaries().names
result = sphrom.run_cosim(sys.argv[1], force="1e-3*sin(2*pi*t)", t_end=0.1)
out["rows"] = len(result.values)
import fmpy
out["step"] = float(fmpy.read_model_description(sys.argv[1]).defaultExperiment.stepSize)
print(json.dumps(out))
"""


def test_installed_wheel_runs_from_another_folder(wheel, tmp_path):
    """Unpacked as pip installs it, first on the path of a process started elsewhere (nothing of the checkout on
    its path): it imports as sphrom, finds its data inside itself, builds the binaries from its own sources (the
    same sources: the test session's cache serves them), co-simulates, and ``python -m sphrom`` works."""
    site, elsewhere = tmp_path / "site", tmp_path / "elsewhere"
    with zipfile.ZipFile(wheel) as zf:
        zf.extractall(site)
    elsewhere.mkdir()
    fmu = elsewhere / "forced.fmu"
    package_fmu(fmu_scene("forced"), fmu, k=6, fmi=2, progress=False)
    env = {**os.environ, "PYTHONPATH": str(site)}
    proc = subprocess.run([sys.executable, "-c", INSTALLED, str(fmu)], cwd=elsewhere, env=env, capture_output=True,
                          text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout.splitlines()[-1])
    assert Path(out["file"]) == site / "sphrom" / "__init__.py"
    assert out["version"] == out["metadata"] == sphrom.__version__
    assert out["harness"] is None
    assert [Path(p) for p in out["data"]] == [site / "sphrom" / d for d in ("scenes", "fmu_src", "model_description")]
    assert out["scene"] == "tenmode" and out["platforms"][0] == "linux64"
    assert out["rows"] == round(0.1 / out["step"]) + 1          # t = 0 to 0.1 s at the FMU's default step
    proc = subprocess.run([sys.executable, "-m", "sphrom", "--version"], cwd=elsewhere, env=env, capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 0 and proc.stdout.strip() == f"sphrom {sphrom.__version__}", proc.stdout + proc.stderr
