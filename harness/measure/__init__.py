"""What is left of the old measurement library (now :mod:`sphrom.bench.lib`): ``hostile_fmu``, the hostile
battery's FMU cases, which moves to the test side with :mod:`sphrom.bench.hostile`."""
