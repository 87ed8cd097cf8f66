"""The documentation site: MkDocs over the repository's own Markdown, laid out as in the repository.

``mkdocs.yml`` (at the top of the checkout) names this module as its hook.  The site holds README.md (its front
page), every file under ``docs/``, BENCHMARKS.md and the generated reports under ``validation/`` (Markdown, PNG and
CSV), each at its path in the repository, so a relative link that resolves in the repository (on a forge, in an
editor) resolves in the site too, and one link check serves both: :func:`relative_links` lists every relative
link of the Markdown sources, ``mkdocs build --strict`` (with the link validation of mkdocs.yml) refuses a link
or an anchor that resolves to nothing, and :func:`build` runs it.  The navigation is built from the folders: a new
page under ``docs/`` appears in it with its first heading as title, with nothing to register.

    python3 -m sphrom.docs_site [--out DIR]    # build the site, warnings as errors (default: a temporary folder)
"""

from __future__ import annotations

import argparse
import logging
import re
import tempfile
from pathlib import Path

from mkdocs.commands.build import build as mkdocs_build
from mkdocs.config import load_config
from mkdocs.exceptions import MkDocsException
from mkdocs.structure.files import File, Files

ROOT = Path(__file__).resolve().parents[1]

# what the site holds besides docs/: (folder or file relative to the checkout, glob patterns)
SOURCES = [("README.md", None), ("BENCHMARKS.md", None), ("docs", ("**/*.md", "**/*.png")),
           ("validation", ("**/*.md", "**/*.png", "**/*.csv", "**/*.toml"))]

# docs/'s sections in the navigation, in order, with their titles; a folder not named here comes after them, by
# name, titled by its index.md's heading or its name
SECTIONS = {"user": "User guide", "fmu": "The FMU", "science": "Science", "internals": "Internals",
            "validation": "Validation", "benchmarks": "Benchmarks"}

LINK = re.compile(r"(?<!!)\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)|!\[[^\]]*\]\(([^)\s]+)\)")
FENCE = re.compile(r"^(```|~~~)")


def source_files(root=ROOT):
    """The repository files of the site, relative to ``root`` (sorted)."""
    root = Path(root)
    out = set()
    for path, patterns in SOURCES:
        if patterns is None:
            if (root / path).is_file():
                out.add(path)
            continue
        for pattern in patterns:
            out.update(str(p.relative_to(root)) for p in (root / path).glob(pattern) if p.is_file())
    return sorted(out)


def markdown_files(root=ROOT):
    """The Markdown sources of the site (README.md, docs/, BENCHMARKS.md, validation/)."""
    return [p for p in source_files(root) if p.endswith(".md")]


def relative_links(text):
    """Every relative link target (``path`` or ``path#anchor``) of a Markdown text, outside code blocks and code
    spans; absolute URLs and pure anchors are left out."""
    out, fenced = [], False
    for line in text.splitlines():
        if FENCE.match(line.lstrip()):
            fenced = not fenced
            continue
        if fenced:
            continue
        line = re.sub(r"`[^`]*`", "", line)
        for m in LINK.finditer(line):
            target = m.group(1) or m.group(2)
            if re.match(r"[a-zA-Z][a-zA-Z0-9+.-]*:", target) or target.startswith("#"):
                continue
            out.append(target)
    return out


def broken_links(root=ROOT):
    """(file, link) of every relative link in the site's Markdown whose file does not exist in the checkout."""
    root = Path(root)
    broken = []
    for name in markdown_files(root):
        for target in relative_links((root / name).read_text(encoding="utf-8")):
            path = target.split("#", 1)[0]
            if path and not ((root / name).parent / path).exists():
                broken.append((name, target))
    return broken


# ---------------------------------------------------------------------------------------------------------------
# MkDocs hooks (mkdocs.yml: hooks)
# ---------------------------------------------------------------------------------------------------------------

def on_files(files, config):
    """Replace the pages found under docs_dir by the repository's files at their repository paths."""
    root = _root(config)
    docs_dir = Path(config["docs_dir"]).resolve()
    kept = [f for f in files if not Path(f.abs_src_path or "").resolve().is_relative_to(docs_dir)]
    ours = [File(path, src_dir=str(root), dest_dir=config["site_dir"],
                 use_directory_urls=config["use_directory_urls"]) for path in source_files(root)]
    return Files(kept + ours)


def _root(config):
    """The checkout: the folder of mkdocs.yml."""
    return Path(config.config_file_path).resolve().parent


def _page_title(path, root=ROOT):
    for line in (Path(root) / path).read_text(encoding="utf-8").splitlines():
        if line.startswith("# "):
            return line[2:].strip().replace("`", "")
    return Path(path).stem


def navigation(root=ROOT):
    """MkDocs's ``nav``: the front page, docs/'s sections (their index.md first, then the pages by title), the
    benchmarks and the validation reports."""
    pages = markdown_files(root)
    nav = [{"Home": "README.md"}]

    def _title(path):
        return _page_title(path, root)

    sections = {}
    for p in pages:
        parts = p.split("/")
        if parts[0] == "docs":
            sections.setdefault(parts[1] if len(parts) > 2 else "", []).append(p)
    order = list(SECTIONS) + sorted(s for s in sections if s not in SECTIONS and s)
    for page in sections.get("", []):
        nav.append({_title(page): page})
    for section in order:
        members = sections.get(section)
        if not members:
            continue
        index = [p for p in members if p.endswith("/index.md")]
        rest = sorted((p for p in members if p not in index), key=lambda p: _title(p).lower())
        nav.append({SECTIONS.get(section) or (_title(index[0]) if index else section.capitalize()):
                    [{_title(p): p} for p in index + rest]})
    generated = [p for p in pages if p == "BENCHMARKS.md" or p.startswith("validation/")]
    nav.append({"Generated reports": [{_title(p): p} for p in generated]})
    return nav


def on_config(config):
    """The navigation from the folders (:func:`navigation`)."""
    config["nav"] = navigation(_root(config))
    return config


def build(out, strict=True, root=ROOT):
    """Build the site of the checkout ``root`` into ``out`` (warnings are errors when ``strict``); raises mkdocs's
    error on failure."""
    logger = logging.getLogger("mkdocs")
    if not logger.handlers:                       # mkdocs's own command line installs one; as a library, we do
        handler = logging.StreamHandler()
        handler.setFormatter(logging.Formatter("%(levelname)s: %(message)s"))
        handler.setLevel(logging.WARNING)
        logger.addHandler(handler)
    config = load_config(str(Path(root) / "mkdocs.yml"), site_dir=str(out), strict=strict)
    mkdocs_build(config)


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python3 -m sphrom.docs_site",
                                     description="Build the documentation site (mkdocs.yml) with warnings as "
                                                 "errors and every relative link checked.")
    parser.add_argument("--out", metavar="DIR", help="site folder (default: a temporary folder, removed after)")
    args = parser.parse_args(argv)
    broken = broken_links()
    for name, target in broken:
        print(f"{name}: broken link {target}")
    if broken:
        return 1
    try:
        if args.out:
            build(args.out)
        else:
            with tempfile.TemporaryDirectory() as tmp:
                build(tmp)
    except MkDocsException as e:
        print(f"the site does not build: {e}")
        return 1
    print(f"wrote the site into {args.out}" if args.out else "the site builds clean")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
