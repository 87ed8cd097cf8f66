"""The full SPH model of section 2.2: kernel, neighbour operator, solver.

Public names (imported from their modules on first use)::

    build_problem, SPHProblem          scene -> particles, fields, neighbours  (solver)
    run_sph, SPHResult                 the time loop of eqs. 2.10-2.11         (solver)
    step_count, stability, stability_warnings, energy_bound_factors           (solver)
    energy, momentum, total_length     diagnostics per sample                  (diagnostics)
    cubic_spline, cubic_spline_gradient  the kernel of eqs. 2.6-2.7            (kernel)
    build_neighbours, Neighbours, particle_positions, fixed_offsets  eqs. 2.8-2.9  (operator)
    run_sph_ports, port_kernel, mass_spring, ...  point forces in, port velocities out  (ports)

Modules: ``kernel`` (the SPH kernel), ``operator`` (neighbour lists and
weights), ``loops`` (the compiled right-hand side and time loops), ``solver``
(problems and runs), ``diagnostics``, ``ports`` (mechanical ports: point forces and port velocities).
"""

from ..lazy import lazy_exports

EXPORTS = {
    "SPHProblem": "solver", "build_problem": "solver", "SPHResult": "solver", "run_sph": "solver",
    "step_count": "solver", "stability": "solver", "stability_warnings": "solver",
    "energy_bound_factors": "solver",
    "energy": "diagnostics", "momentum": "diagnostics", "total_length": "diagnostics",
    "cubic_spline": "kernel", "cubic_spline_gradient": "kernel",
    "build_neighbours": "operator", "Neighbours": "operator", "particle_positions": "operator",
    "fixed_offsets": "operator",
    "run_sph_ports": "ports", "port_kernel": "ports", "port_accelerations": "ports", "port_velocity_rows": "ports",
    "momentum_weights": "ports", "mass_spring": "ports", "parse_ports": "ports", "MAX_PORTS": "ports",
}
__all__ = sorted(EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, EXPORTS)
