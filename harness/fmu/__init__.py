"""The FMU: the frozen-coefficient reduced model as FMI 2.0 / 3.0 co-simulation.

resources  model.bin, the scene's numbers for the C core (format and token)
build      the binaries from fmu_src/ with CMake, built once and cached
describe   modelDescription.xml from the templates in modelDescription/
package    sphrom fmu: scene -> validated .fmu
reference  the FMU's co-simulation in Python (the equality reference)
fmi        one FMU instance through fmpy, with its log
cosim      sphrom cosim: fmpy.simulate_fmu with a force expression or CSV
core       ctypes access to the C core (benchmark, tests)
bench      sphrom bench-fmu
"""
