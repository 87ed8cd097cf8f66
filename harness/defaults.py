"""The defaults that more than one module needs, each in one place (units in the comments).

A module that needs one of these imports it from here; nothing else types its value.
"""

N_FREEZE = 10                   # refresh period of the frozen model's coefficients [internal steps] (eq. 2.23)
REFRESH = "tensor"              # the frozen model's refresh path: the exact tensor ("direct": the O(N k²) product)
HOLD = "linear"                 # a linear model's input over a communication step ("held": its start value)
ORDER_TOLERANCE = 1e-3          # the balanced model's order criterion: Hankel-singular-value tail / total
PROBES = (0.25, 0.5, 0.66)      # probe positions [x/L]; 0.66: the probe of the paper's Fig. C.6
STEP = 0.01                     # an FMU's DefaultExperiment stepSize [s] (at most T/10), the benchmarks' step

# The FMU's start values that are the same in every FMU (harness/fmu/variables.py declares them; the instance
# layer, fmu_src/instance.c, applies them after every instantiation and reset).  The Python models keep their
# own defaults (harness/rom/: initial state scale 1, the scene's initial state).
FMU_INITIAL_STATE_SCALE = 0     # the FMU starts at rest: initial state = this x the scene's deviation from rest [1]
# |initial_state_scale| allowed by sphrom cosim [1]: the reduced models were built on the scene's own deviation
# (scale 1); a thousand times it is far past what they represent, and 1e308 overflowed the outputs
MAX_INITIAL_STATE_SCALE = 1e3
FMU_INPUT = 0                   # the inputs f [m s^-2] and F_port_j [N] before the importer sets them
FMU_AREA = 1                    # the cross-section A of an FMU with ports [m^2]
FMU_PORT_IMPEDANCE = 0          # port_impedance [N s m^-1]: 0, the force form of the ports (F_port_j the inputs)
