"""Fast end to end, before and after: whole commands and the frozen core, this checkout against another.

``python -m sphrom.bench.fast`` / ``sphrom bench fast [--before CHECKOUT] [--repeats R] [--no-cold]
[--report BENCHMARKS.md]``

Whole processes, each a fresh interpreter (its start-up and imports included), timed from outside: a bare Python
start and ``import numpy, fmpy`` (the yardsticks of instant commands), ``sphrom --help``, ``sphrom cosim`` of
tenmode's exact FMU over 10 s (packaged once by this checkout; both checkouts run the same file), ``sphrom fmu
tenmode`` with a warm cache and with a cold SPH/POD cache (the binaries built: the build folder copied into an
empty cache before the clock starts).  With ``--before`` each command runs in turn in this checkout (A) and in
CHECKOUT (B), ``PYTHONPATH`` set per command, A B A B ...: medians of each, and the ratio B / A taken pair by
pair (a drift of the shared machine falls on both).  Wall and CPU seconds (user + system of the child) are both
given: on a loaded machine the CPU time is the work, the wall time what a user waits.

The frozen core (in-process, each checkout's own code and build in a subprocess): ns per internal step at k = 12,
n_freeze = 10 (tenmode at N = 400), a port FMU's model (damped_forced, ports at x/L = 0.3, 0.7) against the same
scene's portless one, and a component at rest (initial_state_scale 0, f = 0): each the slope between M and 2M
internal steps, thread CPU time and wall, medians of the repeats.
"""

from __future__ import annotations

import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from ..paths import import_path
from ..progress import progress_bar
from ..runio import atomic_path
from . import program_parser
from .lib.document import update_report
from .lib.timing import cpu_model, load_average

HERE = Path(__file__).resolve().parents[2]          # this checkout

# the core measurement, run by each checkout's own Python code (either layout: sphrom.fmu.make/run or older)
CORE_SCRIPT = r"""
import ctypes, json, statistics, sys, time
try:
    from sphrom.fmu.make.build import ensure_binaries
    from sphrom.fmu.make.models import reduced_model
    from sphrom.fmu.run.core import Core
except ImportError:
    from sphrom.fmu.build import ensure_binaries
    from sphrom.fmu.package import reduced_model
    from sphrom.fmu.core import Core
from sphrom.fmu.kinds import pack
from sphrom.scene import derive_scene, load_scene

repeats = int(sys.argv[1])
core = Core(ensure_binaries().core)
lib = core.lib
lib.rom_set_initial_state_scale.argtypes = [ctypes.c_void_p, ctypes.c_double, ctypes.c_char_p, ctypes.c_size_t]
buf = ctypes.create_string_buffer(1024)

def model_of(scene, ports=()):
    import inspect                 # the tensor too (its refresh paths are timed), in a checkout that can skip it
    always = {"tensor": "always"} if "tensor" in inspect.signature(reduced_model).parameters else {}
    data, ops, problem, _ = reduced_model(scene, 12, 10, [0.5], "euler", progress=False,
                                          **({"ports": ports} if ports else {}), **always)
    try:                    # the particle refresh where packaging puts it (a checkout that has it)
        from sphrom.fmu.make.models import particle_sections
        data.sections.update(particle_sections(ops, problem))
    except ImportError:
        pass
    return core.load(pack(data)), data.k_v, data.k_rho

def paths(m, n):
    # CPU ns per step on each refresh path, and the one chosen at load (a checkout whose core has the choice)
    if not hasattr(m, "set_refresh"):
        return None
    chosen = m.refresh["path"]
    try:
        got = {"chosen": chosen}
        for path in ("tensor", "symmetric") + (("particles",) if chosen == "particles" else ()):
            m.set_refresh(path=path)
            got[path] = slopes(m, n)["cpu_ns"]
        return got
    finally:
        m.set_refresh(path=chosen)

def slopes(m, n, n_freeze=10, rest=False):
    wall, cpu = [], []
    for _ in range(repeats):
        pair = []
        for count in (n, 2 * n):
            m.reset()
            if rest:
                lib.rom_set_initial_state_scale(m.state, 0.0, buf, 1024)
            m.set_n_freeze(n_freeze)
            w0, c0 = time.perf_counter(), time.thread_time()
            m.advance(count)
            pair.append((time.perf_counter() - w0, time.thread_time() - c0))
        wall.append((pair[1][0] - pair[0][0]) / n * 1e9)
        cpu.append((pair[1][1] - pair[0][1]) / n * 1e9)
    return {"wall_ns": statistics.median(wall), "cpu_ns": statistics.median(cpu)}

out = {}
ten = load_scene("tenmode")
window = ten.snapshots.get("window")
ten = derive_scene(ten, {"domain": {"T": float(window[1]) if window else ten.T}})
m, kv, kr = model_of(ten)
m.advance(1000)
out["k12"] = {**slopes(m, 100_000), "k_v": kv, "k_rho": kr}
out["k12_rest"] = {**slopes(m, 100_000, rest=True), "k_v": kv, "k_rho": kr}
out["k12_paths"] = paths(m, 100_000)
df = load_scene("damped_forced")
m, kv, kr = model_of(df)
out["portless"] = {**slopes(m, 50_000), "k_v": kv, "k_rho": kr}
m, kv, kr = model_of(df, (0.3, 0.7))
out["ports"] = {**slopes(m, 5_000), "k_v": kv, "k_rho": kr}
out["ports_paths"] = paths(m, 5_000)
print("CORE-JSON " + json.dumps(out))
"""


def _env(checkout, cache):
    env = dict(os.environ)
    env["PYTHONPATH"] = import_path(checkout)
    env["SPHROM_CACHE"] = str(cache)
    env.pop("PYTHONSTARTUP", None)
    return env


def _run(argv, env, cwd):
    """(wall s, CPU s of the child) of one whole process; raises on a non-zero exit."""
    before = os.times()
    t0 = time.perf_counter()
    done = subprocess.run(argv, env=env, cwd=cwd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    wall = time.perf_counter() - t0
    after = os.times()
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(map(str, argv))} failed: {done.stderr.strip().splitlines()[-1:]}")
    return wall, (after.children_user - before.children_user) + (after.children_system - before.children_system)


def paired(label, commands, repeats, prepare=None, bar=None):
    """Time ``commands`` ({"after": (argv, env, cwd), "before": ...}) in turn, ``repeats`` pairs after one
    warm-up each; ``prepare(which)`` runs before each timed run, off the clock.  Returns a row."""
    names = list(commands)
    for name in names:                                      # warm-up (page cache, numba's cache, the SPH cache)
        if prepare:
            prepare(name)
        _run(*commands[name])
    times = {name: [] for name in names}
    for _ in range(repeats):
        for name in names:
            if prepare:
                prepare(name)
            times[name].append(_run(*commands[name]))
        if bar is not None:
            bar.update(1)
    row = {"command": label}
    for name in names:
        row[f"{name}_wall_s"] = statistics.median(w for w, _ in times[name])
        row[f"{name}_cpu_s"] = statistics.median(c for _, c in times[name])
    if "before" in times:
        row["ratio_wall"] = statistics.median(b[0] / a[0] for a, b in zip(times["after"], times["before"]))
        row["ratio_cpu"] = statistics.median(b[1] / a[1] for a, b in zip(times["after"], times["before"])
                                             if a[1] > 0)
    return row


def core_figures(checkout, cache, repeats):
    """The frozen core's figures of one checkout (CORE_SCRIPT in a subprocess with its code)."""
    done = subprocess.run([sys.executable, "-c", CORE_SCRIPT, str(repeats)], env=_env(checkout, cache),
                          cwd=str(checkout), capture_output=True, text=True)
    line = next((x for x in done.stdout.splitlines() if x.startswith("CORE-JSON ")), None)
    if done.returncode != 0 or line is None:
        raise RuntimeError(f"the core measurement failed in {checkout}: {done.stderr.strip().splitlines()[-1:]}")
    return json.loads(line.split(" ", 1)[1])


def measure(before=None, repeats=5, cold=True, progress=True, workdir=None):
    """Every row of the module docstring: {"commands": [...], "core": {"after": ..., "before": ...}}."""
    checkouts = {"after": HERE, **({"before": Path(before).resolve()} if before else {})}
    py = sys.executable
    load_start = load_average()
    with tempfile.TemporaryDirectory(dir=workdir) as tmp:
        tmp = Path(tmp)
        caches = {"after": Path(os.environ.get("SPHROM_CACHE") or tmp / "cache-after"),
                  "before": tmp / "cache-before"}
        fmu = tmp / "tenmode-exact.fmu"
        _run([py, "-m", "sphrom", "fmu", "tenmode", "--model", "exact", "--no-bounds", "--out", str(fmu), "--quiet"],
             _env(HERE, caches["after"]), str(tmp))

        def cmd(*argv):
            return {name: ([py, *argv], _env(path, caches[name]), str(tmp)) for name, path in checkouts.items()}

        rows_plan = [("bare Python start (`python -c pass`)", cmd("-c", "pass")),
                     ("`python -c 'import numpy, fmpy'`", cmd("-c", "import numpy, fmpy")),
                     ("`sphrom --help`", cmd("-m", "sphrom", "--help")),
                     ("`sphrom cosim` tenmode's exact FMU, 10 s", cmd("-m", "sphrom", "cosim", str(fmu), "--out",
                                                                      str(tmp / "cosim.csv"))),
                     ("`sphrom fmu tenmode`, warm cache", cmd("-m", "sphrom", "fmu", "tenmode", "--out",
                                                              str(tmp / "warm.fmu"), "--quiet"))]
        total = len(rows_plan) * repeats + (repeats if cold else 0) + 2
        rows = []
        with progress_bar(total=total, desc="bench fast", enabled=progress) as bar:
            for label, commands in rows_plan:
                rows.append(paired(label, commands, repeats, bar=bar))
            if cold:
                builds = {name: caches[name] / "build" for name in checkouts}
                colds = {name: tmp / f"cold-{name}" for name in checkouts}

                def prepare(name):            # an empty SPH/POD cache with the binaries built, off the clock
                    shutil.rmtree(colds[name], ignore_errors=True)
                    colds[name].mkdir()
                    shutil.copytree(builds[name], colds[name] / "build", symlinks=True)
                commands = {name: ([py, "-m", "sphrom", "fmu", "tenmode", "--out", str(tmp / f"cold-{name}.fmu"),
                                    "--quiet"], _env(checkouts[name], colds[name]), str(tmp))
                            for name in checkouts}
                rows.append(paired("`sphrom fmu tenmode`, cold SPH/POD cache (binaries built)", commands, repeats,
                                   prepare=prepare, bar=bar))
            core = {}
            for name, path in checkouts.items():
                core[name] = core_figures(path, caches[name], repeats)
                bar.update(1)
    return {"commands": rows, "core": core, "cpu": cpu_model(), "load_start": load_start,
            "load_end": load_average(), "repeats": repeats, "before": str(checkouts.get("before", "")),
            "python": sys.version.split()[0]}


def _load(x):
    return " / ".join(f"{v:g}" for v in x) if x else "unavailable"


def section(result, command):
    """The Markdown section of BENCHMARKS.md (lines)."""
    has_before = bool(result["before"])
    lines = ["## Fast end to end: before and after", "",
             f"Produced by `{command}` on {result['cpu']}, Python {result['python']}, load average (1 / 5 / 15 "
             f"min) {_load(result['load_start'])} at the start, {_load(result['load_end'])} at the end. "
             + (f"*Before*: the checkout {result['before']} (the code before this round's speed work), *after*: "
                "this checkout; each command run in turn in both (A B A B ..., PYTHONPATH per command), "
                if has_before else "This checkout only; ")
             + f"medians of {result['repeats']} whole processes after one warm-up each; ratios taken pair by pair "
             "(before / after: above 1 is faster now). Wall seconds are what a user waits, CPU seconds (user + "
             "system of the child) the work, which on the shared machine moves less with the other load.", "",
             "| command | before wall [s] | after wall [s] | before / after (wall) | before CPU [s] | after CPU [s] "
             "| before / after (CPU) |", "| --- | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for r in result["commands"]:
        b = lambda key, spec=".3f": format(r[key], spec) if key in r else "—"          # noqa: E731
        lines.append(f"| {r['command']} | {b('before_wall_s')} | {r['after_wall_s']:.3f} | {b('ratio_wall', '.2f')} | "
                     f"{b('before_cpu_s')} | {r['after_cpu_s']:.3f} | {b('ratio_cpu', '.2f')} |")
    base = {r["command"]: r for r in result["commands"]}
    bare, imports = (base.get("bare Python start (`python -c pass`)"), base.get("`python -c 'import numpy, fmpy'`"))
    helped, cosim = base.get("`sphrom --help`"), base.get("`sphrom cosim` tenmode's exact FMU, 10 s")
    if bare and imports and helped and cosim:
        lines += ["", f"Targets (after, wall): `sphrom --help` {helped['after_wall_s'] - bare['after_wall_s']:+.3f} s "
                  f"from a bare Python start (target ≤ +0.1 s); `sphrom cosim` "
                  f"{cosim['after_wall_s'] / imports['after_wall_s']:.2f}× the time of importing numpy and fmpy "
                  "(target ≤ 2.5×)."]
    core = result["core"]
    lines += ["", "The frozen core (fmu_src/rom_frozen.c through ctypes, each checkout's own code and build): ns per "
              "internal step as the slope between M and 2M steps, medians; n_freeze = 10.", "",
              "| case | k_v, k_ρ | before CPU ns | after CPU ns | before / after (CPU) | before wall ns | "
              "after wall ns |", "| --- | --- | ---: | ---: | ---: | ---: | ---: |"]
    cases = [("k12", "tenmode, N = 400, k = 12 (target ≤ 150 ns)"),
             ("k12_rest", "the same at rest (initial_state_scale 0, f = 0)"),
             ("portless", "damped_forced, k = 12, no ports"),
             ("ports", "damped_forced, k = 12, ports at x/L = 0.3, 0.7")]
    for key, label in cases:
        a, b = core["after"][key], core.get("before", {}).get(key)
        lines.append(f"| {label} | {a['k_v']}, {a['k_rho']} | {'—' if b is None else format(b['cpu_ns'], '.1f')} | "
                     f"{a['cpu_ns']:.1f} | {'—' if b is None else format(b['cpu_ns'] / a['cpu_ns'], '.2f')} | "
                     f"{'—' if b is None else format(b['wall_ns'], '.1f')} | {a['wall_ns']:.1f} |")
    a = core["after"]
    lines += ["", f"Port FMU against its portless model per internal step (after, CPU): "
              f"{a['ports']['cpu_ns'] / a['portless']['cpu_ns']:.1f}× (target ≤ 2×); at rest against moving "
              f"(after, CPU): {a['k12_rest']['cpu_ns'] / a['k12']['cpu_ns']:.2f}×."]
    for key, label in (("k12_paths", "k = 12"), ("ports_paths", "the port model")):
        got = a.get(key)
        if got:
            particles = (f", particles {got['particles']:.1f} (other bits: the Python model's refresh=\"direct\")"
                         if "particles" in got else "")
            lines.append(f"Refresh paths at {label} (after, CPU ns per step, n_freeze = 10; tensor and symmetric give "
                         f"the same bits): tensor {got['tensor']:.1f}, symmetric {got['symmetric']:.1f}{particles}; "
                         f"chosen: {got['chosen']} (the particles at packaging, else at load).")
    lines.append("")
    return lines


def main(argv=None):
    p = program_parser("fast", description=__doc__.split("\n\n")[0])
    p.add_argument("--before", metavar="CHECKOUT", help="another checkout of sphrom, timed in turn with this one")
    p.add_argument("--repeats", type=int, default=5, metavar="R")
    p.add_argument("--no-cold", action="store_true", help="skip the cold-cache packaging (the longest row)")
    p.add_argument("--report", metavar="FILE.md", help="replace (or add) the section of this Markdown file")
    p.add_argument("--out", metavar="FILE.json", help="write the figures as JSON")
    p.add_argument("--quiet", action="store_true")
    args = p.parse_args(argv)
    if args.repeats < 1:
        p.error(f"--repeats {args.repeats} is out of range (allowed: >= 1)")
    if args.before and not (Path(args.before) / "harness" / "__init__.py").is_file():
        p.error(f"--before {args.before}: not a checkout of sphrom (no harness/__init__.py)")
    result = measure(args.before, repeats=args.repeats, cold=not args.no_cold, progress=not args.quiet)
    given = argv if argv is not None else sys.argv[1:]
    lines = section(result, "sphrom bench fast" + (" " + " ".join(given) if given else ""))
    if args.out:
        with atomic_path(args.out) as tmp:
            Path(tmp).write_text(json.dumps(result, indent=1))
    if args.report:
        update_report(args.report, {lines[0]: lines})
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
