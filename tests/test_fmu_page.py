"""The FMU's page (documentation/index.html): what it says, and its layout in a real headless browser."""

import re
import zipfile

import pytest

from conftest import fmu_scene
from sphrom.fmu.check import page
from sphrom.fmu.make.package import package_fmu


@pytest.fixture(scope="module")
def fmus(tmp_path_factory):
    """{name: (fmu path, its index.html text)}: an exact FMI 2 FMU, a frozen FMI 3 FMU with two ports."""
    folder = tmp_path_factory.mktemp("page")
    out = {}
    for name, model, fmi, ports in [("exact", "exact", 2, None), ("frozen_ports", "frozen", 3, [0.3, 0.7])]:
        path = folder / f"{name}.fmu"
        package_fmu(fmu_scene("forced"), path, k=6, fmi=fmi, progress=False, model=model, ports=ports)
        out[name] = (path, zipfile.ZipFile(path).read("documentation/index.html").decode("utf-8"))
    return out


def _text(html):
    return re.sub(r"\s+", " ", re.sub(r"<[^>]+>", " ", html))


def test_the_page_says_how_to_use_the_fmu(fmus):
    exact, frozen = _text(fmus["exact"][1]), _text(fmus["frozen_ports"][1])
    assert "FMI 2.0 co-simulation" in exact and "FMI 3.0 co-simulation" in frozen
    for text in (exact, frozen):
        assert "It starts at rest" in text and "Communication step" in text and "simulate_fmu(" in text
    assert "canInterpolateInputs" in exact and "no input derivatives" in frozen
    assert "This FMU has no mechanical ports" in exact
    assert "Mechanical ports at x/L = 0.3, 0.7" in frozen and "on the bar" in frozen


def test_the_page_states_numbers_with_their_units_and_labels(fmus):
    for name, (_, html) in fmus.items():
        text = _text(html)
        for field in ("rho0(x) [kg m^-3]", "v0(x) [m s^-1]", "c(x) [Pa", "d(x) [s^-1]"):
            assert field in text, (name, field)
        assert "training max |v|" in text                      # ENVPROBE holds rho0 and max |v|, labelled so
        variables = html[html.index('id="variables"'):]
        variables = variables[:variables.index("</table>")]
        mantissas = [m.replace(".", "").lstrip("0") for m in re.findall(r"\d+\.\d+", variables)]
        assert mantissas and max(map(len, mantissas)) <= 6, (name, mantissas)      # a few digits, not 17
        assert not re.search(r"\d\.\d+e-(1[3-9]|[2-9]\d)\b", text), name      # no round-off printed as a mean
        assert not re.search(r"(\d+(\.\d+)?, ){12}", text), name     # no raw lists of numbers


def test_the_page_says_one_thing_about_run_time_checks(fmus):
    """With certified error bounds (both FMUs here) the run-time signal is the bound, on every page: the
    envelope is information, never 'checks nothing' nor 'warns when a run leaves it'."""
    for name in ("exact", "frozen_ports"):
        text = _text(fmus[name][1])
        assert "run-time signal is its certified error bound" in text, name
        assert "run-time signal: the certified error bound of every output" in text, name
        assert "checks nothing at run time" not in text and "leaves it" not in text, name
        assert "run-time warning (once) beyond" not in text, name


@pytest.mark.parametrize("name", ["exact", "frozen_ports"])
def test_no_horizontal_overflow_at_1280_px_in_a_headless_browser(fmus, tmp_path, name):
    if page.find_chromium() is None:
        pytest.skip("no headless Chromium installed (apt-get install chromium, or set SPHROM_CHROMIUM)")
    index = page.extract_page(fmus[name][0], tmp_path)
    layout = page.layout(index, width=1280)
    assert layout["client"] == 1280 and layout["body"] < 1280
    assert layout["scroll"] <= layout["client"] and layout["over"] == [], layout


def test_the_browser_check_sees_an_overflowing_table(tmp_path):
    if page.find_chromium() is None:
        pytest.skip("no headless Chromium installed (apt-get install chromium, or set SPHROM_CHROMIUM)")
    (tmp_path / "wide.html").write_text('<!DOCTYPE html><html><body style="max-width:60em;margin:auto">'
                                        '<table id="t"><tr><td style="white-space:nowrap">' + "x" * 400 +
                                        "</td></tr></table></body></html>")
    layout = page.layout(tmp_path / "wide.html", width=1280)
    assert any(e.startswith("table#t") for e in layout["over"]), layout


def test_the_packaging_message_says_what_each_model_does_with_the_force_profile():
    """The exact model appends the profile's residual whatever its size: never 'above 0.01' for it."""
    from sphrom.commands.fmu import input_decision
    from sphrom.rom.registry import get_model
    exact, frozen = get_model("exact"), get_model("frozen")
    assert "whatever its size" in input_decision(exact, augmented=True) and "0.01" not in input_decision(exact, True)
    assert input_decision(frozen, augmented=True).startswith("above 0.01")
    assert input_decision(frozen, augmented=False).startswith("at most 0.01")
    assert "parametric" in input_decision(frozen, augmented=False, parametric=True)
