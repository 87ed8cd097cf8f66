"""Signal trials: Ctrl-C (SIGINT to the whole process group, as a terminal sends it) and SIGTERM to the whole
process group (``kill -TERM -PGID``, a service manager stopping it) at random moments of ``sphrom sweep``, and
SIGTERM at random moments of ``sphrom --help`` and ``sphrom cosim``.

    python3 -m tests.hostile signals [--sweeps 50] [--sweep-terms 20] [--terms 200] [--seed 36]
                                     [--out validation/hostile]

Each trial starts the command in a session of its own with a private temporary folder (TMPDIR), sends the
signal at a moment uniform over the command's running span (measured once on an undisturbed run, from sphrom's
first line, which installs its handler, to the end: before it the interpreter starts up, where no program can
take a signal), and then asks: did it exit 128 + the signal within :data:`LIMIT_S` of the signal, with one
line on stderr ("... interrupted (SIGINT) ..."), no traceback, no process of its group left, nothing left in its
temporary folder (dask's scratch space included) and no temporary beside its output?  A run that ended before
its signal (its exit came first: :func:`~tests.hostile.battery.still_running`) is run again at half the moment.
Writes ``signal_trials.csv`` and ``signal_trials_run.csv`` (the command, date, machine) under --out, recomposes
the README there (:mod:`tests.hostile.report`) and prints the counts.
"""

from __future__ import annotations

import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from .battery import sphrom_catches_sigterm, still_running

LIMIT_S = 10.0          # s from the signal to the exit


def _group_alive(pgid):
    """Pids of the processes still in process group ``pgid`` (Linux /proc)."""
    alive = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            except (OSError, IndexError):
                continue
            if int(fields[2]) == pgid and fields[0] != "Z":
                alive.append(int(entry.name))
    return alive


def default_signals():
    """In the child before exec: SIGINT and SIGTERM at their defaults.  A shell starts a background job (``cmd &``
    without job control, as CI runners and nohup do) with SIGINT ignored, and sphrom rightly keeps an ignored
    signal ignored: the trial would then measure its launcher, not sphrom."""
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, signal.SIG_DFL)


def trial(argv, cwd, env, sig, delay, to_group):
    """One run of ``sphrom argv`` with ``sig`` after ``delay`` s: a dict of what happened."""
    tmp = Path(tempfile.mkdtemp(prefix="trial-tmp-", dir=cwd))
    env = {**env, "TMPDIR": str(tmp)}
    proc = subprocess.Popen([sys.executable, "-m", "sphrom", *argv], cwd=cwd, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True, preexec_fn=default_signals)
    while not sphrom_catches_sigterm(proc.pid) and proc.poll() is None:      # sphrom's first line has run
        time.sleep(0.0005)
    time.sleep(delay)
    sent = still_running(proc)
    if sent:
        if to_group:
            os.killpg(proc.pid, sig)
        else:
            proc.send_signal(sig)
    t_sig = time.monotonic()
    try:
        _, err = proc.communicate(timeout=LIMIT_S + 120)
        hung = time.monotonic() - t_sig > LIMIT_S
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        _, err = proc.communicate()
        hung = True
    wall = time.monotonic() - t_sig
    deadline = time.monotonic() + 5
    while _group_alive(proc.pid) and time.monotonic() < deadline:     # the workers' own exit, after the parent's
        time.sleep(0.05)
    left_procs = _group_alive(proc.pid)
    for pid in left_procs:
        os.kill(pid, signal.SIGKILL)
    left_tmp = [p.name for p in tmp.rglob("*")]
    shutil.rmtree(tmp, ignore_errors=True)
    left_out = [p.name for p in Path(cwd).iterdir() if ".tmp-" in p.name]
    lines = [line for line in err.strip().splitlines() if line.strip()]
    code = proc.returncode
    if not sent:
        outcome = "ended before the signal"
    elif hung:
        outcome = "hang"
    elif "Traceback" in err:
        outcome = "traceback"
    elif code == 0:
        outcome = "lost signal"
    elif code != 128 + sig:
        outcome = f"exit {code}"
    elif len(lines) != 1 or "interrupted" not in lines[0]:
        outcome = "unclear"
    elif left_procs or left_tmp or left_out:
        outcome = "left behind"
    else:
        outcome = "clean"
    return {"command": argv[0] if argv[0] != "--help" else "--help", "signal": signal.Signals(sig).name,
            "delay_s": f"{delay:.3f}", "exit": code, "seconds_to_exit": f"{wall:.2f}", "stderr_lines": len(lines),
            "outcome": outcome, "left": " ".join(map(str, left_procs + left_tmp + left_out))[:200],
            "last_line": (lines[-1] if lines else "")[:200]}


def span(argv, cwd, env):
    """Seconds an undisturbed run of ``sphrom argv`` takes from sphrom's handler being up (its first line: before
    it the interpreter's own start-up runs, where no program can take a signal) to its end."""
    proc = subprocess.Popen([sys.executable, "-m", "sphrom", *argv], cwd=cwd, env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, preexec_fn=default_signals)
    while not sphrom_catches_sigterm(proc.pid) and proc.poll() is None:
        time.sleep(0.0005)
    t0 = time.monotonic()
    proc.wait()
    length = time.monotonic() - t0
    for p in Path(cwd).iterdir():            # its outputs: a trial's sweep would resume them and have nothing to do
        if p.is_file():
            p.unlink()
    return length


def run_trials(root, sweeps=50, terms=200, seed=36, log=print, sweep_terms=20, on_row=None):
    """The trials in workspace ``root`` (scenes, an FMU and a sweep spec: :func:`tests.hostile.battery.prepare`);
    a list of row dicts, each also handed to ``on_row(rows)`` as it comes (the files stay current: a run stopped
    early keeps the counts of the trials it made)."""
    from .battery import prepare
    rng = random.Random(seed)
    ws = prepare(Path(root))
    spec = Path(root) / "spec_trials.toml"            # about 10 s on 2 workers: moments through start, runs, close
    spec.write_text(ws["spec_long"].read_text().replace("t_end = 20.0", "t_end = 5.0").split("frequency")[0]
                    + "frequency = [" + ", ".join(f"{0.5 + 0.25 * i}" for i in range(16)) + "]\nk = [4]\n")
    sweep = ["sweep", str(spec), "--workers", "2", "--out", "r.h5", "--quiet"]
    plans = [("--help", ["--help"], signal.SIGTERM, terms // 2, False),
             ("cosim", ["cosim", str(ws["fmu2"]), "--t-end", "20", "--step", "0.001", "--out", "o.csv"],
              signal.SIGTERM, terms - terms // 2, False),
             ("sweep", sweep, signal.SIGINT, sweeps, True),
             ("sweep", sweep, signal.SIGTERM, sweep_terms, True)]
    rows = []
    for name, argv, sig, count, to_group in plans:
        if not count:
            continue
        work = Path(tempfile.mkdtemp(prefix=f"trials-{name.strip('-')}-", dir=root))
        length = min(span(argv, work, ws.env), 60.0)
        log(f"{count} x {signal.Signals(sig).name} {'to the process group of' if to_group else 'to'} sphrom "
            f"{name} (an undisturbed run: {length:.1f} s) ...")
        for i in range(count):
            delay = rng.uniform(0.0, length)
            for _ in range(4):
                for p in work.iterdir():    # the outputs of the run before: a sweep would resume them, done at once
                    if p.is_file():
                        p.unlink()
                row = trial(argv, work, ws.env, sig, delay, to_group)
                if row["outcome"] != "ended before the signal":
                    break
                delay /= 2
            rows.append(row)
            if on_row is not None:
                on_row(rows)
            if row["outcome"] != "clean":
                log(f"  {name} #{i}: {row['outcome']} (delay {row['delay_s']} s, exit {row['exit']}): "
                    f"{row['last_line'] or row['left']}")
    return rows


def summary(rows):
    """{(command, signal): {outcome: count}} and the slowest exit after the signal per command [s]."""
    table, slowest = {}, {}
    for r in rows:
        key = (r["command"], r["signal"])
        table.setdefault(key, {})
        table[key][r["outcome"]] = table[key].get(r["outcome"], 0) + 1
        if r["outcome"] != "ended before the signal":
            slowest[key] = max(slowest.get(key, 0.0), float(r["seconds_to_exit"]))
    return table, slowest


def main(argv=None):
    import argparse
    p = argparse.ArgumentParser(prog="python3 -m tests.hostile signals", description=__doc__.split("\n\n")[0])
    p.add_argument("--sweeps", type=int, default=50, help="Ctrl-Cs of sphrom sweep (default 50)")
    p.add_argument("--sweep-terms", type=int, default=20,
                   help="SIGTERMs to the process group of sphrom sweep (default 20)")
    p.add_argument("--terms", type=int, default=200, help="SIGTERMs, half to sphrom --help, half to sphrom cosim")
    p.add_argument("--seed", type=int, default=36)
    p.add_argument("--out", default="validation/hostile", help="folder for signal_trials.csv")
    p.add_argument("--workdir", help="workspace (default a new temporary folder, removed at the end)")
    args = p.parse_args(argv)
    root = Path(args.workdir or tempfile.mkdtemp(prefix="sphrom-trials-"))
    t0 = time.monotonic()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    from .report import compose_readme, machine, now, write_csv, write_run
    command = "python3 -m tests.hostile signals " + " ".join(argv if argv is not None else sys.argv[2:])
    date = now()

    def save(rows):
        write_csv(out / "signal_trials.csv", rows)
        write_run(out / "signal_trials_run.csv", command=command.strip(), seed=args.seed, trials=len(rows),
                  wall_s=f"{time.monotonic() - t0:.0f}", date=date, machine=machine())
        compose_readme(out)

    rows = run_trials(root, args.sweeps, args.terms, args.seed, sweep_terms=args.sweep_terms, on_row=save)
    save(rows)
    table, slowest = summary(rows)
    print(f"{len(rows)} trials in {time.monotonic() - t0:.0f} s ({command.strip()}):")
    for (name, sig), by in table.items():
        print(f"  sphrom {name}, {sig}: " + ", ".join(f"{n} {o}" for o, n in sorted(by.items()))
              + f"; slowest exit after the signal {slowest.get((name, sig), 0):.2f} s")
    if not args.workdir:
        shutil.rmtree(root, ignore_errors=True)
    bad = [r for r in rows if r["outcome"] not in ("clean", "ended before the signal")]
    return 1 if bad else 0
