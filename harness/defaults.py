"""The defaults that more than one module needs, each in one place (units in the comments).

A module that needs one of these imports it from here; nothing else types its value.
"""

N_FREEZE = 10                   # refresh period of the frozen model's coefficients [internal steps] (eq. 2.23)
REFRESH = "tensor"              # the frozen model's refresh path: the exact tensor ("direct": the O(N k²) product)
HOLD = "linear"                 # a linear model's input over a communication step ("held": its start value)
ORDER_TOLERANCE = 1e-3          # the balanced model's order criterion: Hankel-singular-value tail / total
PROBES = (0.25, 0.5, 0.66)      # probe positions [x/L]; 0.66: the probe of the paper's Fig. C.6
