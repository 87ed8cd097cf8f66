"""The FMU's variables as documented to users: ``sphrom fmu --help`` prints this list, README.md's table
"Variables" holds the same rows, and a test checks every variable of packaged FMUs (both models, FMI 2 and 3)
against it (name, value reference, causality, unit): a variable added to the FMU without a row here and in the
README fails that test.

A name ending in ``_j`` stands for one variable per probe (or port) j = 1, 2, ...; its value reference is
given as ``BASE+j-1``.  Units are the modelDescription's unit names ('' for none).
"""

from __future__ import annotations

import re

# name, value reference, causality (as in modelDescription), unit, meaning
FMU_VARIABLES = (
    ("time", "0", "independent", "s", "simulation time (FMI 3 only); exactly t_comm + h after each step"),
    ("f", "1", "input", "m/s2", "external force per mass; the field is profile(x) f; held over each "
                               "communication step, or linear with an input derivative (FMI 2, linear models)"),
    ("n_freeze", "2", "parameter", "", "refresh period of the frozen coefficients in internal steps, >= 1"),
    ("dt", "3", "parameter", "s", "internal time step, > 0 (start: the scene's dt)"),
    ("initial_state_scale", "4", "parameter", "1", "the initial state is this multiple of the scene's deviation "
                                                  "from rest: 0 (start) at rest, 1 the scene's v0, any finite real"),
    ("c", "5", "parameter", "Pa", "stiffness c, only in a parametric FMU (sphrom fmu --vary c=LO:HI); within the "
                                  "trained range"),
    ("d", "6", "parameter", "1/s", "damping d, only in a parametric FMU (--vary d=LO:HI); within the trained "
                                   "range"),
    ("v_probe_j", "1000+j-1", "output", "m/s", "velocity at probe j (x_j/L), interpolated linearly between "
                                               "particles"),
    ("rho_probe_j", "2000+j-1", "output", "kg/m3", "density at probe j, likewise"),
    ("force_error_bound", "8", "calculatedParameter", "s", "linear models: the largest of the "
                                                           "force_error_bound_j"),
    ("initial_state_error_bound", "9", "calculatedParameter", "m/s*s^0.5", "linear models: the largest of the "
                                                                           "initial_state_error_bound_j"),
    ("force_error_bound_j", "5000+j-1", "calculatedParameter", "s", "linear models: ||v_probe_j - v_full_j||_L2(0,T) "
                                                                    "<= this ||f||_L2(0,T) for every force from rest"),
    ("initial_state_error_bound_j", "6000+j-1", "calculatedParameter", "m/s*s^0.5",
     "linear models: ||v_probe_j - v_full_j||_L2(0,T) of the free response from the scene's initial state"),
    ("area", "7", "parameter", "m2", "with ports: the cross-section A, start 1, > 0"),
    ("F_port_j", "3000+j-1", "input", "N", "with ports: point force at port j, spread by the SPH kernel"),
    ("v_port_j", "4000+j-1", "output", "m/s", "with ports: sum_i W(x_i - x_j, h) v_i dx, power-conjugate to "
                                              "F_port_j"),
)


def lookup(name):
    """(row, value reference) of the documented variable ``name`` (``v_probe_2`` matches ``v_probe_j`` with
    j = 2), or (None, None)."""
    for row in FMU_VARIABLES:
        pattern, vr = row[0], row[1]
        if pattern.endswith("_j"):
            m = re.fullmatch(re.escape(pattern[:-1]) + r"([1-9]\d*)", name)
            if m:
                j = int(m.group(1))
                base = int(vr.split("+")[0])
                return row, base + j - 1
        elif pattern == name:
            return row, int(vr)
    return None, None


def help_text():
    """The variable list of ``sphrom fmu --help`` (one line per variable)."""
    lines = ["FMU variables (name [value reference] causality, unit: meaning):"]
    for name, vr, causality, unit, meaning in FMU_VARIABLES:
        lines.append(f"  {name} [{vr}] {causality}, {unit or '-'}: {meaning}")
    return "\n".join(lines) + "\n"
