"""Making an FMU (``sphrom fmu``): :mod:`.package` is the sequence of named steps, each step a module here.

``options`` (the packaging options checked before any work), ``models`` (the model's numbers and operators per
resource kind: frozen, exact, balanced), ``envelope`` (what the basis was trained on), ``parametric`` (one model
over a range of c and d), ``describe`` (modelDescription.xml from the templates and the variable table),
``documentation`` (documentation/index.html), ``build`` (the binaries, CMake, cached), ``archive`` (the zip and
fmpy's validation), ``package`` (``package_fmu``: the steps in order), ``auto`` (``--model auto``).
"""
