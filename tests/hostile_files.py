"""The small files the hostile-input tests run on, made through the command line once per session: a scene
(damped_forced, N = 32, T = 0.2), its POD basis and a frozen FMI 2 FMU (not measured).  Imported as fixtures by
tests/test_hostile_io.py and tests/test_hostile_options.py."""

import pytest

from conftest import small_scene
from harness.cli import main


@pytest.fixture(scope="session")
def scene(tmp_path_factory):
    path = tmp_path_factory.mktemp("scene") / "s.toml"
    path.write_text(small_scene("damped_forced", T=0.2, n=32).text)
    return path


@pytest.fixture(scope="session")
def basis(scene, tmp_path_factory):
    out = tmp_path_factory.mktemp("basis") / "b.h5"
    assert main(["pod", str(scene), "--out", str(out), "--quiet"]) == 0
    return out


@pytest.fixture(scope="session")
def fmu(scene, tmp_path_factory):
    out = tmp_path_factory.mktemp("fmu") / "f.fmu"
    assert main(["fmu", str(scene), "--modes", "4", "--no-verify", "--out", str(out), "--quiet"]) == 0
    return out
