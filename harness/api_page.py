"""The user documentation's page of the Python API, ``docs/user/api.md``, generated from the docstrings of
``import sphrom``'s public names.

    python3 -m sphrom.api_page --write docs/user/api.md

The package's docstring (its example), then each public name of :data:`sphrom.EXPORTS` in its order: its
signature and its numpy-style docstring as Markdown (Parameters, Returns, Raises and Attributes as lists; an
indented block after ``::`` as code); a class adds its methods.  ``tests/test_public_api.py`` fails, naming the
command above, when the page is stale.
"""

from __future__ import annotations

import argparse
import inspect
import re
import sys

import sphrom

from .markdown import print_or_write

PAGE = "docs/user/api.md"
COMMAND = f"python3 -m sphrom.api_page --write {PAGE}"
LISTS = ("Parameters", "Other Parameters", "Returns", "Yields", "Raises", "Attributes")
# FMU's methods without a docstring of their own: each is the FMI call of its name, FMI 2 or 3
# the page that says more about each public name (relative to docs/user/); a docstring's "(module docstring)",
# which points into the source, gives way to it
SEE_ALSO = {"load_scene": ("the scene schema", "scenes.md"), "package_fmu": ("packaging an FMU", "../fmu/index.md"),
            "FMU": ("driving an FMU from Python", "../fmu/cosim.md"),
            "run_cosim": ("driving an FMU from Python and the input rule", "../fmu/cosim.md"),
            "verify_fmu": ("what sphrom fmu measures", "../fmu/index.md")}
FMI_CALLS = "the FMI calls of their names, FMI 2 or FMI 3 (values by value reference: `fmu.vr[name]`)"


def inline(text):
    """Sphinx roles and reST literals as Markdown code: ``:func:`x``` and ````x```` become ```x```."""
    text = re.sub(r":(?:func|class|mod|meth|attr|data|exc|obj):`~?([^`]+)`", r"`\1`", text)
    return re.sub(r"``([^`]+)``", r"`\1`", text)


def _header(lines, i):
    """Whether lines[i] is a numpy-style section header (a title over a line of dashes)."""
    return (i + 1 < len(lines) and lines[i].strip() and not lines[i].startswith(" ")
            and re.fullmatch(r"-{3,}", lines[i + 1].strip()) is not None)


def _entries(block):
    """The entries of a Parameters-like section: (head, description lines) per unindented line."""
    out = []
    for line in block:
        if line and not line.startswith(" "):
            out.append((line.strip(), []))
        elif out and line.strip():
            out[-1][1].append(line.strip())
    return out


def _list(section, block):
    lines = [f"**{section}**", ""]
    for head, words in _entries(block):
        name, _, kind = head.partition(" : ")
        if section in ("Returns", "Yields", "Raises") and not kind:
            label = f"`{name}`"
        else:
            label = f"`{name}`" + (f" ({inline(kind)})" if kind else "")
        lines.append(f"- {label}" + (f": {inline(' '.join(words))}" if words else ""))
    return lines + [""]


def _code(block):
    """An indented literal block as a fenced one (Python when it reads as code)."""
    text = inspect.cleandoc("\n".join(block))
    language = "python" if re.search(r"^(import |from |with |[\w.]+ = )", text, re.M) else "text"
    return [f"```{language}", *text.splitlines(), "```", ""]


def docstring_markdown(doc):
    """A numpy-style docstring as Markdown lines (module docstring)."""
    lines = inspect.cleandoc(doc or "").splitlines()
    out, i = [], 0
    while i < len(lines):
        if _header(lines, i):
            section, j = lines[i].strip(), i + 2
            while j < len(lines) and not _header(lines, j):
                j += 1
            block = lines[i + 2:j]
            out += _list(section, block) if section in LISTS else [f"**{section}**", "", *map(inline, block), ""]
            i = j
            continue
        line = lines[i]
        if line.rstrip().endswith("::"):
            out.append(inline(line.rstrip()[:-1]))          # "in Python::" -> "in Python:"
            j = i + 1
            while j < len(lines) and (not lines[j].strip() or lines[j].startswith(" ")):
                j += 1
            out += [""] + _code(lines[i + 1:j])
            i = j
            continue
        out.append(inline(line))
        i += 1
    while out and not out[-1]:
        out.pop()
    return out + [""]


def _signature(name, obj):
    try:
        return f"{name}{inspect.signature(obj)}"
    except (TypeError, ValueError):
        return name


def _methods(cls):
    """Markdown lines of the public methods and properties of ``cls``: each documented one with its first
    paragraph, the undocumented ones (the FMI calls) in one line."""
    documented, bare = [], []
    for name, member in inspect.getmembers(cls):
        if name.startswith("_"):
            continue
        static = inspect.getattr_static(cls, name)
        doc = inspect.getdoc(member) if not isinstance(static, property) else inspect.getdoc(static)
        if not callable(member) and not isinstance(static, property):
            continue
        title = f"fmu.{name}" if isinstance(static, property) else _signature(f"fmu.{name}", member)
        title = title.replace("(self, ", "(").replace("(self)", "()")
        if doc:
            first = inline(" ".join(doc.split("\n\n")[0].split()))
            documented.append(f"- `{title}`: {first}")
        else:
            bare.append(f"`{name}`")
    lines = ["**Methods**", "", *documented]
    if bare:
        lines.append(f"- {', '.join(bare)}: {FMI_CALLS}")
    return lines + [""]


def markdown() -> str:
    """The page ``docs/user/api.md`` (module docstring)."""
    lines = ["# Python API: `import sphrom`", "",
             f"<!-- generated by `{COMMAND}` from the docstrings of the public names of harness/__init__.py: do "
             "not edit by hand -->", ""]
    lines += docstring_markdown(sphrom.__doc__)
    for name in sphrom.EXPORTS:
        obj = getattr(sphrom, name)
        lines += [f"## `sphrom.{name}`", "", "```python", f"sphrom.{_signature(name, obj)}", "```", "",
                  f"Defined in `{obj.__module__}`.", ""]
        doc = re.sub(r" \(module docstring(: [^)]*)?\)", "", inspect.getdoc(obj) or "")
        lines += docstring_markdown(doc)
        if inspect.isclass(obj):
            lines += _methods(obj)
        if name in SEE_ALSO:
            lines += [f"See also: [{SEE_ALSO[name][0]}]({SEE_ALSO[name][1]}).", ""]
    lines += ["## `sphrom.__version__`", "",
              f"The package's version, `{sphrom.__version__}`: written once, in harness/__init__.py, from which "
              "pyproject.toml takes it (`[tool.setuptools.dynamic]`), so it equals the installed package's metadata "
              "(`importlib.metadata.version(\"sphrom\")`).", ""]
    return "\n".join(lines)


def main(argv=None):
    p = argparse.ArgumentParser(prog="python3 -m sphrom.api_page",
                                description="Print (or write) the Python API page, generated from the docstrings "
                                            "of import sphrom's public names.")
    p.add_argument("--write", metavar="PATH", help=f"write the page here ({PAGE})")
    args = p.parse_args(argv)
    text = markdown()
    print_or_write(text, args.write)
    return 0


if __name__ == "__main__":
    sys.exit(main())
