"""sphrom harness: full SPH, POD reduced models, FMU packaging and validation.

The package follows the paper (Fang, Song, Fraser, Huang, "POD-based
model-order reduction of SPH for a 1D mass-spring-damper system"); equation
numbers in comments refer to it.
"""

__version__ = "0.1.0"
