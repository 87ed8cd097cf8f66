"""The Markdown of BENCHMARKS.md (``sphrom bench --report``) and of the stress maps (``sphrom stress``).

One function per section, each taking measured rows (plain dicts, as
:mod:`sphrom.bench.suite` and :mod:`sphrom.bench.lib.stress_maps` produce them)
and returning a list of Markdown lines that ends with a blank line;
:func:`report` assembles them.  Nothing here measures or reads a file.

Image paths are given by the caller relative to the page that holds them.
"""

from __future__ import annotations

import math

SPH_INTEGRATORS = ("euler", "symplectic", "rk4")
SPH_STEP_HEADING = "## The full SPH step against N (as `sphrom bench-sph`)"


def _fmt(x, spec=".3e"):
    """A number for a table; ``—`` for None or NaN."""
    return "—" if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, spec)


def _pct(x):
    return f"{100 * x:.0f} %"


# ---------------------------------------------------------------------------
# BENCHMARKS.md, in document order
# ---------------------------------------------------------------------------

def intro_section(command, version, python, machine, wall, repeats):
    """The title and the paragraph saying how the figures were made."""
    return ["# Benchmarks", "",
            f"Produced by `{command}` (sphrom {version}, Python {python}, {machine}, {wall:.0f} s wall). Times are "
            f"medians of {repeats} runs on a shared 2-core machine; speed-ups are ratios to the full SPH timed in the "
            "same run. Errors: relative L² (square-root form of eq. 3.4); reduced models against the full SPH, the "
            "full SPH against the reference (exact, or a continuum reference for heterogeneous); ρ errors of "
            "ρ − ρ0. Online = the time loop; offline = SPH run for the snapshots, SVD and operators.", ""]


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


def savings_section(savings):
    """CPU saving of the frozen model per scene and k beside the paper's.

    ``savings``: list of (scene name, {k: saving}, the paper's saving or None).
    """
    lines = ["## CPU saving of the frozen model against the full SPH (n_freeze = 10)", "",
             "| scene | ours, per k | paper (\"up to\") |", "| --- | --- | --- |"]
    for name, by_k, paper in savings:
        lines.append(f"| {name} | " + ", ".join(f"{100 * v:.0f} % (k = {k})" for k, v in by_k.items())
                     + f" | {_fmt(None if paper is None else 100 * paper, '.0f')} % |")
    return lines + ["", "Both in Python in our case; the paper's full SPH was slower relative to its reduced models "
                    "than our compiled (numba) one, which is why our savings are smaller: see the per-step costs "
                    "below.", ""]


def scene_section(name, rows, image):
    """Run time against error of every method on one scene: the plot and the table of ``rows``."""
    lines = [f"## {name}", "", f"![time against error]({image})", "",
             "| method | k | n_freeze | online [s] | speed-up | offline [s] | error v | error ρ−ρ0 | vs ref: v | "
             "vs ref: ρ−ρ0 |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        lines.append(f"| {r['method']} | {r['k']} | {r['n_freeze'] or ''} | {r['online_s']:.4f} | "
                     f"{r['speedup']:.1f}× | {r['offline_s']:.3f} | {_fmt(r['err_v_sph'])} | "
                     f"{_fmt(r['err_rho_sph'])} | {_fmt(r['err_v_ref'])} | {_fmt(r['err_rho_ref'])} |")
    return lines + [""]


def _cost_rows(rows, key, values, methods):
    from .scaling import growth
    out = []
    for method in methods:
        cells = [next((f"{r['us_per_step']:.3g} µs" for r in rows if r["method"] == method and r[key] == v), "—")
                 for v in values]
        out.append(f"| {method} | " + " | ".join(cells) + f" | {growth(rows, method, key=key):.2f} |")
    return out


def cost_n_section(scaling, sizes, image):
    """Cost per step of every method against the particle count N (rows of ``per_step_costs``)."""
    lines = ["## Cost per step against N (k = 12, tenmode fields, Δt at the scene's CFL number)", "",
             f"![cost against N]({image})", "",
             "| method | " + " | ".join(f"N = {n}" for n in sizes) + " | growth exponent |",
             "| --- |" + " --- |" * (len(sizes) + 1)]
    lines += _cost_rows(scaling, "n", sizes, dict.fromkeys(r["method"] for r in scaling))
    return lines + [""]


def cost_k_section(scaling_k, ks, image):
    """Cost per step of every reduced model against the mode count k at N = 400."""
    lines = [f"## Cost per step against k (N = 400, k = {', '.join(map(str, ks))})", "",
             f"![cost against k]({image})", "",
             "| method | " + " | ".join(f"k = {k}" for k in ks) + " | growth exponent in k |",
             "| --- |" + " --- |" * (len(ks) + 1)]
    lines += _cost_rows(scaling_k, "k", ks, dict.fromkeys(r["method"] for r in scaling_k if r["k"]))
    return lines + ["", "Expected: the original and linearised models cost O(N k) per step (the nonlinear term is "
                    "evaluated on the particles), the frozen model O(k²) per step plus O(k⁴)/n_freeze for the exact "
                    "refresh tensor, the exact model O(k²) per communication step.", ""]


def skip_section(skips):
    """What skipping absent terms saves (rows of :func:`sphrom.bench.lib.skip.skip_savings`)."""
    lines = ["## Skipping what a scene doesn't need", "",
             "The same loop on the same inputs with the scene's own terms (specialised) and with every term forced "
             "on (zero damping and force evaluated, per-particle arrays); the results are identical.", "",
             "| scene | solver | specialised [µs/step] | general [µs/step] | saving |",
             "| --- | --- | --- | --- | --- |"]
    for r in skips:
        lines.append(f"| {r['scene']} | {r['solver']} | {r['specialised_us']:.3f} | {r['general_us']:.3f} | "
                     f"{_pct(r['saving'])} |")
    return lines + [""]


def input_direction_section(directions, scene_names, tolerance):
    """Projected against appended force direction per scene; [] without rows.

    ``tolerance`` is the FMU's rule (``sphrom.rom.operators.INPUT_TOLERANCE``).
    """
    if not directions:
        return []
    lines = ["## How the force direction enters the frozen model", "",
             "The FMU takes any f(t) along the scene's force profile (uniform). Projected as in eq. 2.19, the part "
             "of the profile outside the POD velocity modes is lost; appended, the normalised residual becomes an "
             "extra velocity mode. Frozen model, n_freeze = 10, errors against the full SPH. The FMU appends only "
             f"when the modes miss more than {tolerance:g} of the profile (`INPUT_TOLERANCE`).", "",
             "| scene | k | modes miss | projected: v | ρ − ρ0 | appended (k_v + 1): v | ρ − ρ0 | FMU's rule |",
             "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for name in scene_names:
        pr = {r["choice"]: r for r in directions if r["scene"] == name}
        if len(pr) == 2:
            a, b = pr["project"], pr["augment"]
            lines.append(f"| {name} | {a['k']} | {100 * a['input_error']:.2g} % | {_fmt(a['err_v'])} | "
                         f"{_fmt(a['err_rho'])} | {_fmt(b['err_v'])} | {_fmt(b['err_rho'])} | {a['fmu_rule']} |")
    return lines + [""]


def sph_step_section(sph_steps, sizes, repeats, integrators=SPH_INTEGRATORS, produced=None, image=None):
    """The full SPH step against N per integrator (rows of :func:`sphrom.bench.lib.sph_scaling.scaling_table`);
    ``produced``: a sentence naming the command, the machine and its load, ``image``: the plot's path from the
    report (``sphrom bench-sph --report``)."""
    from .sph_scaling import growth_exponent
    lines = [SPH_STEP_HEADING, "",
             (produced + " " if produced else "")
             + "µs per step of the numba loop (one thread) in the layout `sphrom sph` takes (the fixed-offset "
             "stencil where the neighbour lists allow it, as in every built-in scene), tenmode's fields at the "
             "scene's CFL number; each figure the slope between runs of M and 2M steps (the call's fixed cost "
             f"cancels), the median of {repeats} repeats; growth exponent of time against N for N ≥ 1000 "
             "(1 = linear). Target: ≤ 10 µs per step at N = 400 (explicit Euler).", "",
             "| integrator | " + " | ".join(f"N = {n}" for n in sizes) + " | growth exponent |",
             "| --- |" + " ---: |" * (len(sizes) + 1)]
    for integrator in integrators:
        cells = [next(f"{r['us_per_step']:.3g} µs" for r in sph_steps if r["integrator"] == integrator and r["n"] == n)
                 for n in sizes]
        lines.append(f"| {integrator} | " + " | ".join(cells) + f" | {growth_exponent(sph_steps, integrator):.2f} |")
    return lines + [""] + ([f"![full SPH step against N]({image})", ""] if image else [])


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
                     f"{r['ns_max']:.1f} | {_fmt(r.get('ns_per_step_cpu'), '.1f')} | {r.get('refresh', '—')} |")
    if e2e is not None:
        sph_err = e2e["sph"].get("probe_error_v_vs_exact")
        lines += ["", f"{heading} End to end through sphrom's FMU driver: {e2e['scene']} (N = {e2e['n']}, "
                      f"T = {e2e['T']:g} s, {e2e['internal_steps']} internal steps, k_v = {e2e['k_v']}, "
                      f"k_rho = {e2e['k_rho']}, probes x/L = {', '.join(f'{p:g}' for p in e2e['probes'])})", "",
                  f"Full SPH (run_sph, numba, same run): {e2e['sph']['call_s']:.3f} s per run "
                  f"({e2e['sph']['loop_s']:.3f} s in its time loop); its probe-velocity error against the exact "
                  f"solution: {_fmt(sph_err)}. Each FMU time is the whole "
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
                         f"{r['fmu_e2e_s']:.4f} | {r['speedup']:.1f}x | {_fmt(r.get('probe_error_v_vs_sph'))} | "
                         f"{r['fixed_s']:.4f} | {_fmt(r['core_s'], '.4f')} | {r['us_per_doStep_fmpy']:.1f} | "
                         f"{_fmt(r.get('us_per_doStep_core'), '.1f')} | {_fmt(r['us_per_doStep_bare_call'], '.1f')} |")
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


def _within_margin(rows, scenes, margin):
    """", at s = margin the frozen error is r × its value at s = 1 (scene, ...)" from the rows that have both."""
    ratios = []
    for s in scenes:
        at = {r["scale"]: r["frozen_v_error"] for r in rows if r["scene"] == s}
        if 1.0 in at and margin in at and at[1.0] > 0:
            ratios.append(f"{at[margin] / at[1.0]:.2g}× ({s})")
    return f": at s = {margin:g} the frozen error is {', '.join(ratios)} its value at s = 1" if ratios else ""


def envelope_section(envelope, image_dir=""):
    """The frozen FMU's training envelope (:func:`sphrom.bench.envelope.run`: rows, training, command, and
    failure, the probe strain per scene where the frozen error reaches failure_error): error against
    amplitude and strain, the margin's headroom on the training runs; [] without it."""
    if not envelope:
        return []
    from ...fmu.make.envelope import FAILURE_STRAIN, MARGIN
    rows, d = envelope["rows"], image_dir.rstrip("/") + "/" if image_dir else ""
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    lines = ["## The training envelope of the frozen FMU", "",
             f"`{envelope['command']}` (`{d}envelope.csv`): the initial velocity scaled by s, the density at ρ0; "
             "the full SPH runs the scaled scene, the reduced models start from the scaled coordinates on the x1 "
             "basis (the FMU's: k = the scene's largest `rom.accel_modes`, n_freeze = 10). Relative L² error of "
             "the probe velocities (x/L = 0.25, 0.5, 0.66) against the full SPH; peak strain |ρ0/ρ − 1| of the "
             "full SPH over the particles and at the probes; the frozen run's largest coordinate excess beyond "
             "its trained ranges in units of its block's largest half-width (the FMU warns above margin − 1 = "
             f"{MARGIN - 1:g}).", "",
             f"![error against strain]({d}envelope.png)", "",
             "| scene | s | peak strain | peak probe strain | frozen v error | coordinate excess | exact v error |",
             "| --- | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for r in rows:
        lines.append(f"| {r['scene']} | {r['scale']:g} | {r['peak_strain']:.3g} | {r['peak_probe_strain']:.3g} | "
                     f"{r['frozen_v_error']:.3g} | {r['frozen_coordinate_excess']:.3g} | {r['exact_v_error']:.3g} |")
    reached = envelope["failure"]              # scene -> probe strain at the failure error (nan: not reached)
    where = ", ".join(f"{v:.3g} ({s})" for s, v in reached.items() if not math.isnan(v)) or "never in this range"
    exact = "; ".join(f"{s} {min(r['exact_v_error'] for r in rows if r['scene'] == s):.4g} to "
                      f"{max(r['exact_v_error'] for r in rows if r['scene'] == s):.4g}" for s in scenes)
    lines += ["", "The full SPH is linear in J = ρ0/ρ (up to its time stepping of ρ), so a scaled initial state "
              f"scales its solution and the exact model's error hardly moves with s ({exact}); the frozen "
              "model's error grows about linearly with the strain (the density linearization of eq. 2.17 and the "
              f"ρ² coefficient): it reaches {envelope['failure_error']:.0%} at a probe strain of {where}. The FMU's failure "
              f"strain is {FAILURE_STRAIN:g}, its margin {MARGIN:g}{_within_margin(rows, scenes, MARGIN)}.", "",
              "Headroom on the training runs (every built-in scene's frozen model on its own scene, "
              f"`{d}envelope_training.csv`): the FMU warns above a coordinate excess of {MARGIN - 1:g} or a probe "
              f"strain of {MARGIN:g}× the trained one.", "",
              "| scene | largest coordinate excess | probe strain / trained |", "| --- | ---: | ---: |"]
    for r in envelope["training"]:
        lines.append(f"| {r['scene']} | {r['coordinate_excess']:.3g} | {r['probe_strain_ratio']:.3g} |")
    return lines + [""]


def stress_section(maps, command, image_dir="", level=1):
    """The stability stress maps (:class:`sphrom.bench.lib.stress_maps.StressMaps`) as Markdown lines.

    ``level`` 1 gives a page of its own (``stress.md``), 2 the section of BENCHMARKS.md; ``image_dir`` is
    the heat maps' folder as seen from the page ('' when they sit beside it).
    """
    h = "#" * level
    prefix = f"{image_dir.rstrip('/')}/" if image_dir else ""
    lines = [f"{h} Stability stress maps", "",
             f"Produced by `{command}`. Outcomes: stable (energy never above 1.1× its start), growing, "
             "unphysical (ρ ≤ 0 / J ≤ 0 reached: compression beyond the physical limit), blow-up (the method's "
             "own check fired: non-finite, non-positive density, runaway; the FMU returns an error status). "
             "Δt* = 2/ω_max is the explicit limit of the full SPH operator (ω_max Δt < 2 for the Euler schemes, 2√2 for RK4). "
             "Reduced models use the basis of the paper-setting run and start from the amplified state. "
             f"Wall time {maps.wall:.0f} s.", ""]
    for s in maps.scenes:
        lines += _stress_scene(s, maps.amplitudes[0], h + "#", prefix)
    return lines


def _stress_scene(s, amplitude, h, prefix):
    rows, hor, krows, frows = s["map"], s["horizons"], s["modes"], s["forces"]
    lines = [f"{h} {s['name']}", "",
             f"Explicit limit Δt* = {s['dt_limit']:.4g} s; the paper's Δt = {s['dt']:g} s "
             f"= {s['dt'] / s['dt_limit']:.3g} Δt*; k = {s['k']}.", "",
             f"![stress map]({prefix}{s['name']}_stress.png)", "",
             f"Largest Δt (in Δt*) at which each method stays finite and physical at amplitude ×1 over T = "
             f"{s['T']:g} s:", "", "| method | stable up to | first failure |", "| --- | --- | --- |"]
    for method in dict.fromkeys(r["method"] for r in rows):
        ok = [r for r in rows if r["method"] == method and r["amplitude"] == amplitude and r["dt_factor"] != "paper"]
        good = [r["dt_factor"] for r in ok if r["outcome"] in ("stable", "growing")]
        bad = [r for r in ok if r["outcome"] in ("blow-up", "unphysical")]
        first = (f"{bad[0]['outcome']} at Δt = {bad[0]['dt_factor']} Δt*, t = {bad[0]['blowup_time']:.3g} s"
                 if bad and bad[0]["blowup_time"] is not None else (bad[0]["outcome"] if bad else "none"))
        lines.append(f"| {method} | {max(good) if good else '—'} | {first} |")
    if s["fmu"]:
        fmu_rows = [r for r in rows + hor + frows if str(r["method"]).startswith("FMU")]
        errors = [r for r in fmu_rows if r.get("fmu_error")]
        silent = sum(int(r.get("silent_nan", 0)) for r in fmu_rows)
        lines += ["", f"The FMU (FMI 2 through fmpy, the same operators and internal grid): {len(fmu_rows)} runs, "
                      f"{len(errors)} ended with an error status whose message names the time"
                      + (f" (e.g. “{errors[0]['fmu_error'][:160]}”)" if errors else "")
                      + f"; non-finite outputs without an error status: **{silent}**."]
    lines += ["", "Long horizons at the paper's Δt (amplitude ×1):", "",
              "| method | T | outcome | blow-up time | max E/E0 |", "| --- | --- | --- | --- | --- |"]
    for r in hor:
        bt = "" if r["blowup_time"] is None else f"{r['blowup_time']:.4g} s"
        lines.append(f"| {r['method']} | {r['T']:g} | {r['outcome']} | {bt} | {r['energy_growth']:.4g} |")
    lines += ["", "Mode count (paper's Δt, amplitude ×1):", "", "| method | k | outcome | max E/E0 |",
              "| --- | --- | --- | --- |"]
    for r in krows:
        lines.append(f"| {r['method']} | {r['k']} | {r['outcome']} | {r['energy_growth']:.4g} |")
    lines += ["", "Random piecewise-constant forces (held 0.05 s): final energy against the exact-in-time reduced "
              "model:", "", "| force amplitude [m/s²] | method | outcome | E_end / E_end(exact) − 1 |",
              "| --- | --- | --- | --- |"]
    for r in frows:
        lines.append(f"| {r['force_amplitude']:g} | {r['method']} | {r['outcome']} | {r['energy_vs_exact']:.3g} |")
    return lines + [""]


# ---------------------------------------------------------------------------
# the document
# ---------------------------------------------------------------------------

def linear_tradeoff_section(rows, command, wall):
    """Time against error of balanced, exact, frozen and original at equal state dimension, per scene and force,
    with the linear models' certified bounds beside their measured errors (:mod:`sphrom.bench.linear_tradeoff`)."""
    lines = ["## Linear models: time against error", "",
             f"Produced by `{command}` ({wall:.0f} s wall; online times are medians of repeated runs on a shared "
             "2-core machine). State dimension r for every model: the balanced model's order, k = r/2 POD modes "
             "of each kind for the others (one more velocity mode where the force profile is appended, as in each "
             "model's FMU; the column *state* gives the count). "
             "Errors: probe velocities at x/L = 0.25, 0.5, 0.66; *vs SPH* the relative L² error (eq. 3.4) against "
             "the full SPH run; *vs linear* the absolute ‖y − y_full‖_L2(0,T) [m s⁻¹ s^½] against the full "
             "linear SPH exact in time (largest over the probes), beside its certified *bound* "
             "force_error_bound ‖f‖_L2 + initial_state_error_bound (what `sphrom fmu` stores in the FMU). "
             "*training*: the scene's own force; *unseen*: another time history along the same profile "
             "(`UNSEEN_FORCE` of the module), the POD basis unchanged. Where *vs linear* lies far below "
             "*vs SPH*, the rest is the difference between the time-stepped full SPH run and the linear SPH exact "
             "in time (the linear models have no time-step error).", ""]
    for scene in dict.fromkeys(r["scene"] for r in rows):
        for force in ("training", "unseen"):
            sub = [r for r in rows if r["scene"] == scene and r["force"] == force]
            if not sub:
                continue
            lines += [f"### {scene}, {force} force", "",
                      "| r | model | state | online [s] | v error vs SPH | vs linear | bound | bound / measured | note |",
                      "| -- | ----- | ----- | ---------- | -------------- | --------- | ----- | ---------------- | ---- |"]
            for r in sub:
                ratio = r["bound"] / r["err_linear"] if r["err_linear"] and not math.isnan(r["err_linear"]) else None
                lines.append(f"| {r['order']} | {r['model']} | {r['state']} | {_fmt(r['online_s'], '.4f')} | "
                             f"{_fmt(r['err_sph'])} | {_fmt(r['err_linear'])} | {_fmt(r['bound'])} | "
                             f"{_fmt(ratio, '.5f')} | {r['note']} |")
            lines.append("")
    return lines


# Sections that other commands write into BENCHMARKS.md (each names its command; they sit between the FMU's
# section and the stress maps): ``sphrom bench --report`` carries them over from the existing document, in
# its order, so that regenerating the benchmarks never drops them.
CARRIED = ("## The full SPH step: numba against a hand-written C stencil",
           "## The training envelope of the frozen FMU",
           "## The packaged FMU against the full SPH, every scene",
           "## Linear models: time against error",
           "## A component at rest",
           "## Scale: the balanced model and its bounds to N = 10⁴",
           "## Fast end to end: before and after",
           "## Certified error bounds",        # sphrom bench error_bounds
           "## Certified error bounds: ports and coupled components",     # sphrom bench error_bounds_ports
           "## Certified error bounds of parametric FMUs")   # sphrom bench error_bounds --parametric
PACKAGED_HEADING = "## The packaged FMU against the full SPH, every scene"


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


def report(results, image_dir, stress_image_dir=None, existing=None):
    """BENCHMARKS.md from :class:`sphrom.bench.suite.BenchResults` (text ending in a newline).

    ``image_dir`` is the folder of the PNG files as seen from the report; ``stress_image_dir`` that of the
    heat maps (default ``image_dir``/stress); ``existing`` the document being replaced, whose
    :data:`CARRIED` sections are kept.
    """
    r = results
    d = image_dir.rstrip("/") + "/" if image_dir else ""
    lines = intro_section(r.command, r.version, r.python, r.machine, r.wall, r.repeats)
    lines += headline_section(r.fmu)
    lines += savings_section(r.savings)
    for name in r.scene_names:
        lines += scene_section(name, [row for row in r.rows if row["scene"] == name], f"{d}{name}_time_error.png")
    lines += cost_n_section(r.scaling, r.sizes, f"{d}scaling_n.png")
    lines += cost_k_section(r.scaling_k, r.ks_scaling, f"{d}scaling_k.png")
    lines += skip_section(r.skips)
    lines += input_direction_section(r.directions, r.scene_names, r.input_tolerance)
    lines += sph_step_section(r.sph_steps, r.sph_sizes, r.repeats)
    lines += fmu_section(r.fmu)
    old = split_sections(existing or "")
    carried = {h: body for h, body in old.items() if h in CARRIED}
    if getattr(r, "packaged", None):
        carried[PACKAGED_HEADING] = packaged_fmu_section(r.packaged, **r.packaged_meta)
    for heading in [h for h in old if h in carried] + [h for h in carried if h not in old]:
        body = list(carried[heading])
        while body and not body[-1]:
            body.pop()
        lines += body + [""]
    if r.stress is not None:
        lines += stress_section(r.stress, r.stress_command, f"{d}stress" if stress_image_dir is None
                                else stress_image_dir, level=2)
    while lines and not lines[-1]:
        lines.pop()
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------------------
# written by python -m sphrom.bench.fmu_verify into BENCHMARKS.md
# ---------------------------------------------------------------------------

def packaged_fmu_section(rows, *, command, repeats, wall, machine):
    """The packaged FMU against the full SPH for every scene and model (rows of
    :func:`sphrom.bench.fmu_verify.measure_scene`): what ``sphrom fmu`` measures and stores in each FMU."""
    lines = ["## The packaged FMU against the full SPH, every scene", "",
             f"Produced by `{command}` ({machine}, {wall:.0f} s wall). Each scene's FMU (FMI 2, the scene's "
             "default k, n_freeze = 10, probes x/L = 0.25, 0.5, 0.66), as `sphrom fmu SCENE --model MODEL` "
             "builds and measures it: co-simulated through fmpy at its default communication step (f at the "
             "points, held, or linear with df/dt where the FMU declares canInterpolateInputs) against the full "
             "SPH (f at every internal step), relative L² errors of eq. 3.4 at the probes (v; ρ as ρ − ρ0). "
             "Training: the scene's force and initial state. Unseen: A sin(2π·0.7 t) (A: the training force's "
             "peak, or 2π·0.7·max|v0| for a free scene), from the start given in the table. Times: medians of "
             f"{repeats} runs of the training case, timed in turn in one run, setup excluded (the FMU through "
             "fmpy on an instantiated FMU, Python's per-step overhead included; the full SPH's compiled time "
             "loop); speed-up = full SPH / FMU. Tolerance: the full SPH's own v error against the reference "
             "(the paper's, `paper.sph_error_v`): met when the FMU adds less than that. A uniform force from rest "
             "moves the bar rigidly: the full SPH's ρ − ρ0 is then 0 (no relative error, —) and the largest "
             "|ρ − ρ_SPH| at the probes says how much density the FMU makes up.", "",
             "| scene | model | k_v, k_ρ | training: v | ρ − ρ0 | unseen: v | ρ − ρ0 | max abs(ρ − ρ_SPH) "
             "[kg/m³] | unseen from | FMU [s] | full SPH [s] | speed-up | tolerance | met |",
             "| --- | --- | --- | ---: | ---: | ---: | ---: | ---: | --- | ---: | ---: | ---: | ---: | --- |"]
    for r in rows:
        met = "—" if r["meets"] is None else ("yes" if r["meets"] else "**no**")
        lines.append(f"| {r['scene']} | {r['model']} | {r['k_v']}, {r['k_rho']} | {_fmt(r['train_err_v'])} | "
                     f"{_fmt(r['train_err_rho'])} | {_fmt(r['unseen_err_v'])} | {_fmt(r['unseen_err_rho'])} | "
                     f"{_fmt(r.get('unseen_max_drho'), '.2e')} | {r['unseen_start']} | {r['fmu_s']:.4f} | {r['sph_s']:.4f} | {r['speedup']:.1f}× | "
                     f"{_fmt(r['tolerance'], '.3g')} | {met} |")
    notes = [f"{r['scene']} {r['model']}: {r['note']}" for r in rows if r.get("note")]
    if notes:
        lines += ["", "FMU failures: " + "; ".join(notes) + "."]
    return lines + [""]


# ---------------------------------------------------------------------------
# Sections of BENCHMARKS.md replaced in place (the programs that rewrite one section)
# ---------------------------------------------------------------------------

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
    from pathlib import Path

    from ...markdown import write_text
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
    import os
    import sys
    from pathlib import Path
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
