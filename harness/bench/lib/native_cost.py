"""The native doStep cost of an FMU with its certified error bounds against the same FMU without them.

The FMU's own binary in the native FMI 2 master ``sphrom_step_cost`` (fmu_src/tests/step_cost.c), beside a copy whose
model.bin has no bounds' sections (SH*): the ratio the error bounds cost per communication step, with the outputs
read (held to at most COST_TARGET) and with their bounds read too.
"""

import tempfile
from pathlib import Path
from typing import NamedTuple

import numpy as np

NATIVE_STEPS = 20000    # steps per run of the native FMI master (native_cost)
COST_TARGET = 1.3       # doStep with the bounds at most this x without (native, the outputs read)
STEP = 0.01             # [s] the communication step


class NativeCost(NamedTuple):
    """ns per step (medians over the rounds) and the ratios to the FMU without bounds (medians of each round's ratio:
    the three runs of a round are back to back, so a drift of the machine's speed falls on both sides of a ratio)."""
    bounds_ns: float            # with the bounds, the outputs read
    read_ns: float              # ... and every bound read too
    plain_ns: float             # without the bounds' sections
    ratio: float                # bounds_ns / plain_ns per round, median
    read_ratio: float           # read_ns / plain_ns per round, median

    def row(self):
        """The benches' columns."""
        return {"native_ns_bounds": self.bounds_ns, "native_ns_read": self.read_ns, "native_ns_plain": self.plain_ns,
                "native_ratio": self.ratio, "native_read_ratio": self.read_ratio}


NO_COST = NativeCost(*(float("nan"),) * 5)


def native_cost(path, repeats, n_steps=NATIVE_STEPS, h=STEP):
    """:class:`NativeCost` (ns per step with the bounds, with the bounds read, without; the ratios) of the FMU at
    ``path`` in the native FMI 2 master
    ``sphrom_step_cost`` (fmu_src/tests/step_cost.c: the FMU's binary loaded with dlopen, per step fmi2SetReal of f
    (and of F_port_j: a spring to ground on each port of a port FMU), fmi2DoStep, fmi2GetReal of the outputs, with
    their bounds in the second figure), beside the same FMU without the bounds' sections (its modelDescription's
    guid set to that model.bin's token): thread CPU time, medians over ``repeats`` runs of ``n_steps`` steps of
    ``h`` [s], the three in turn.  None where the master was not built."""
    import json
    import re
    import statistics
    import subprocess
    import zipfile

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
        n_ports = len(re.findall(r'name="F_port_\d+"', (with_dir / "modelDescription.xml").read_text()))
        data.sections = {k: v for k, v in data.sections.items() if not k.startswith("SH")}
        blob = pack(data)
        (bare_dir / "resources" / "model.bin").write_bytes(blob)
        md = bare_dir / "modelDescription.xml"
        md.write_text(re.sub(r'guid="[^"]*"', f'guid="{read(blob)[4]}"', md.read_text(), count=1))

        def run(folder, bounds):
            cmd = [str(driver), str(folder.resolve()), "--probes", str(data.n_probes), "--ports", str(n_ports),
                   "--steps", str(n_steps), "--h", repr(h), "--repeats", "1"] + (["--bounds"] if bounds else [])
            done = subprocess.run(cmd, capture_output=True, text=True, check=False)
            if done.returncode != 0:
                raise RuntimeError(f"{driver.name} on {path}: {done.stderr.strip()}")
            return json.loads(done.stdout)["ns_per_step_cpu"]
        times = [[], [], []]
        plan = ((with_dir, False), (with_dir, True), (bare_dir, False))
        for r in range(repeats):             # a round: the three back to back, in turn forwards and backwards
            for i in (range(3) if r % 2 == 0 else reversed(range(3))):
                times[i].append(run(*plan[i]))
    ratio = [a / c for a, c in zip(times[0], times[2])]
    read_ratio = [b / c for b, c in zip(times[1], times[2])]
    return NativeCost(*(statistics.median(x) for x in (*times, ratio, read_ratio)))


def cost_summary(rows, key="model"):
    """Per value of ``key``: (median, max, FMUs above COST_TARGET, FMUs) of the native doStep ratio (outputs read)
    over the distinct FMUs of ``rows`` (one per scene, model and parametric point; rows without a ratio skipped)."""
    per_fmu = {}
    for r in rows:
        x = r.get("native_ratio", float("nan"))
        if r.get("note") or not np.isfinite(x):
            continue
        per_fmu[(r.get("scene"), r.get("model"), r.get("point"))] = (r[key], x)
    out = {}
    for group, x in per_fmu.values():
        out.setdefault(group, []).append(x)
    return {g: (float(np.median(x)), float(np.max(x)), int(np.sum(np.array(x) > COST_TARGET)), len(x))
            for g, x in out.items()}


def cost_lines(rows):
    """The native doStep ratio per model (cost_summary) as a table's lines ([] where no FMU was timed)."""
    costs = cost_summary(rows)
    if not costs:
        return []
    lines = ["", f"doStep with the bounds against without (native FMI 2 master, the outputs read; the target is at "
             f"most {COST_TARGET:g}x), over the FMUs:", "",
             f"| model | FMUs | native ratio median | max | above {COST_TARGET:g} |", "| --- | ---: | ---: | ---: | ---: |"]
    for model in sorted(costs):
        med, mx, above, n = costs[model]
        lines.append(f"| {model} | {n} | {med:.2f} | {mx:.2f} | {above} |")
    med, mx, above, n = next(iter(cost_summary([{**r, "all": "all"} for r in rows], "all").values()))
    lines.append(f"| all | {n} | {med:.2f} | {mx:.2f} | {above} |")
    return lines
