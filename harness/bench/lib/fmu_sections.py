"""The Markdown of the FMU's timings (:mod:`.fmu`): BENCHMARKS.md's sections "Headline" and "The FMU" (written by
``sphrom bench --report`` and by ``sphrom bench fmu``), and the tables of ``sphrom bench fmu-speed --out``
(bench_fmu.md).  Nothing here measures."""

from __future__ import annotations

from .document import fmt


def headline_section(fmu):
    """The FMU's headline sentences (end to end at 10 ms, the same-language ratio, the core); [] without FMU.

    ``fmu`` is the dict of :func:`sphrom.bench.lib.fmu.fmu_measurements` (``e2e``, ``core``, ``same``).
    """
    if not fmu:
        return []
    e2e, core, same = fmu["e2e"], fmu["core"], fmu["same"]
    sph_err = e2e["sph"]["probe_error_v_vs_exact"]
    lines = ["## Headline", ""]
    for r in e2e["rows"]:
        if r["step_s"] != 0.01:
            continue
        err = r["probe_error_v_vs_sph"]
        cond = ("—" if err is None or sph_err is None else
                f"probe v error against the full SPH {err:.2e}, "
                f"{'below' if err < sph_err else '**above**'} the full SPH's own error against exact ({sph_err:.2e})")
        lines.append(f"- {e2e['scene']}, FMU {r['model']} through sphrom's FMU driver at 10 ms: {r['fmu_e2e_s']:.4f} s "
                     f"for T = {e2e['T']:g} s against {e2e['sph']['call_s']:.3f} s for the Python full SPH (numba) "
                     f"in the same run: **{r['speedup']:.1f}×** (target ≥ 50×); {cond}.")
    lines.append(f"- C frozen step against the C full-SPH step at N = {same['n']}: **{same['ratio']:.1f}×** "
                 f"({same['frozen_ns']:.0f} ns against {same['sph_ns']:.0f} ns; target ≥ 10×).")
    lines.append("- C core per internal step at k = 12, n_freeze = 10: "
                 + ", ".join(f"{r['ns_per_step']:.0f} ns (N = {r['n']})" for r in core) + " (target ≤ 150 ns, "
                 "independent of N).")
    return lines + [""]


def fmu_tables(core, e2e, heading="##"):
    """The C core table and the end-to-end table (``sphrom bench-fmu``) as Markdown text.

    ``core``: rows of :func:`sphrom.bench.lib.fmu.core_rows`; ``e2e``: the dict of
    :func:`sphrom.bench.lib.fmu.end_to_end`, or None.
    """
    lines = [f"{heading} C core: ns per internal step (k = %d, n_freeze = %d)" % (core[0]["k"], core[0]["n_freeze"]),
             "", "Each figure the slope between runs of M and 2M internal steps from the same start (M = "
             f"{core[0]['steps']}; the call's fixed cost cancels): wall time (median, min, max of the repeats) and "
             "the thread's CPU time (median: the core's own time, whatever else the shared machine ran). Refresh: "
             "the path the core chose at load by measured cost (fmu_src/rom_frozen.c; both give the same bits).",
             "", "| N | k_v | k_rho | ns/step (median) | min | max | CPU ns/step | refresh |",
             "| ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- |"]
    for r in core:
        lines.append(f"| {r['n']} | {r['k_v']} | {r['k_rho']} | {r['ns_per_step']:.1f} | {r['ns_min']:.1f} | "
                     f"{r['ns_max']:.1f} | {fmt(r.get('ns_per_step_cpu'), '.1f')} | {r.get('refresh', '—')} |")
    if e2e is not None:
        sph_err = e2e["sph"].get("probe_error_v_vs_exact")
        lines += ["", f"{heading} End to end through sphrom's FMU driver: {e2e['scene']} (N = {e2e['n']}, "
                      f"T = {e2e['T']:g} s, {e2e['internal_steps']} internal steps, k_v = {e2e['k_v']}, "
                      f"k_rho = {e2e['k_rho']}, probes x/L = {', '.join(f'{p:g}' for p in e2e['probes'])})", "",
                  f"Full SPH (run_sph, numba, same run): {e2e['sph']['call_s']:.3f} s per run "
                  f"({e2e['sph']['loop_s']:.3f} s in its time loop); its probe-velocity error against the exact "
                  f"solution: {fmt(sph_err)}. Each FMU time is the whole "
                  "co-simulation through the FMU driver, harness/fmu/run/driver.py (extract, load, instantiate, "
                  "initialize, the loop reading every output, free); the probe error is "
                  "the FMU's probe velocities against the full SPH interpolated at the probes (relative L² over "
                  "the run, input held), at the first communication step. Per doStep: the slope between runs over "
                  "T/2 and T, paired (the fixed cost cancels), which includes the core's internal steps; fixed "
                  "cost: the intercept of the same runs; core: the C core alone over the same internal steps (its "
                  "slope), and per doStep; doStep call alone: the slope of 10^4 against 2·10^4 doSteps of one "
                  "internal step with no input and no output (the step's own work included).", "",
                  "| model | comm. step | doSteps | FMU [s] | speed-up vs full SPH | probe v error vs SPH | "
                  "fixed cost [s] | core [s] | per doStep [µs] | core per doStep [µs] | doStep call alone [µs] |",
                  "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
        for r in e2e["rows"]:
            lines.append(f"| {r.get('model', 'frozen')} | {r['step_s'] * 1e3:g} ms | {r['doSteps']} | "
                         f"{r['fmu_e2e_s']:.4f} | {r['speedup']:.1f}x | {fmt(r.get('probe_error_v_vs_sph'))} | "
                         f"{r['fixed_s']:.4f} | {fmt(r['core_s'], '.4f')} | {r['us_per_doStep_fmpy']:.1f} | "
                         f"{fmt(r.get('us_per_doStep_core'), '.1f')} | {fmt(r['us_per_doStep_bare_call'], '.1f')} |")
    return "\n".join(lines) + "\n"


def fmu_section(fmu):
    """The FMU's own tables and the same-language ratio; [] without FMU."""
    if not fmu:
        return []
    same = fmu["same"]
    return ["## The FMU", "", *fmu_tables(fmu["core"], fmu["e2e"], heading="###").splitlines(), "",
            f"### Same language: the C frozen step against the C full-SPH step (N = {same['n']})", "",
            f"`fmu_src/rom_frozen.c` at k = {same['k']} (k_v = {same['k_v']}, k_ρ = {same['k_rho']}), n_freeze = "
            f"{same['n_freeze']}: {same['frozen_ns']:.0f} ns per step; `fmu_src/sph.c` (eqs. 2.10-2.11, explicit "
            f"Euler): {same['sph_ns']:.0f} ns per step; ratio **{same['ratio']:.1f}×** (target ≥ 10×). Medians of "
            f"{fmu['repeats']}.", ""]
