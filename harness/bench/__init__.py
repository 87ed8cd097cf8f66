"""The measurement programs and the library they share: measurement's one home.

``sphrom bench NAME [options]`` runs the program NAME (``sphrom bench NAME --help``: its options);
``sphrom bench --list`` prints one line per program: what it measures, how long it takes, what it writes;
``sphrom bench [SCENE ...]`` is the program ``suite`` (BENCHMARKS.md).  A program is a module here with
``main(argv)`` (``python -m sphrom.bench.MODULE`` runs it as well) that holds its measurement and the report
section it writes.  What programs share is the library :mod:`sphrom.bench.lib` (with :mod:`sphrom.fmu`,
:mod:`sphrom.rom`, ...), never another program: tests/test_bench_programs.py.

:data:`PROGRAMS` is the one list; :data:`ALIASES` gives a program's other names under ``sphrom bench``, and
:data:`COMMANDS` the sphrom commands that are aliases of a program (the commands these programs once were).
Durations are the wall times the programs recorded in their own output (BENCHMARKS.md, validation/), or the
command that measured them, on this project's shared 2-core machine.
"""

from __future__ import annotations

import importlib
import platform
import sys
from dataclasses import dataclass

from ..options import option_message
from ..errors import FieldError
from ..parser import Parser


@dataclass(frozen=True)
class Program:
    """One measurement program of :data:`PROGRAMS`."""

    module: str          # the module with main(argv): sphrom.bench.NAME
    measures: str
    takes: str           # how long, as measured (and where the figure comes from)
    writes: str


PROGRAMS = {
    "suite": Program("sphrom.bench.suite", "run time against error of every method on the paper's scenes, cost "
                     "against N and k, skipped terms, the force direction, the full SPH step, the FMU (and the stress "
                     "maps with --report); also `sphrom bench [SCENE ...]`",
                     "1290 s (BENCHMARKS.md, its first line)",
                     "validation/benchmarks/*.csv, *.png; BENCHMARKS.md with --report"),
    "sph-step": Program("sphrom.bench.sph_step", "µs per full SPH step against N and the integrator", "not recorded",
                        "sph_scaling.csv/png with --out; a BENCHMARKS.md section with --report"),
    "stress": Program("sphrom.bench.stress", "stability maps of every method over Δt, amplitude, horizon, k and "
                      "random forces", "not recorded", "validation/stress/: stress.md, CSV, PNG"),
    "fmu": Program("sphrom.bench.fmu", "the FMU's speed: ns per step of its C core against N, the FMU end to end "
                   "beside the full SPH, the same-language ratio (BENCHMARKS.md's Headline and The FMU)",
                   "not recorded", "fmu_core.csv, fmu_e2e.csv, BENCHMARKS.md's two sections; as fmu-speed "
                   "bench_fmu_core.csv, bench_fmu_e2e.csv, bench_fmu.md with --out"),
    "fast": Program("sphrom.bench.fast", "fast end to end before and after: whole commands (`sphrom "
                    "--help`, cosim, fmu warm and cold) against their yardsticks and another checkout, the frozen "
                    "core per step (k = 12, ports, at rest)", "measured: see BENCHMARKS.md, its section",
                    "a BENCHMARKS.md section with --report; JSON with --out"),
    "fmu_verify": Program("sphrom.bench.fmu_verify", "every built-in scene's packaged FMU against the full SPH "
                          "(what `sphrom fmu` measures), medians of repeated timings",
                          "230 s with --no-bounds (BENCHMARKS.md)", "fmu_verify.csv; a BENCHMARKS.md section"),
    "envelope": Program("sphrom.bench.envelope", "where the frozen model leaves its training envelope: probe error "
                        "against the amplitude", "not recorded", "envelope.csv, envelope.png; a BENCHMARKS.md "
                        "section"),
    "rest": Program("sphrom.bench.rest", "whether each packaged FMU stays at rest, and what the rest-consistent b "
                    "costs", "847 s (BENCHMARKS.md)", "rest.csv, rest.png; a BENCHMARKS.md section"),
    "linear_tradeoff": Program("sphrom.bench.linear_tradeoff", "time against error of the linear models (balanced, "
                               "exact) beside the paper's, with the certified bounds", "787 s (BENCHMARKS.md)",
                               "a BENCHMARKS.md section"),
    "sph_stencil": Program("sphrom.bench.sph_stencil", "the numba full SPH step against a C stencil and an older "
                           "checkout", "89 s with --repeats 9 (BENCHMARKS.md)", "sph_stencil.csv/png; a "
                           "BENCHMARKS.md section"),
    "scale": Program("sphrom.bench.scale", "offline time and accuracy of the balanced model and its certified "
                     "bounds from N = 400 to 10⁴ (through the Fourier modes; --dense times the O(N³) path)",
                     "measured: see BENCHMARKS.md", "scale.csv, scale.png; a BENCHMARKS.md section"),
    "balanced_measure": Program("sphrom.bench.balanced_measure", "the balanced models against the full linear SPH "
                                "and the exact POD model, their bounds' effectivity", "not recorded",
                                "CSV and PNG files into --out"),
    "cosim_fmi": Program("sphrom.bench.cosim_fmi", "FMI 2 against FMI 3 builds of the same model under sphrom "
                         "cosim, with its defaults and with --hold-inputs", "measured: see the report",
                         "prints a table; CSV with --out"),
    "input_derivatives": Program("sphrom.bench.input_derivatives", "held against interpolated input: the FMUs' "
                                 "probe error against the communication step", "measured: see the report",
                                 "input_derivatives.csv"),
    "port_rates": Program("sphrom.bench.port_rates", "held against interpolated port forces: the port FMU's error "
                          "against the communication step", "measured: see the report", "port_rates.csv"),
    "port_coupling": Program("sphrom.bench.port_coupling", "a port FMU against the full SPH with the same point "
                             "forces, open loop and coupled to a mass-spring", "measured: see the report",
                             "port_coupling.csv"),
    "port_cost": Program("sphrom.bench.port_cost", "the cost per communication step of the FMUs with and without "
                         "ports (the port channel, and the ports in the basis as before) and against k, by a native "
                         "FMI 2 master, with the multiply-adds beside", "measured: see the report",
                         "port_cost.csv; a BENCHMARKS.md section with --report"),
    "port_loop": Program("sphrom.bench.port_loop", "ports in a system simulator's sampled loop: Jacobi, "
                         "Gauss-Seidel and the wave form around the full SPH, the frozen and the exact port FMU, "
                         "against the monolithic coupled system; the coupled energy at steps up to 50 ms",
                         "measured: see the report", "port_loop.csv, port_loop_passivity.csv; a BENCHMARKS.md "
                         "section with --report"),
    "port_integrator": Program("sphrom.bench.port_integrator", "the frozen port FMU's own state in a long damped "
                               "loop per integrator: its energy against the full SPH's", "measured: see the report",
                               "prints a table; port_integrator.csv with --out"),
    "port_envelope": Program("sphrom.bench.port_envelope", "the port FMU's accuracy against the port-force "
                             "amplitude", "measured: see the report", "port_envelope.csv"),
    "inputs": Program("sphrom.bench.inputs", "every input channel at every frequency: ports under slow "
                      "and constant forces, forces along non-uniform profiles, before and after, against the "
                      "linear SPH exact in time", "measured: see the report", "prints a table; inputs.csv with --out"),
    "passivity": Program("sphrom.bench.passivity", "passive ports on every built-in scene: each port model's "
                         "passivity check (frozen Euclidean and energy, exact) and its poles coupled to a spring and a "
                         "heavy mass", "measured: see the report", "prints a table; passivity.csv with --out"),
    "unseen_force": Program("sphrom.bench.unseen_force", "the FMUs under forces their basis never saw, against "
                            "the full SPH's forced response", "measured: see the report", "unseen_force.csv"),
    "error_bounds": Program("sphrom.bench.error_bounds", "the certified error-bound outputs on every built-in "
                            "scene: bound >= true error at every point, effectivity, doStep cost with and without "
                            "them (with --parametric, the parametric FMUs at held-out (c, d))", "measured: see the "
                            "report", "error_bounds.csv, error_bounds.png (with --parametric, "
                            "error_bounds_parametric.csv); a BENCHMARKS.md section"),
    "error_bounds_ports": Program("sphrom.bench.error_bounds_ports", "the certified error bounds of port FMUs: "
                                  "open-loop port forces, a coupled mass-spring, f with port forces, against the "
                                  "linear SPH exact in time (--corpus N: error_bounds's user scenes, cases sized "
                                  "from each scene)", "measured: see the report", "error_bounds_ports.csv; "
                                  "a BENCHMARKS.md section"),
    "parametric": Program("sphrom.bench.parametric", "the parametric model at held-out (c, d) against the full SPH "
                          "and a model trained there", "not recorded", "CSV and a PNG map into --out"),
    "reduced_stability": Program("sphrom.bench.reduced_stability", "how close the reduced models' sound runs come "
                                 "to their blow-up alarms", "measured: see the report", "reduced_stability.csv"),
    "automatic_choices": Program("sphrom.bench.automatic_choices", "what the automatic rules of a scene choose on "
                                 "each paper scene", "measured: see the report", "prints a table"),
    "hostile": Program("sphrom.bench.hostile", "an alias: the hostile-input battery is a test-side tool, "
                       "python3 -m tests.hostile in a checkout", "not recorded", "validation/hostile/"),
    "sweep": Program("sphrom.bench.sweep", "the committed parameter sweep on dask (throughput, resume)",
                     "not recorded", "validation/sweeps/"),
    "scenes": Program("sphrom.bench.scenes", "a corpus of plausible user scenes through `sphrom fmu` at the first "
                      "try: built or refused, v errors of the default and the exact FMU against the linear SPH exact "
                      "in time, bounds, warnings, cost against the full SPH", "measured: see BENCHMARKS.md, its "
                      "section", "scenes.csv, scenes.png; a BENCHMARKS.md section"),
}

@dataclass(frozen=True)
class Alias:
    """Another name of a program under ``sphrom bench`` (:data:`ALIASES`)."""

    program: str         # the program it runs, a key of PROGRAMS
    differs: str = ""    # what differs from the program under its own name, in words (its defaults)


# Other names of a program under `sphrom bench`.  fmu-speed is `sphrom bench fmu` keeping the defaults and files of the
# command it was (sphrom bench-fmu).
ALIASES = {"fmu-speed": Alias("fmu", "its defaults: the tables printed, files only with --out (bench_fmu_core.csv, "
                                     "bench_fmu_e2e.csv, bench_fmu.md), a report only with --report")}

# sphrom commands that are aliases of `sphrom bench NAME` (the commands these programs were before they joined
# sphrom bench): command -> NAME.  Each keeps its options; its help says whose alias it is.
COMMANDS = {"bench-sph": "sph-step", "bench-fmu": "fmu-speed", "stress": "stress"}


def program_of(name):
    """The program (a key of :data:`PROGRAMS`) that ``name`` (a program's name or an alias) runs."""
    return ALIASES[name].program if name in ALIASES else name


def also_called(program):
    """The other names of ``program``: its aliases (``sphrom bench NAME``) and the commands that run it."""
    names = [n for n, a in ALIASES.items() if a.program == program]
    return [f"sphrom bench {n}" for n in names] + [f"sphrom {c}" for c, n in COMMANDS.items()
                                                     if program_of(n) == program]


def list_lines():
    """One line per program: name, what it measures (and its other names), how long it takes, what it writes."""
    width = max(map(len, PROGRAMS))
    lines = []
    for name, p in PROGRAMS.items():
        also = also_called(name)
        lines.append(f"{name:<{width}}  {p.measures}" + (f" (also {', '.join(also)})" if also else "")
                     + f"; takes {p.takes}; writes {p.writes}")
    return lines


def alias_note(name, command=None):
    """The sentence that opens the help of an alias: of ``name`` under ``sphrom bench`` when it is an alias, of the
    command ``command`` (a key of :data:`COMMANDS`) that runs ``name``; '' for a program under its own name."""
    alias = ALIASES.get(name)
    also = f"`sphrom bench {alias.program}` with {alias.differs}" if alias else ""
    if command is not None:
        return (f"An alias of `sphrom bench {name}`" + (f" (itself {also})" if alias else "")
                + ": the same program, options and files. ")
    return f"An alias of {also}. " if alias else ""


def program_parser(name, description=None, **options):
    """The argument parser of program ``name`` (or of an alias of it): one-line errors with exit status 2 (as every
    sphrom command), named as it was called (``sphrom bench NAME`` or ``python -m sphrom.bench.MODULE``)."""
    prog = (f"sphrom bench {name}" if _CALLED_AS_SPHROM else
            f"python -m {PROGRAMS[program_of(name)].module}")
    return Parser(prog=prog, description=description, **options)


_CALLED_AS_SPHROM = False


def program_main(name, description, add_arguments, run, argv=None):
    """``main`` of a program that is also a sphrom command (its options in ``add_arguments(parser)``, its body in
    ``run(args)``): parse ``argv`` (default the process's), run, the exit status.  A library error that names a
    field is the option's one-line error (exit status 2), as under the command."""
    p = program_parser(name, description=alias_note(name) + description)
    add_arguments(p)
    args = p.parse_args(argv)
    try:
        return int(run(args) or 0)
    except FieldError as exc:
        p.error(option_message(p, exc))


def program_command(name, argv=None):
    """The command line that ran program ``name``, as it was called (``sphrom bench NAME`` or ``python -m ...``)
    with its arguments (``argv``, default the process's): the reports' "Produced by"."""
    given = list(sys.argv[1:] if argv is None else argv)
    prog = f"sphrom bench {name}" if _CALLED_AS_SPHROM else f"python -m {PROGRAMS[program_of(name)].module}"
    return " ".join([prog, *given])


def machine_text():
    """The machine and Python a report's figures were measured on, in a few words."""
    return f"{platform.machine()}, Python {platform.python_version()}"


def run_program(name, argv):
    """Run program ``name`` (a program's name or an alias) with the arguments ``argv``; its exit status
    (``--help``: 0, a bad option: 2)."""
    global _CALLED_AS_SPHROM
    program = program_of(name)
    _CALLED_AS_SPHROM = True
    try:
        main = importlib.import_module(PROGRAMS[program].module).main
        return int((main(list(argv), name=name) if name != program else main(list(argv))) or 0)
    except SystemExit as exc:            # the program's --help, or a bad option (one line already printed)
        return exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
    finally:
        _CALLED_AS_SPHROM = False
