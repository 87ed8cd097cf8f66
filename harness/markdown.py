"""Small Markdown helpers for the pages sphrom writes (the validation report, BENCHMARKS.md, stress.md): tables,
numbers, images, and a page written atomically."""

from __future__ import annotations

import math


def num(x, spec=".3e"):
    """A number for a table; ``—`` for None or NaN."""
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "—"
    if isinstance(x, float) and math.isinf(x):
        return "∞"
    return format(x, spec)


def table(headers, rows):
    """Markdown table lines from a header list and rows of cells (already text)."""
    out = ["| " + " | ".join(headers) + " |", "| " + " | ".join("---" for _ in headers) + " |"]
    out += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return out + [""]


def image(path, alt):
    """A Markdown image line (``path`` relative to the page)."""
    return [f"![{alt}]({path})", ""]


def write_text(path, text):
    """Write a page atomically (a temporary file, then rename): never half a page."""
    from .runio import atomic_path           # deferred: runio loads numpy, which making a page's text never needs
    with atomic_path(path) as tmp:
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(text)


def print_or_write(text, path=None):
    """A generated page's text to stdout, or written to ``path`` (its folder made; atomic, :func:`write_text`)."""
    import sys
    from pathlib import Path
    if path:
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        write_text(path, text)
        print(f"wrote {path}")
    else:
        sys.stdout.write(text)
