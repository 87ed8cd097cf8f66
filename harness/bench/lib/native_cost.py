"""The native doStep cost of an FMU with its certified error bounds against the same FMU without them.

The FMU's own binary in the native FMI 2 master ``sphrom_step_cost`` (fmu_src/tests/step_cost.c), beside a copy whose
model.bin has no bounds' sections (SH*): the ratio the error bounds cost per communication step, with the outputs
read (held to at most COST_TARGET) and with their bounds read too.  Where valgrind is installed, also the same
ratio in instructions (callgrind): a count that does not move with the machine's load, where the timings of a
shared machine do; and, for an FMU with a free response table, the same count past the table's end (t > t_end, where
the complement's modes that matter are continued by a recurrence instead of read from the table).

The timing on a loaded machine (:func:`timing_rounds`).  Each run is short (NATIVE_STEPS steps: milliseconds for most
FMUs) and the three variants' runs of a round are back to back, so the two runs of a ratio are close in time; the
ratio is the median over many rounds (NATIVE_ROUNDS, as many as fit in NATIVE_BUDGET).  On a loaded shared virtual
machine the thread CPU time of a run is off both ways (runs reported well below the usual time as well as above), so
a variant's minimum over the runs is no estimate, and a median over a few rounds moves with the one or two of them
that were off.  A run spans n_steps h from t = 0 (NATIVE_STEPS x STEP = 200 s): for an FMU whose free response table
ends sooner, its steps past the table's end too, so the native ratio mixes the two regimes the instruction counts
keep apart, and past the table a step's time need not follow its instructions.
"""

import tempfile
from pathlib import Path
from typing import NamedTuple

import numpy as np

NATIVE_STEPS = 20000    # steps per run of the native FMI master (native_cost)
NATIVE_ROUNDS = 15      # rounds of the three runs (native_cost: the ratios' medians over them), at least ``repeats``
NATIVE_BUDGET = 4.0     # [s] ... the rounds past ``repeats`` only while the timing has taken less than this
COST_TARGET = 1.3       # doStep with the bounds at most this x without (native, the outputs read)
STEP = 0.01             # [s] the communication step
COUNT_STEPS = (500, 1500)   # instruction counts: runs of these many steps, per step the difference / 1000 (setup cancels)
PAST_STEPS = 50             # past the table: the counted steps begin this many steps after t_end


class NativeCost(NamedTuple):
    """ns per step (medians over the rounds) and the ratios to the FMU without bounds (medians of each round's ratio:
    the three runs of a round are back to back, so a drift of the machine's speed falls on both sides of a ratio;
    :func:`timing_rounds`: NATIVE_ROUNDS rounds where they fit in NATIVE_BUDGET, else the ``repeats`` asked for)."""
    bounds_ns: float            # with the bounds, the outputs read
    read_ns: float              # ... and every bound read too
    plain_ns: float             # without the bounds' sections
    ratio: float                # bounds_ns / plain_ns per round, median
    read_ratio: float           # read_ns / plain_ns per round, median
    instr_bounds: float = float("nan")   # instructions per step with the bounds, the outputs read (callgrind)
    instr_plain: float = float("nan")    # ... without the bounds' sections
    instr_ratio: float = float("nan")    # instr_bounds / instr_plain (NaN: valgrind not installed)
    instr_past_bounds: float = float("nan")   # instructions per step with the bounds past the table's end (NaN: no
    instr_past_plain: float = float("nan")    # table, or no valgrind) ... without the bounds' sections, as far
    instr_past_ratio: float = float("nan")    # instr_past_bounds / instr_past_plain

    def row(self):
        """The benches' columns."""
        return {"native_ns_bounds": self.bounds_ns, "native_ns_read": self.read_ns, "native_ns_plain": self.plain_ns,
                "native_ratio": self.ratio, "native_read_ratio": self.read_ratio,
                "instr_bounds": self.instr_bounds, "instr_plain": self.instr_plain, "instr_ratio": self.instr_ratio,
                "instr_past_bounds": self.instr_past_bounds, "instr_past_plain": self.instr_past_plain,
                "instr_past_ratio": self.instr_past_ratio}


NO_COST = NativeCost(*(float("nan"),) * 5)


def instructions_per_step(command, steps=COUNT_STEPS):
    """Instructions per step of the native master's ``command`` (its arguments but --steps) under callgrind: the
    difference of the totals of runs of ``steps[1]`` and ``steps[0]`` steps over their difference (the setup, the
    loading and the first steps cancel).  NaN where valgrind is not installed."""
    import re
    import shutil
    import subprocess
    if shutil.which("valgrind") is None:
        return float("nan")
    totals = []
    with tempfile.TemporaryDirectory(prefix="sphrom-callgrind-") as tmp:
        for n in steps:
            out = Path(tmp) / f"callgrind.{n}"
            done = subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}", *command,
                                   "--steps", str(n)], capture_output=True, text=True, check=False)
            found = re.search(r"^totals: (\d+)", out.read_text(), re.M) if out.exists() else None
            if done.returncode != 0 or not found:
                raise RuntimeError(f"callgrind on {command[0]}: {done.stderr.strip()[-300:]}")
            totals.append(int(found.group(1)))
    return (totals[1] - totals[0]) / (steps[1] - steps[0])


def timing_rounds(run, repeats, rounds=NATIVE_ROUNDS, budget=NATIVE_BUDGET, clock=None):
    """The times of ``run(i)`` (i = 0, 1, 2: the three variants of :func:`native_cost`) in rounds: each round the
    three back to back, in turn forwards and backwards (a drift of the machine's speed falls on both sides of a
    ratio), ``repeats`` rounds at least and up to ``rounds`` while the rounds so far took less than ``budget`` [s]
    (an FMU of costly steps stays at ``repeats``).  ``clock``: seconds (time.perf_counter).  Returns three lists,
    one time per round each."""
    import time
    clock = clock or time.perf_counter
    times = [[], [], []]
    start = clock()
    r = 0
    while r < max(int(repeats), 1) or (r < rounds and clock() - start < budget):
        for i in (range(3) if r % 2 == 0 else reversed(range(3))):
            times[i].append(run(i))
        r += 1
    return times


def native_cost(path, repeats, n_steps=NATIVE_STEPS, h=STEP):
    """:class:`NativeCost` (ns per step with the bounds, with the bounds read, without; the ratios) of the FMU at
    ``path`` in the native FMI 2 master
    ``sphrom_step_cost`` (fmu_src/tests/step_cost.c: the FMU's binary loaded with dlopen, per step fmi2SetReal of f
    (and of F_port_j: a spring to ground on each port of a port FMU), fmi2DoStep, fmi2GetReal of the outputs, with
    their bounds in the second figure), beside the same FMU without the bounds' sections (its modelDescription's
    guid set to that model.bin's token): thread CPU time, medians over the rounds (:func:`timing_rounds`: at least
    ``repeats``, up to NATIVE_ROUNDS within NATIVE_BUDGET) of runs of ``n_steps`` steps of ``h`` [s], the three
    back to back in each round; where the FMU has a free response table (its span t_end), the instruction counts
    also over the 1000 steps from PAST_STEPS steps past t_end.  None where the master was not built."""
    import json
    import re
    import statistics
    import subprocess
    import zipfile

    from ...fmu import layout
    from ...fmu.make.build import ensure_binaries
    from ...fmu.resources import pack, read, unpack
    driver = ensure_binaries(quiet=True).folder / "sphrom_step_cost"
    if not driver.exists():
        return None
    with tempfile.TemporaryDirectory(prefix="sphrom-native-cost-") as tmp:
        with_dir, bare_dir = Path(tmp) / "with", Path(tmp) / "bare"
        for folder in (with_dir, bare_dir):
            with zipfile.ZipFile(path) as z:
                z.extractall(folder)
        data = unpack((with_dir / "resources" / "model.bin").read_bytes())
        scal = data.sections.get("SHSCAL")
        nodes = int(scal[0, layout.column("SHSCAL", "nodes")]) if scal is not None else 0
        t_end = scal[0, layout.column("SHSCAL", "h_tab")] * (nodes - 1) if nodes > 1 else None
        n_ports = len(re.findall(r'name="F_port_\d+"', (with_dir / "modelDescription.xml").read_text()))
        data.sections = {k: v for k, v in data.sections.items() if not k.startswith("SH")}
        blob = pack(data)
        (bare_dir / "resources" / "model.bin").write_bytes(blob)
        md = bare_dir / "modelDescription.xml"
        md.write_text(re.sub(r'guid="[^"]*"', f'guid="{read(blob)[4]}"', md.read_text(), count=1))

        def command(folder, bounds):
            return [str(driver), str(folder.resolve()), "--probes", str(data.n_probes), "--ports", str(n_ports),
                    "--h", repr(h), "--repeats", "1"] + (["--bounds"] if bounds else [])

        def run(folder, bounds):
            cmd = command(folder, bounds) + ["--steps", str(n_steps)]
            done = subprocess.run(cmd, capture_output=True, text=True, check=False)
            if done.returncode != 0:
                raise RuntimeError(f"{driver.name} on {path}: {done.stderr.strip()}")
            return json.loads(done.stdout)["ns_per_step_cpu"]
        plan = ((with_dir, False), (with_dir, True), (bare_dir, False))
        times = timing_rounds(lambda i: run(*plan[i]), repeats)
        counts = [instructions_per_step(command(with_dir, False)), instructions_per_step(command(bare_dir, False))]
        past = [float("nan")] * 2
        if t_end is not None:
            first = int(np.ceil(t_end / h)) + PAST_STEPS
            steps = (first, first + COUNT_STEPS[1] - COUNT_STEPS[0])
            past = [instructions_per_step(command(with_dir, False), steps),
                    instructions_per_step(command(bare_dir, False), steps)]
    ratio = [a / c for a, c in zip(times[0], times[2])]
    read_ratio = [b / c for b, c in zip(times[1], times[2])]
    return NativeCost(*(statistics.median(x) for x in (*times, ratio, read_ratio)), counts[0], counts[1],
                      counts[0] / counts[1], past[0], past[1], past[0] / past[1])


def cost_summary(rows, key="model", value="native_ratio"):
    """Per value of ``key``: (median, max, FMUs above COST_TARGET, FMUs) of the doStep ratio ``value`` (native_ratio:
    the native timing, the outputs read; instr_ratio: its instruction count) over the distinct FMUs of ``rows`` (one
    per scene, model and parametric point; rows without that ratio skipped)."""
    per_fmu = {}
    for r in rows:
        x = r.get(value, float("nan"))
        if r.get("note") or not np.isfinite(x):
            continue
        per_fmu[(r.get("scene"), r.get("model"), r.get("point"))] = (r[key], x)
    out = {}
    for group, x in per_fmu.values():
        out.setdefault(group, []).append(x)
    return {g: (float(np.median(x)), float(np.max(x)), int(np.sum(np.array(x) > COST_TARGET)), len(x))
            for g, x in out.items()}


RATIOS = (("native_ratio", "native FMI 2 master, thread CPU time, the outputs read", "native ratio"),
          ("instr_ratio", "the same runs' instructions per step, callgrind: independent of the machine's load",
           "instruction ratio"),
          ("instr_past_ratio", "instructions per step past the free response table's end, where the complement's "
           "modes that matter are continued, callgrind; the FMUs with a table", "past-table instruction ratio"))


def cost_lines(rows):
    """The doStep ratios per model (cost_summary: the native timing, and the instruction count where measured) as
    tables' lines ([] where no FMU was timed)."""
    lines = []
    for value, what, name in RATIOS:
        costs = cost_summary(rows, value=value)
        if not costs:
            continue
        lines += ["", f"doStep with the bounds against without ({what}; the target is at most {COST_TARGET:g}x), "
                  "over the FMUs:", "",
                  f"| model | FMUs | {name} median | max | above {COST_TARGET:g} |", "| --- | ---: | ---: | ---: | ---: |"]
        for model in sorted(costs):
            med, mx, above, n = costs[model]
            lines.append(f"| {model} | {n} | {med:.2f} | {mx:.2f} | {above} |")
        med, mx, above, n = next(iter(cost_summary([{**r, "all": "all"} for r in rows], "all", value).values()))
        lines.append(f"| all | {n} | {med:.2f} | {mx:.2f} | {above} |")
    return lines
