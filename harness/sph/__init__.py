"""The full SPH model of section 2.2: kernel, neighbour operator, solver."""
