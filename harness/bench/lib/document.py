"""BENCHMARKS.md as a document of ``## `` sections, each written by the program that measures it.

:func:`update_report` replaces (or inserts, before the stress maps) a program's sections in place;
:func:`publish` prints a section, replaces it and says what was written; :func:`program_outputs` gives a
section's command and its files' paths as seen from the report; :func:`split_sections` reads a document back.
:func:`fmt` is a number in a table.  Nothing here measures.

The sections live beside what measures their rows: in the program that writes them (``sphrom bench NAME``,
:mod:`sphrom.bench`), or, when the whole report (``sphrom bench --report``, :mod:`sphrom.bench.suite`) writes them
too, beside the measurement in this library (:mod:`.fmu_sections`, :mod:`.sph_scaling`, :mod:`.stress_maps`).
"""

from __future__ import annotations

import math
import os
import sys
from pathlib import Path

from ...markdown import write_text


def fmt(x, spec=".3e"):
    """A number for a table; ``—`` for None or NaN."""
    return "—" if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, spec)


def split_sections(text):
    """{"## heading": lines up to the next ``## `` heading} of a Markdown document, in document order."""
    out, current = {}, None
    for line in text.splitlines():
        if line.startswith("## "):
            current = line
            out[current] = []
        if current is not None:
            out[current].append(line)
    return out


def replace_section(text, heading, lines, before="## Stability stress maps"):
    """``text`` with the section ``heading`` (up to the next ``## ``) replaced by ``lines``, or inserted before
    the section ``before`` (at the end when that is absent)."""
    block = "\n".join(lines).rstrip("\n") + "\n\n"
    start = text.find(heading + "\n")
    if start >= 0:
        end = text.find("\n## ", start + len(heading))
        return text[:start] + block + (text[end + 1:] if end >= 0 else "")
    at = text.find("\n" + before + "\n")
    if at >= 0:
        return text[:at + 1] + block + text[at + 1:]
    return text.rstrip("\n") + "\n\n" + block


def update_report(path, sections):
    """Replace (or insert) the sections {heading: lines} of the Markdown report at ``path`` (atomically)."""
    report = Path(path)
    text = report.read_text() if report.exists() else "# Benchmarks\n"
    for heading, lines in sections.items():
        text = replace_section(text, heading, lines)
    write_text(report, text)
    return report


def program_outputs(name, argv, report, *paths):
    """(command, relative paths) of a benchmark program's section: the command as it was run (``sphrom bench NAME``
    and its arguments, ``argv`` None: the process's) and ``paths`` relative to the report's folder, as the
    section links them."""
    given = argv if argv is not None else sys.argv[1:]
    here = Path(report).resolve().parent
    return (f"sphrom bench {name}" + (" " + " ".join(given) if given else ""),
            [Path(os.path.relpath(Path(p).resolve(), here)).as_posix() for p in paths])


def publish(report, heading, lines, written, wall):
    """Print a program's section, replace it in the report at ``report`` and say what was written (``written``:
    the other files, ``wall`` [s] the program's wall time)."""
    print("\n".join(lines))
    path = update_report(report, {heading: lines})
    print(f"wrote {', '.join(str(p) for p in written)} and the section of {path} ({wall:.0f} s)")
    return path
