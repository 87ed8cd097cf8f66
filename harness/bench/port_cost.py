"""The cost per communication step of the FMUs with and without ports, measured by a native FMI 2 master.

``python -m sphrom.bench.port_cost`` / ``sphrom bench port_cost [--steps M] [--repeats R] [--ks 4,8,12,24]
[--out validation/benchmarks] [--report BENCHMARKS.md] [--quiet]``

Each FMU is packaged as ``sphrom fmu`` makes it (FMI 2, the scene's defaults, with its certified error bounds) and
driven by ``sphrom_step_cost`` (fmu_src/tests/step_cost.c): the FMU's own binary loaded with ``dlopen`` as an importer
does, no Python in the loop; per step fmi2SetReal of f and of each F_port_j (a spring of 5 N/m to ground on each port,
its force from the port velocity read after the last step), fmi2DoStep of 1 ms, fmi2GetReal of v_probe_j, rho_probe_j
and v_port_j.  The thread's CPU time over M steps (the first, which computes a new step length's exponentials, not
counted), the median of R runs taken in turn over all the FMUs (A B C A B C ...: a drift of the shared machine falls
on all); the ratios of a port FMU to its portless one are taken run by run, then their median.  ``floor``: the same
loop without fmi2DoStep, the cost of the calls themselves.

Cases: tenmode (N = 400, undamped) with a port at x/L = 0.5 and damped_forced (N = 100) with ports at 0.3 and 0.7,
the frozen and the exact model: without ports, with ports (the port channel: the portless model plus the channel,
:mod:`sphrom.rom.port_channel`) and with the ports in the basis as before (build option ``port_channel=False``, the
frozen one with symplectic Euler, the linear one dense: the FMUs of before the channel); the exact model (k = 12) and
the balanced model (order :data:`BALANCED_ORDER`) without ports in their block form (the default) and dense (build
option ``blocks=False``).  Against k: tenmode's frozen and exact FMUs at each k of ``--ks``, without and with the
port, and the exact one dense.

Beside each time, the multiply-adds of one communication step as the C core does them (:func:`multiply_adds`): the
model's own (the frozen model's internal steps and refreshes; the linear model's step, dense or block by block), the
port channel's (its planes' step and the output rows once), the error bounds' shadow (its planes' step and the check
of the velocity bounds against error_tolerance after each step) and the outputs read; the sincos calls per step
(:func:`trig_calls`); and for a linear FMU its time over ``floor + multiply-adds x ns per multiply-add``, the rate of
the core's own row loop timed by ``sphrom_step_cost --calibrate`` in each round (:func:`calibrate`).  The a priori
bounds (``sphrom fmu --a-priori-bounds``) are not computed: as ``sphrom fmu`` packages by default.
"""

from __future__ import annotations

import json
import statistics
import subprocess
import sys
import tempfile
import time
import zipfile
from pathlib import Path

from ..options import int_at_least, int_list
from ..runio import atomic_path
from . import program_command, program_parser
from .lib.document import fmt, publish

# The measuring modules (numba through the model code, scipy, fmpy, matplotlib) are imported inside the functions:
# `sphrom bench NAME --help` answers before they load (tests/test_bench_programs.py).

HEADING = "## Ports at their cost floor: the cost per communication step"
CASES = (("tenmode", (0.5,)), ("damped_forced", (0.3, 0.7)))
MODELS = ("frozen", "exact")
BALANCED_ORDER = 24          # the balanced model's order: the exact model's state size at k = 12
STEP = 1e-3                  # the communication step [s]
SLOW_STEPS = 2000            # steps of an FMU of before the channel (up to 0.3 ms each)


def multiply_adds(data, h=STEP):
    """{part: multiply-adds} of one communication step of length ``h`` [s] of the FMU whose model.bin is ``data``
    (unpacked), as the C core computes them: ``model`` (the kind's step: fmu_src/rom_frozen.c's internal steps and
    1/n_freeze of a refresh each, or rom_exact.c's dense step), ``channel`` (rom_port.c: each plane's step and its
    inputs with held port forces, the output rows and the state's norm for their bounds once), ``shadow``
    (rom_bound.c: each plane's step, and the velocity rows checked against error_tolerance after each step),
    ``outputs`` (the probe and port rows read) and ``total``."""
    from ..fmu.kinds import kind_of
    import numpy as np
    from ..fmu.kinds.frozen import refresh_matrix_work
    s = data.sections
    P, n_ports = data.n_probes, (s["PORTC"].shape[0] if "PORTC" in s else 0)
    port_inputs = s["PORTB"].shape[0] if "PORTB" in s else 0
    pad = lambda k, m=4: -(-k // m) * m                                   # noqa: E731
    kv, kr = data.k_v, data.k_rho
    if kind_of(data).INTERNAL_STEP:
        n_int = max(1, int(round(h / data.dt)))
        kvp, krp = pad(kv), pad(kr)
        step = krp * kv + kvp * (kr + (kv if data.D is not None else 0)) + kvp + krp + kv + kr
        particles = s["PARTUR"].shape[0] if "PARTUR" in s else 0
        refresh = refresh_matrix_work(kv, kr, particles) + kvp + port_inputs * kv
        model = n_int * (step + refresh / max(int(data.n_freeze), 1))
        outputs = P * (kv + kr) + n_ports * kv
    elif getattr(data, "blocks", False):        # rom_exact.c block by block: each row over its own block
        k = data.k
        m = (1 if data.B is not None else 0) + port_inputs
        sizes = block_sizes(data.A)
        model = float(np.sum(sizes ** 2)) + 2 * k * m    # (a skew one's rotations too: no free path)
        outputs = 3 * P * k + n_ports * kv
    else:
        k = data.k
        m = (1 if data.B is not None else 0) + port_inputs
        model = k * k + 2 * k * m + (k * k + 3 * k if data.Q is not None else 0)
        outputs = 3 * P * k + n_ports * kv
    channel = 0.0
    if "PCSCAL" in s:
        planes = int(s["PCSCAL"][0, 0])
        cp = pad(planes, 16)
        rows = 3 * P + n_ports
        # each plane's step with held port forces (the master's here): its input from the ports, Phi (p, q) and g0
        # times the input (a ramp adds g1 and its input: 2 + n_ports); the output rows and |w|^2 (the rows'
        # bounds) once
        channel = cp * (6 + n_ports) + rows * cp + 2 * cp
    shadow = 0.0
    if "SHSCAL" in s:
        order, planes, m = (int(x) for x in s["SHSCAL"][0, :3])
        checked = P + n_ports if s["SHSCAL"][0, 10] > 0 else 0         # velocity bounds against error_tolerance
        shadow = planes * (4 + 4 * m) + 3 * m * m + order + checked * order
    total = model + channel + shadow + outputs
    return {"model": float(model), "channel": float(channel), "shadow": float(shadow), "outputs": float(outputs),
            "total": float(total)}


def block_sizes(A):
    """The sizes (1 or 2) of the blocks of a block-diagonal A in order (rom_exact.c block_size: A[i+1][i] != 0
    starts a 2 x 2 block)."""
    import numpy as np
    A = np.asarray(A, float)
    sizes, i = [], 0
    while i < A.shape[0]:
        b = 2 if i + 1 < A.shape[0] and A[i + 1, i] != 0.0 else 1
        sizes.append(b)
        i += b
    return np.asarray(sizes, int)


def trig_calls(data):
    """The sincos calls of one communication step of a linear model.bin ``data``: the free response of a dense
    undamped one (its Schur form) evaluated at the time itself, one per 2 x 2 rotation; 0 else (the block form
    steps its rotations, their cos and sin once per step length)."""
    import numpy as np
    if not getattr(data, "blocks", False) and getattr(data, "Q", None) is not None:
        return int(np.count_nonzero(np.diag(data.S, -1) != 0.0))
    return 0


def package(scene_name, model, ports, k, path, binaries, *, before=False, dense=False):
    """Package the FMU of the case (``before``: the ports in the basis, symplectic Euler for the frozen model, the
    linear model dense, as before the channel; ``dense``: a linear model in its dense form, build option
    ``blocks=False``) at ``path``; returns its unpacked model.bin."""
    from ..rom.registry import get_model
    from ..fmu.make.package import package_fmu
    from ..fmu.resources import unpack
    from ..scene import load_scene
    linear = get_model(model).linear
    build = {}
    if before:
        build["port_channel"] = False
    if linear and (before or dense):
        build["blocks"] = False
    options = {"build_options": build} if build else {}
    if before and not linear:                          # the time-stepped model: symplectic with ports
        options["integrator"] = "symplectic"
    # bounds=False: as `sphrom fmu` packages by default (no a priori bounds: constants that cost no step, whose
    # H-infinity bisection at N = 400 is minutes of dense eigenvalues); the run-time certified bounds are kept
    package_fmu(load_scene(scene_name), path, k=k, fmi=2, progress=False, binaries=binaries, model=model,
                ports=ports or None, verify=False, bounds=False, **options)
    return unpack(zipfile.ZipFile(path).read("resources/model.bin"))


def unzip(path, folder):
    """The FMU at ``path`` unzipped into ``folder`` (a new folder), returned."""
    folder = Path(folder)
    folder.mkdir(parents=True)
    with zipfile.ZipFile(path) as z:
        z.extractall(folder)
    return folder


def step_cost(driver, folder, n_probes, n_ports, steps, *, h=STEP, floor=False, impedance=0.0):
    """One run of the native master (fmu_src/tests/step_cost.c) on the unzipped FMU ``folder``: its JSON line."""
    cmd = [str(driver), str(folder), "--probes", str(n_probes), "--ports", str(n_ports), "--steps", str(steps),
           "--h", repr(h), "--repeats", "1", "--scale", "1"]
    if floor:
        cmd.append("--floor")
    if impedance:
        cmd += ["--impedance", repr(impedance)]
    done = subprocess.run(cmd, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise RuntimeError(f"{driver.name} on {folder.name}: {done.stderr.strip()}")
    return json.loads(done.stdout)


def cases(ks, before=True):
    """[(label, scene, model, ports, k, before, dense)] of the measurement (module docstring)."""
    out = []
    for scene, ports in CASES:
        for model in MODELS:
            out += [(f"{scene} {model}", scene, model, (), 12, False, False),
                    (f"{scene} {model} ports", scene, model, ports, 12, False, False)]
            if before:
                out.append((f"{scene} {model} ports (before)", scene, model, ports, 12, True, False))
        out += [(f"{scene} exact (dense)", scene, "exact", (), 12, False, True),
                (f"{scene} balanced r={BALANCED_ORDER}", scene, "balanced", (), BALANCED_ORDER, False, False),
                (f"{scene} balanced r={BALANCED_ORDER} (dense)", scene, "balanced", (), BALANCED_ORDER, False, True)]
    for k in ks:
        if k == 12:
            continue
        for model in MODELS:
            out += [(f"tenmode {model} k={k}", "tenmode", model, (), k, False, False),
                    (f"tenmode {model} ports k={k}", "tenmode", model, (0.5,), k, False, False)]
        out.append((f"tenmode exact k={k} (dense)", "tenmode", "exact", (), k, False, True))
    return out


def _linear(model):
    """Whether the registered ``model`` is linear (exact in time: the dense and block forms apply)."""
    from ..rom.registry import get_model          # numba's load deferred: `sphrom bench port_cost --help` is quick
    return get_model(model).linear


def calibrate(driver, repeats=5):
    """ns per multiply-add of the core's row loop on this machine (``sphrom_step_cost --calibrate``)."""
    done = subprocess.run([str(driver), "--calibrate", "--repeats", str(repeats)], capture_output=True, text=True,
                          check=False)
    if done.returncode != 0:
        raise RuntimeError(f"{driver.name} could not time its multiply-add rate: {done.stderr.strip()}")
    return float(json.loads(done.stdout)["ns_per_madd"])


def measure(ks=(4, 8, 12, 24), steps=20000, repeats=5, progress=True, workdir=None, before=True):
    """Rows (dict) per FMU: its sizes, multiply-adds and CPU ns per step (median), the floor, and for a port FMU its
    ratio to the portless FMU of the same scene, model and k (median of the run-by-run ratios); for a linear one
    its cost against ``floor + multiply-adds x ns per multiply-add`` (:func:`calibrate`, taken in each round)."""
    from ..fmu.kinds import kind_of
    from ..fmu.make.build import ensure_binaries
    from ..progress import progress_bar
    binaries = ensure_binaries(quiet=not progress)
    driver = binaries.folder / "sphrom_step_cost"
    if not driver.exists():
        raise RuntimeError(f"the native master {driver} was not built (POSIX, SPHROM_BUILD_TESTS)")
    with tempfile.TemporaryDirectory(dir=workdir) as tmp:
        fmus = []
        todo = cases(ks, before=before)
        with progress_bar(len(todo), "packaging", unit="FMU", enabled=progress) as bar:
            for i, (label, scene, model, ports, k, old, dense) in enumerate(todo):
                path = Path(tmp) / f"{i}.fmu"
                data = package(scene, model, ports, k, path, binaries, before=old, dense=dense)
                fmus.append(dict(label=label, scene=scene, model=model, ports=len(ports), k=k, before=old,
                                 dense=dense,
                                 data=data, folder=unzip(path, Path(tmp) / f"{i}")))
                bar.update(1)
        for f in fmus:
            f["steps"] = SLOW_STEPS if f["before"] and f["ports"] else steps
            f["floor"] = step_cost(driver, f["folder"], f["data"].n_probes, f["ports"], f["steps"], floor=True)
        runs = {f["label"]: [] for f in fmus}
        rates = []
        with progress_bar(repeats, "timing", unit="round", enabled=progress) as bar:
            for _ in range(repeats):
                rates.append(calibrate(driver, 1))
                for f in fmus:
                    runs[f["label"]].append(step_cost(driver, f["folder"], f["data"].n_probes, f["ports"],
                                                      f["steps"]))
                bar.update(1)
    rows = []
    for f in fmus:
        cpu = [r["ns_per_step_cpu"] for r in runs[f["label"]]]
        data = f["data"]
        base = next((g for g in fmus if g["scene"] == f["scene"] and g["model"] == f["model"] and g["k"] == f["k"]
                     and not g["ports"] and not g["before"] and not g["dense"]), None)
        ratio = ratio_min = ratio_max = float("nan")
        if f["ports"] and base is not None:
            ratios = [a["ns_per_step_cpu"] / b["ns_per_step_cpu"]
                      for a, b in zip(runs[f["label"]], runs[base["label"]])]
            ratio, ratio_min, ratio_max = statistics.median(ratios), min(ratios), max(ratios)
        planes = int(data.sections["PCSCAL"][0, 0]) if "PCSCAL" in data.sections else 0
        shadow = int(data.sections["SHSCAL"][0, 0]) if "SHSCAL" in data.sections else 0
        madds = multiply_adds(data)
        linear = not kind_of(data).INTERNAL_STEP
        floor = f["floor"]["ns_per_step_cpu"]
        # a linear model's cost against its arithmetic at the core's rate: floor + madds x ns per madd (run by run)
        to_madds = statistics.median(c / (floor + madds["total"] * r) for c, r in zip(cpu, rates)) \
            if linear else float("nan")
        rows.append({"fmu": f["label"], "scene": f["scene"], "model": f["model"], "k": f["k"], "ports": f["ports"],
                     "before": f["before"], "dense": f["dense"], "blocks": bool(getattr(data, "blocks", False)),
                     "k_v": data.k_v, "k_rho": data.k_rho, "channel_planes": planes,
                     "shadow_order": shadow, "steps": f["steps"], "ns_per_step": statistics.median(cpu),
                     "ns_min": min(cpu), "ns_max": max(cpu), "floor_ns": floor,
                     "ratio_to_portless": ratio, "ratio_min": ratio_min, "ratio_max": ratio_max,
                     "ns_per_madd": statistics.median(rates),
                     "sincos": trig_calls(data) if linear else 0, "ratio_to_madds": to_madds,
                     **{f"madds_{k}": v for k, v in madds.items()}})
    return rows


def table(rows):
    """The report's table lines."""
    out = ["| FMU | form | k_v, k_ρ | channel planes | shadow order | multiply-adds per step (model + channel + "
           "shadow + outputs) | sincos | CPU ns per step (median) | floor ns | × (floor + madds) | × portless |",
           "| --- | --- | --- | ---: | ---: | --- | ---: | ---: | ---: | ---: | ---: |"]
    for r in rows:
        parts = f"{r['madds_total']:.0f} ({r['madds_model']:.0f} + {r['madds_channel']:.0f} + " \
                f"{r['madds_shadow']:.0f} + {r['madds_outputs']:.0f})"
        form = "blocks" if r["blocks"] else ("dense" if _linear(r["model"]) else "—")
        out.append(f"| {r['fmu']} | {form} | {r['k_v']}, {r['k_rho']} | {r['channel_planes'] or '—'} | "
                   f"{r['shadow_order'] or '—'} | {parts} | {r['sincos'] or '—'} | {r['ns_per_step']:.0f} | "
                   f"{r['floor_ns']:.0f} | {fmt(r['ratio_to_madds'], '.2f')} | {fmt(r['ratio_to_portless'], '.2f')} |")
    return out


def report_lines(rows, command, wall, steps, repeats):
    from .lib.timing import cpu_model, load_average
    lines = [HEADING, "",
             f"Produced by `{command}` ({cpu_model()}, load average {load_average()} at the end; {wall:.0f} s wall; "
             "`validation/benchmarks/port_cost.csv`).  Each FMU as `sphrom fmu` packages it (FMI 2, the scene's "
             "defaults, with its certified error bounds), driven by the native FMI 2 master `fmu_src/tests/"
             "step_cost.c` (the FMU's binary loaded with dlopen): per 1 ms step fmi2SetReal of f and of each F_port_j "
             "(a spring to ground on each port), fmi2DoStep, fmi2GetReal of v_probe_j, rho_probe_j, v_port_j and a "
             "second fmi2GetReal of v_port_j (the springs' feedback); the "
             f"thread's CPU time over {steps} steps ({SLOW_STEPS} for the FMUs of before the channel), the median of "
             f"{repeats} runs taken in turn over all the FMUs; × portless: the median of the run-by-run ratios (their "
             "range in the notes below the table) to the "
             "same scene's, model's and k's FMU without ports.  *ports*: the portless model plus the port channel "
             "(docs/fmu/ports.md); *(before)*: the ports in the basis (build option `port_channel=False`, the frozen "
             "model with symplectic Euler), as every port FMU was before.  floor: the same loop without fmi2DoStep "
             "(the FMI calls themselves).  Multiply-adds: `sphrom.bench.port_cost.multiply_adds`, the C core's "
             "arithmetic of one step (the frozen model's internal steps of its dt and 1/n_freeze of a refresh each; "
             "the linear model's step: k² dense, Σ b² over its 1 × 1 and 2 × 2 blocks in the block form, the "
             "default (build option `blocks`; *(dense)*: `blocks=False`); the channel's planes and its output rows "
             "once; the shadow's planes and the check of the velocity bounds against error_tolerance after every "
             "step); sincos: the calls per step beside them (a dense undamped model's free response at t).  "
             "× (floor + madds): a linear FMU's CPU time per step over floor + multiply-adds × "
             f"{rate_text(rows)} ns, the core's row loop timed by `sphrom_step_cost --calibrate` in each round "
             "(the median of the run-by-run ratios).", ""]
    lines += table(rows)
    lines.append("")
    for scene, ports in CASES:
        for model in MODELS:
            r = next((r for r in rows if r["fmu"] == f"{scene} {model} ports"), None)
            b = next((r for r in rows if r["fmu"] == f"{scene} {model} ports (before)"), None)
            p = next((r for r in rows if r["fmu"] == f"{scene} {model}"), None)
            if r and b and p:
                lines.append(f"- {scene} {model} with ports at x/L = {', '.join(f'{x:g}' for x in ports)}: "
                             f"{r['ratio_to_portless']:.2f}× its portless FMU per step (runs "
                             f"{r['ratio_min']:.2f} to {r['ratio_max']:.2f}; before: "
                             f"{b['ns_per_step'] / p['ns_per_step']:.1f}×; target ≤ 1.5× for the frozen one).")
    linear = [r for r in rows if _linear(r["model"]) and not r["before"]]
    for form, name in ((True, "block form (the default)"), (False, "dense form")):
        mine = [r for r in linear if r["blocks"] == form]
        if mine:
            worst = max(mine, key=lambda r: r["ratio_to_madds"])
            lines.append(f"- linear FMUs in the {name}: at most {worst['ratio_to_madds']:.2f}× floor + multiply-adds "
                         f"({worst['fmu']}; target ≤ 2× for the exact and balanced FMUs).")
    return lines


def rate_text(rows):
    """The median ns per multiply-add of the run, as printed."""
    rates = [r["ns_per_madd"] for r in rows if r.get("ns_per_madd") == r.get("ns_per_madd")]
    return f"{statistics.median(rates):.2f}" if rates else "—"


def write_csv(path, rows):
    keys = list(rows[0])
    with atomic_path(Path(path)) as tmp:
        Path(tmp).write_text("\n".join([",".join(keys)] + [",".join(
            f"{r[k]:.6g}" if isinstance(r[k], float) else str(r[k]) for k in keys) for r in rows]) + "\n")


def main(argv=None):
    p = program_parser("port_cost", description=__doc__.split("\n\n")[0])
    p.add_argument("--steps", type=int_at_least(10), default=20000, help="communication steps per run (default 20000)")
    p.add_argument("--repeats", type=int_at_least(1), default=5, help="runs per FMU, taken in turn (default 5)")
    p.add_argument("--ks", type=int_list(lo=1), default=(4, 8, 12, 24), help="the k of tenmode's sweep (default 4,8,12,24)")
    p.add_argument("--out", default="validation/benchmarks", metavar="FOLDER")
    p.add_argument("--report", default=None, metavar="BENCHMARKS.md")
    p.add_argument("--quiet", action="store_true")
    args = p.parse_args(argv)
    ks = tuple(args.ks)
    t0 = time.perf_counter()
    rows = measure(ks=ks, steps=args.steps, repeats=args.repeats, progress=not args.quiet)
    out = Path(args.out) / "port_cost.csv"
    out.parent.mkdir(parents=True, exist_ok=True)
    write_csv(out, rows)
    lines = report_lines(rows, program_command("port_cost", argv), time.perf_counter() - t0, args.steps,
                         args.repeats)
    if args.report:
        publish(args.report, HEADING, lines, [out], time.perf_counter() - t0)
    else:
        print("\n".join(lines))
        print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
