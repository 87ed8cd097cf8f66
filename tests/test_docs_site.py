"""The README is a front door and the documentation site builds clean, every relative link resolving."""

import re
from pathlib import Path

import pytest

from sphrom import docs_figures, docs_site

ROOT = Path(__file__).resolve().parents[1]
README_MAX_LINES = 300


def test_the_readme_is_a_front_door():
    lines = (ROOT / "README.md").read_text(encoding="utf-8").splitlines()
    assert len(lines) <= README_MAX_LINES, f"README.md has {len(lines)} lines (at most {README_MAX_LINES})"
    text = "\n".join(lines)
    for heading in ("## Install", "## The two commands", "## Which model?", "## Using the FMU in a system simulator",
                    "## Code map", "## Commands", "## Documentation"):
        assert f"\n{heading}\n" in text, heading


def test_the_readme_test_command_is_the_one_ci_runs():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    command = "pip install -e '.[test]' && python3 -m pytest -q"
    assert command in readme and command in ci


def test_the_link_finder_sees_links_and_skips_code():
    text = "a [x](docs/a.md) ![p](b.png) [u](https://e.org) [h](#top) `[c](no.md)`\n```\n[d](no2.md)\n```\n[e](c.md#s)"
    assert docs_site.relative_links(text) == ["docs/a.md", "b.png", "c.md#s"]


def test_every_relative_link_resolves_in_the_checkout():
    pages = docs_site.markdown_files()
    assert "README.md" in pages and "docs/fmu/variables.md" in pages and "docs/user/scenes.md" in pages
    assert sum(len(docs_site.relative_links((ROOT / p).read_text(encoding="utf-8"))) for p in pages) > 50
    assert docs_site.broken_links() == []


def test_a_broken_link_is_found(tmp_path):
    (tmp_path / "docs").mkdir()
    (tmp_path / "README.md").write_text("[ok](docs/a.md) [gone](docs/b.md#x)\n")
    (tmp_path / "docs" / "a.md").write_text("# A\n[up](../README.md)\n")
    assert docs_site.broken_links(tmp_path) == [("README.md", "docs/b.md#x")]


def test_the_navigation_holds_every_page_of_docs():
    def pages(nav):
        for entry in nav:
            for value in entry.values():
                yield from (pages(value) if isinstance(value, list) else [value])
    listed = set(pages(docs_site.navigation()))
    assert {p for p in docs_site.markdown_files() if p.startswith("docs/")} <= listed
    assert "README.md" in listed and "BENCHMARKS.md" in listed


def test_the_readme_model_table_is_generated_from_the_measurements():
    assert not docs_figures.stale(), f"README.md's model table is stale: regenerate it with `{docs_figures.COMMAND}`"
    table = docs_figures.table()
    assert table.count("\n| `") == 3 and "(default)" in table


def test_the_site_builds_with_warnings_as_errors(tmp_path):
    pytest.importorskip("mkdocs", reason="MkDocs is not installed (pip install -e '.[test]' installs it)")
    docs_site.build(tmp_path / "site")
    assert (tmp_path / "site" / "index.html").is_file()
    assert (tmp_path / "site" / "docs" / "fmu" / "variables" / "index.html").is_file()
    page = (tmp_path / "site" / "docs" / "fmu" / "variables" / "index.html").read_text(encoding="utf-8")
    assert re.search(r"<code>v_probe_j</code>", page)


@pytest.mark.parametrize("link, builds", [("docs/a.md#a", True), ("docs/a.md#nowhere", False),
                                         ("docs/b.md", False)])
def test_the_strict_build_checks_links_and_anchors(tmp_path, link, builds):
    """A checkout of two pages with this repository's mkdocs.yml and hook: a missing page or anchor fails."""
    pytest.importorskip("mkdocs", reason="MkDocs is not installed (pip install -e '.[test]' installs it)")
    from mkdocs.exceptions import Abort
    (tmp_path / "harness").mkdir()
    (tmp_path / "docs").mkdir()
    for name in ("mkdocs.yml", "harness/docs_site.py"):
        (tmp_path / name).write_text((ROOT / name).read_text(encoding="utf-8"), encoding="utf-8")
    (tmp_path / "README.md").write_text(f"# R\n\n[a]({link})\n")
    (tmp_path / "docs" / "a.md").write_text("# A\n\n[home](../README.md)\n")
    if builds:
        docs_site.build(tmp_path / "site", root=tmp_path)
        assert (tmp_path / "site" / "docs" / "a" / "index.html").is_file()
    else:
        with pytest.raises(Abort):
            docs_site.build(tmp_path / "site", root=tmp_path)
