"""Files generated from one table of the FMU (the variable table, :mod:`sphrom.fmu.variables`; the binary layout,
:mod:`sphrom.fmu.layout`): which are stale, and the command line that writes or checks them
(``python3 -m sphrom.fmu.variables --write``, ``python3 -m sphrom.fmu.layout --check``)."""

from __future__ import annotations

from pathlib import Path


def stale(texts, root):
    """The paths of ``texts`` ({path relative to the checkout ``root``: its text as generated now}) whose committed
    text differs (or that are missing)."""
    root = Path(root)
    return [path for path, text in texts.items()
            if not (root / path).is_file() or (root / path).read_text(encoding="utf-8") != text]


def main(argv, *, prog, source, command, generated):
    """The ``--write`` / ``--check`` command line of the files ``generated(root)`` ({path: text}) makes from
    ``source`` (a file named in the help); ``command`` is the write command, named in ``--check``'s lines.
    Returns the exit status (``--check``: 1 when a file is stale)."""
    import argparse

    from ..paths import repo_root
    parser = argparse.ArgumentParser(prog=prog, description=f"Regenerate (--write) or check (--check) the files "
                                                            f"generated from {source}.")
    group = parser.add_mutually_exclusive_group(required=True)
    group.add_argument("--write", action="store_true", help="write every stale generated file")
    group.add_argument("--check", action="store_true", help="list the stale generated files (exit status 1)")
    args = parser.parse_args(argv)
    root = repo_root()
    texts = generated(root)
    paths = stale(texts, root)
    if args.check:
        for path in paths:
            print(f"stale: {path} (run {command})")
        return 1 if paths else 0
    for path in paths:
        (root / path).write_text(texts[path], encoding="utf-8")
        print(f"wrote {path}")
    if not paths:
        print("every generated file is up to date")
    return 0
