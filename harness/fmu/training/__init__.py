"""What packaging learns from the scene before an FMU is written, shared by every model kind and by the checks.

    steps.py     the scene's POD basis and its training run, the training envelope, the certified bounds' shadow
                 (each kind's ``resource`` calls them: :mod:`sphrom.fmu.kinds`)
    envelope.py  the training envelope: what the basis was trained on, and the training force the checks replay

Below :mod:`sphrom.fmu.kinds`, :mod:`sphrom.fmu.make` and :mod:`sphrom.fmu.check`: it imports none of them.
"""
