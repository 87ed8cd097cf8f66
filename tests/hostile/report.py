"""validation/hostile/README.md, composed from the files the battery and the signal trials write beside it:
``hostile.csv`` and ``battery_run.csv`` (:mod:`tests.hostile.battery`), ``signal_trials.csv`` and
``signal_trials_run.csv`` (:mod:`tests.hostile.trials`).  Each writer recomposes it, so the README always shows
the counts of the files beside it, with the command, the date and the machine of the run that wrote them.

    python3 -m tests.hostile readme [--out validation/hostile]      (recompose it from the files alone)
"""

from __future__ import annotations

import csv
import datetime
import os
import platform
from pathlib import Path

OUTCOMES = ("ok", "clean error", "clean interrupt", "traceback", "hang", "silent wrong result", "replaced file",
            "left behind", "unclear error", "outside sphrom")
BAD = ("traceback", "hang", "silent wrong result", "replaced file", "left behind", "unclear error")
ENDED_FIRST = "the run ended before the signal"

# What the battery covers: its categories, and where the cases of the fourth round of hostile input live in it
# (their numbers as the round numbered them).
CATEGORIES = (
    ("options", "every option of every command given hostile values (wrong types, huge, tiny, negative, NaN, "
                "inf, empty, `--`), and hostile positional arguments"),
    ("paths", "outputs that are devices, FIFOs, sockets, folders, links, odd names or missing folders; inputs "
              "of every such kind"),
    ("scenes", "scene files with a field missing, of the wrong type or out of range, for `sph` and `fmu`"),
    ("round four", "the command-line cases of round four (table below)"),
    ("signals", "SIGINT and SIGTERM at random moments of `sweep`, `sph`, `pod`, `fmu`, `cosim`, `reference`, "
                "and in the interpreter's start-up"),
    ("resources", "`model.bin` of the FMUs mutated at random (bytes, sizes, sections), checksum recomputed, "
                  "loaded and stepped through the C core"),
    ("states", "serialized FMU states mutated at random, restored and stepped through fmpy"),
    ("call sequences", "FMI calls in random orders, out of the standard's sequence, through fmpy"),
    ("step bound", "one doStep given the most work it can be given (dt = 1e-12 s, a 1e7 s step): done or "
                   "refused within 10 s"),
    ("round four FMU", "the C-side cases of round four (table below), through fmpy on the FMI 2 and 3 frozen "
                       "FMUs and the FMI 2 exact one"),
)
ROUND_FOUR = (
    (1, "Ctrl-C of `sphrom sweep` at any moment: exit 130 within seconds, one line, nothing left (dask's "
        "scratch space included)", "signals (SIGINTs and SIGTERMs of `sweep`); the signal trials"),
    (2, "`sphrom fmu` with a scene dt (0.02 s) longer than the FMU's 0.01 s step, frozen and exact, verified",
     "round four"),
    (3, "time exact at any start: an FMU started at 1.7e9 s gives the outputs of one started at 0; a "
        "communication point 1 s ahead; starts and steps of 1e308 s; a step of 1e-8 s at 1.7e9 s",
     "round four FMU"),
    (4, "an output that names an input: the scene (`sph`, `pod`), the FMU and the force CSV (`cosim`), the scene "
        "a sweep's spec names", "round four"),
    (5, "a real full file system (a 64 KiB tmpfs) under `sph`, `fmu` and `cosim`", "round four"),
    (6, "damaged FMUs in `cosim`: a truncated (half, one page), missing, garbage, empty or foreign binary, a CRC "
        "error, absolute and `..` members, stepSize 0, -1 or none, stopTime -2, a zip bomb", "round four"),
    (7, "memory beyond the machine: N = 4e5 and 1e6 under a 6 GiB address-space limit (`fmu`, `sph`, `pod`), "
        "`cosim` of 1e8 steps", "round four"),
    (8, "each section of the error bounds' shadow negated, scaled by 1e6 and by 1e-6, checksum recomputed",
     "round four FMU; resources"),
    (9, "messages that mislead: a byte-order mark in a CSV and in a TOML, a scene that is a folder, a `--force` "
        "that is a FIFO, a negative number `-1e-3` as a value", "round four; paths"),
    (10, "a SIGTERM lost while the command line imports", "signals; the signal trials (`--help`)"),
    (11, "`initial_state_scale` of 1e308, -1e4 and 1000 (the largest allowed); the getters and getFMUstate in "
         "the Error state", "round four FMU; round four (`cosim`)"),
)


def machine():
    """One line naming this machine: its host name, CPU model, logical cores, OS and Python."""
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return (f"{platform.node()}: {cpu}, {os.cpu_count()} logical cores, {platform.system()} {platform.release()}, "
            f"Python {platform.python_version()}")


def now():
    """The date and time in UTC, to the minute."""
    return datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")


def write_run(path: Path, **fields):
    """A one-row CSV of what the run was (command, date, machine, ...), written whole or not at all."""
    write_csv(path, [fields])


def write_csv(path, rows):
    """``rows`` (dicts, the keys of the first as columns) as a CSV file at ``path``, written whole or not at all."""
    from sphrom.runio import atomic_path
    with atomic_path(path) as tmp, open(tmp, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(dict.fromkeys(k for r in rows for k in r)))
        w.writeheader()
        w.writerows(rows)


def read_csv(path: Path):
    """The rows of a CSV file as dicts ([] if it does not exist)."""
    if not path.is_file():
        return []
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def md_table(header, rows):
    """A Markdown table's lines (header, rule, rows) and a blank line."""
    return ["| " + " | ".join(header) + " |", "| " + " | ".join("---" for _ in header) + " |",
            *("| " + " | ".join(row) + " |" for row in rows), ""]


def _delivered(row):
    """A signal case whose signal reached the running command (the column, or from the detail of an old file)."""
    if "delivered" in row:
        return row["delivered"] == "1"
    return row["detail"] != ENDED_FIRST


def battery_lines(rows, run):
    """The battery's part of the README: its run, counts by category and outcome, signals, cases off target."""
    table = {}
    for r in rows:
        table.setdefault(r["category"], {o: 0 for o in OUTCOMES})[r["outcome"]] += 1
    total = {o: sum(by[o] for by in table.values()) for o in OUTCOMES}
    wall = float(run.get("wall_s") or "nan")
    lines = ["## The battery's counts", "",
             f"`{run.get('command', '?')}` (seed {run.get('seed', '?')}), run on {run.get('date', '?')} on "
             f"{run.get('machine', '?')}: {len(rows)} cases in {wall / 60:.0f} min; every case and its outcome: "
             "`hostile.csv`, these counts: `hostile_counts.csv`." + (f"  {run['note']}" if run.get("note") else ""),
             ""]
    rows_md = [[cat] + [str(by[o]) for o in OUTCOMES] + [str(sum(by.values()))] for cat, by in table.items()]
    rows_md.append(["**all**"] + [f"**{total[o]}**" for o in OUTCOMES] + [f"**{sum(total.values())}**"])
    lines += md_table(["category", *OUTCOMES, "cases"], rows_md)
    lines += ["### Signals delivered while the command ran", "",
              "Moments uniform over each command's running span (measured once at the start, from sphrom's "
              "handler being up to its end); a run that ended before its signal was run again with the moment "
              "halved (up to three times).", ""]
    signals = [r for r in rows if r["category"] == "signals"]
    for command in dict.fromkeys(r["command"] for r in signals):
        mine = [r for r in signals if r["command"] == command and _delivered(r)]
        if mine:
            by = {o: sum(r["outcome"] == o for r in mine) for o in OUTCOMES}
            lines.append(f"- `{command}`: {len(mine)} signals, " + ", ".join(f"{n} {o}" for o, n in by.items() if n)
                         + "; " + ", ".join(sorted({r["case"].split(",")[0] for r in mine})))
    lines.append("")
    bad = [r for r in rows if r["outcome"] in BAD]
    lines += ["### Cases off target", ""]
    if not bad:
        lines += ["None: no traceback, hang, silent wrong result, replaced file, temporary left behind or "
                  "unclear error.", ""]
    else:
        lines += md_table(["outcome", "category", "command", "case", "detail"],
                          [[r["outcome"], r["category"], r["command"], r["case"].replace("|", "/"),
                            r["detail"].replace("|", "/")[:160]] for r in bad])
    outside = [r for r in rows if r["outcome"] == "outside sphrom"]
    if outside:
        lines += [f"{len(outside)} signals reached the process before the interpreter ran sphrom's first line "
                  "(its start-up, where Python's own default handlers act) or after it restored the default "
                  "handlers while exiting: counted apart, nothing a program can catch there.", ""]
    return lines


def trial_lines(rows, run):
    """The signal trials' part of the README: their run and counts by command, signal and outcome."""
    lines = ["## The signal trials' counts", "",
             f"`{run.get('command', '?')}`, run on {run.get('date', '?')} on {run.get('machine', '?')}: "
             f"{len(rows)} trials in {float(run.get('wall_s') or 'nan') / 60:.0f} min; every trial: "
             "`signal_trials.csv`.  A trial is clean when the command exits 128 + the signal within 10 s of it with "
             "one line, no traceback, no process of its group and nothing in its temporary folder left."
             + (f"  {run['note']}" if run.get("note") else ""), ""]
    table = {}
    for r in rows:
        key = (r["command"], r["signal"])
        entry = table.setdefault(key, {"outcomes": {}, "slowest": 0.0, "sent": 0})
        entry["outcomes"][r["outcome"]] = entry["outcomes"].get(r["outcome"], 0) + 1
        if r["outcome"] != "ended before the signal":
            entry["sent"] += 1
            entry["slowest"] = max(entry["slowest"], float(r["seconds_to_exit"]))
    lines += md_table(["command", "signal", "trials", "signal delivered", "outcomes", "slowest exit after the "
                       "signal [s]"],
                      [[f"`sphrom {c}`", s, str(sum(e["outcomes"].values())), str(e["sent"]),
                        ", ".join(f"{n} {o}" for o, n in sorted(e["outcomes"].items())), f"{e['slowest']:.2f}"]
                       for (c, s), e in table.items()])
    return lines


def compose_readme(out: Path):
    """Write ``out``/README.md from the battery's and the trials' files in ``out`` (whichever exist)."""
    out = Path(out)
    lines = ["# Hostile-input battery", "",
             "A battery of hostile inputs (a test-side tool in `tests/hostile/`): every command's options, scenes "
             "and output paths, damaged FMUs, full disks, memory limits, mutated FMU resources and states, FMI "
             "calls out of order, and signals at random moments of every long command.  Each case runs in a "
             "process of its own and gets one outcome; what each outcome means: the docstring of "
             "`tests/hostile/battery.py`.  Targets: 0 tracebacks, 0 hangs, 0 silent wrong results, 0 replaced "
             "or left-behind files, 0 unclear errors.", "",
             "## How to run it", "",
             "From a checkout (the folder that holds `tests/`), with its code on the path:", "",
             "    python3 -m tests.hostile --out validation/hostile            # the battery (alias: sphrom bench "
             "hostile)",
             "    python3 -m tests.hostile signals --out validation/hostile    # the signal trials alone",
             "    python3 -m tests.hostile readme --out validation/hostile     # this README from the files beside it",
             "",
             "`--quick` runs about a third of the battery; `--jobs` sets the command-line cases run at a time "
             "(default 2); the trials take `--sweeps` (Ctrl-Cs of `sphrom sweep`), `--sweep-terms` (SIGTERMs to "
             "its process group) and `--terms` (SIGTERMs, half to `sphrom --help`, half to `sphrom cosim`).  The "
             "signal cases' moments are timed: on a loaded machine a command runs longer and the 10 s limits "
             "leave less margin.  The suite runs small samples of both (`tests/test_hostile*.py`).", "",
             "## What it covers", "",
             "By category (the `category` column of `hostile.csv`):", ""]
    lines += [f"- **{name}**: {what}" for name, what in CATEGORIES]
    lines += ["", "The fourth round of hostile input, case by case (the numbers the round gave them), and the "
              "categories that hold each:", ""]
    lines += md_table(["case", "what", "where"], [[str(n), what, where] for n, what, where in ROUND_FOUR])
    battery = read_csv(out / "hostile.csv")
    if battery:
        run = (read_csv(out / "battery_run.csv") or [{}])[0]
        lines += battery_lines(battery, run)
    else:
        lines += ["## The battery's counts", "", "None here: the battery has not written `hostile.csv` in this "
                  "folder (run the first command above).", ""]
    trials = read_csv(out / "signal_trials.csv")
    if trials:
        run = (read_csv(out / "signal_trials_run.csv") or [{}])[0]
        lines += trial_lines(trials, run)
    else:
        lines += ["## The signal trials' counts", "", "None here: the trials have not written `signal_trials.csv` "
                  "in this folder (run the second command above).", ""]
    from sphrom.runio import atomic_path
    with atomic_path(out / "README.md") as tmp:
        Path(tmp).write_text("\n".join(lines).rstrip("\n") + "\n")


def main(argv=None):
    import argparse
    p = argparse.ArgumentParser(prog="python3 -m tests.hostile readme",
                                description="Compose README.md from the battery's and the trials' files.")
    p.add_argument("--out", default="validation/hostile", help="the folder that holds them")
    args = p.parse_args(argv)
    compose_readme(Path(args.out))
    print(f"wrote {Path(args.out) / 'README.md'}")
    return 0
