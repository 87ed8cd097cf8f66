"""The validation report of ``sphrom validate``: one Markdown page per scene.

* :mod:`.accuracy`: the full SPH against the exact solution and every
  continuum reference, the references against each other, the paper's SPH
  figures beside ours and, where they differ by more than 25 %, the evidence;
* :mod:`.reduced`: the POD figures (singular values, modes, error against k,
  the snapshot studies, time against error of the accelerated models);
* :mod:`.convergence`: the references' convergence against the exact
  solution, and scikit-fem against py-pde on ``heterogeneous``;
* :mod:`.pages`: the page of one scene and the index.
"""
