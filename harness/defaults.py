"""The defaults that more than one module needs, each in one place (units in the comments).

A module that needs one of these imports it from here; nothing else types its value.
"""

N_FREEZE = 10                   # refresh period of the frozen model's coefficients [internal steps] (eq. 2.23)
PROBES = (0.25, 0.5, 0.66)      # probe positions [x/L]; 0.66: the probe of the paper's Fig. C.6
