"""Parameter studies of sphrom FMUs on dask.distributed (``sphrom sweep``).

Modules (plain functions, small):

* :mod:`.spec`    -- SPEC.toml: parsing, validation, the Cartesian product
  expanded into entries with stable ids, force shapes;
* :mod:`.fmus`    -- one FMU per scene variant (scene, c, d, profile, k,
  model), packaged on the client and cached on disk;
* :mod:`.worker`  -- the task run on a dask worker: a worker-local cache of
  instantiated FMUs (reset between runs), probe statistics, the optional full
  SPH run and its error;
* :mod:`.table`   -- the result table (HDF5 columns + CSV), merge for resume;
* :mod:`.plot`    -- the summary PNG (a response surface when it can be one);
* :mod:`.study`   -- the client: cluster, tasks, progress bar, checkpoints.

The committed measurement of sweeps is a measurement program, ``sphrom bench sweep`` (:mod:`sphrom.bench.sweep`).
"""
