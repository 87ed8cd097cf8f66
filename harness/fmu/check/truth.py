"""The truth packaging measures an FMU against (the full SPH linear in J, integrated exactly in time): its one
implementation is :mod:`sphrom.rom.truth`, below the FMU layers, which the bounds' reference
(:func:`sphrom.rom.reference.exact_probe_reference`) uses too; this module keeps the names where packaging finds
them."""

from ...rom.truth import DENSE_MAX, TERMS, THETA, TRUTH_NAME, exact_probe_outputs, step_map

__all__ = ["DENSE_MAX", "TERMS", "THETA", "TRUTH_NAME", "exact_probe_outputs", "step_map"]
