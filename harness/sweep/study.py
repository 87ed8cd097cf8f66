"""The client side of a study: cluster, tasks, progress, checkpoints, resume.

Steps of :func:`run_study`:

1. read RESULTS.h5 when it exists: entries whose id is there with status
   ``ok`` are skipped (resume); failed ones are run again (a failure may be
   the cluster's, e.g. a lost worker; a deterministic one fails again
   quickly), with ``attempts`` counting; rows of entries no longer in the
   spec are kept;
2. package the FMUs the remaining entries need (:mod:`.fmus`, cached);
3. connect: a LocalCluster on this machine (``workers`` processes, one thread
   each) or the scheduler at ``scheduler``;
4. scatter each FMU once, submit one task per entry (grouped by FMU), and
   collect them as they complete behind a progress bar; a task lost with its
   worker (dask's KilledWorker, after the scheduler's own allowed-failures
   rescheduling, or cancelled with a dependency lost with its worker) is
   submitted again up to :data:`LOST_RETRIES` times, its FMU
   scattered again, before it is recorded as failed with a one-line error
   naming the grid point (``StudyResult.lost``); the table is written
   (atomically) every ``checkpoint_s`` seconds, at the end, and on
   SIGINT/SIGTERM, so an interrupted study keeps every finished entry;
5. write RESULTS.h5, RESULTS.csv and the summary RESULTS.png, together (all
   renamed into place, or none).

Signals: while the cluster starts, runs and closes, SIGINT and SIGTERM are held
(:func:`sphrom.signals.deferred`) and acted on between results: raised as an
exception inside dask's finalisers they were lost ("Exception ignored", exit 0
with the full output) or left a half-started cluster to print a traceback at
exit.  An interrupted study writes the finished runs (when there are any) and
reports the signal (``StudyResult.interrupted``, its number); a second signal
during that write leaves the files as they were.

Throughput is the entries finished in this session per second of the compute
phase (first submission to last result; packaging and cluster start-up are
timed apart).
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import json
import logging
import math
import os
import shlex
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import uuid
from concurrent.futures import CancelledError
from dataclasses import dataclass, field
from pathlib import Path

import numpy

from .. import __version__
from ..errors import FieldError, Interrupted
from ..signals import current_guard, deferred, pending
from .plot import summary_plot
from .spec import scene_value
from .table import merge, read_results, write_results

CONNECT_TIMEOUT = 20.0     # s, to reach a scheduler
WORKER_TIMEOUT = 60.0      # s, to see a first worker of an existing cluster
CHECKPOINT_S = 30.0        # s between partial writes
POLL_S = 0.05              # s between looks at the results (and at a held signal)
LOST_RETRIES = 2           # resubmissions of a task whose worker died, before the entry is recorded as failed
SCATTER_TIMEOUT = 30.0     # s, for one scatter of an FMU to the workers (a worker dying meanwhile can stall it)
SCATTER_ATTEMPTS = 3       # scatters tried, each after a worker is there, before giving up
CLOSE_TIMEOUT = 5.0        # s, for the client and the LocalCluster to close (after a Ctrl-C: the sweep's last act)


@dataclass
class StudyResult:
    """What a session did (counts of entries; times in s; throughput in runs/s)."""

    entries: int
    skipped: int
    ran: int
    ok: int
    failed: int
    kept: int
    workers: int
    scheduler: str
    package_wall: float
    cluster_start: float
    compute_wall: float
    total_wall: float
    throughput: float
    interrupted: int                  # the signal that interrupted the study (0: it was not interrupted)
    paths: list = field(default_factory=list)
    plot: str | None = None
    lost: list = field(default_factory=list)     # one line per entry lost with its workers beyond the retries


def input_row(spec, entry, fmu_key):
    """The input columns of ``entry`` (c, d, profile: the scene's when not swept)."""
    scene = spec.scene
    return {
        "id": entry.id, "index": entry.index, "scene": entry.scene,
        "c": entry.c if entry.c is not None else scene_value(scene, "c"),
        "d": entry.d if entry.d is not None else scene_value(scene, "d"),
        "profile": entry.profile if entry.profile is not None else scene.fields["profile"].text,
        "k": entry.k, "model": entry.model, "fmi": entry.fmi, "shape": entry.shape,
        "amplitude": entry.amplitude, "frequency": entry.frequency, "n_freeze": entry.n_freeze,
        "t_end": entry.t_end, "step": entry.step, "compare_sph": int(entry.compare_sph), "fmu": fmu_key,
    }


def wait_for_workers(client, n, timeout, held=()):
    """Wait until ``client`` sees ``n`` workers, at most ``timeout`` s, looking at ``held`` (the signals held
    meanwhile, :func:`sphrom.signals.deferred`) every :data:`POLL_S`: Interrupted for the first one (one long
    ``Client.wait_for_workers`` kept a Ctrl-C waiting for minutes).  TimeoutError after ``timeout``."""
    deadline = time.monotonic() + timeout
    while True:
        if held:
            raise Interrupted(held.pop(0))
        try:
            client.wait_for_workers(n, timeout=min(POLL_S * 4, max(deadline - time.monotonic(), 0.01)))
            return
        except TimeoutError:
            if time.monotonic() >= deadline:
                raise


@contextlib.contextmanager
def workers_ignore_sigint(folder):
    """While the block runs (the LocalCluster's life), the processes multiprocessing spawns (dask's workers)
    start with SIGINT and SIGTERM ignored: a Ctrl-C, which a terminal sends to its whole foreground process
    group, or a SIGTERM sent to the group (``kill -TERM -PGID``, a service manager stopping the command), then
    reaches only the command, which closes the cluster itself and keeps the finished runs; each worker printed a
    KeyboardInterrupt traceback and died, and on SIGTERM died with the results it had not handed over yet.  A
    disposition SIG_IGN survives exec and Python keeps it (a blocked mask does not: the spawn clears it), so the
    spawn runs a two-line shell script in ``folder`` that ignores both and execs this Python.  The workers still
    end when their nanny stops them (a message on its queue, then SIGKILL after a timeout) and with their
    parent.  Nothing changes where the script cannot be made or run (no /bin/sh, a folder mounted noexec)."""
    import multiprocessing.spawn as spawn
    script = Path(folder) / "python-ignoring-sigint"
    try:
        script.write_text(f"#!/bin/sh\ntrap '' INT TERM\nexec {shlex.quote(sys.executable)} \"$@\"\n")
        script.chmod(0o700)
        usable = Path("/bin/sh").exists() and os.access(script, os.X_OK) and \
            subprocess_ok(script)
    except OSError:
        usable = False
    if not usable:
        yield
        return
    previous = spawn.get_executable()
    spawn.set_executable(str(script))
    try:
        yield
    finally:
        spawn.set_executable(previous)


def subprocess_ok(script):
    """Whether ``script`` runs (a folder mounted noexec refuses it)."""
    try:
        return subprocess.run([str(script), "-c", "pass"], timeout=30).returncode == 0
    except (OSError, subprocess.SubprocessError):
        return False


def scratch_folder():
    """A new private folder for dask's scratch space (its workers' folders and lock files), removed by
    :func:`_close`: dask's default, ``dask-scratch-space`` in the temporary folder, kept ``*.lock`` files after
    every sweep."""
    return tempfile.mkdtemp(prefix="sphrom-dask-scratch-space-")


def connect(scheduler=None, workers=None, held=()):
    """(client, cluster): the scheduler at ``scheduler``, else a new LocalCluster (cluster None otherwise).

    The LocalCluster starts with no worker and then asks for ``workers``, waiting for them in steps that look at
    ``held`` (a Ctrl-C while they start ends the wait at once); its scratch space is a folder of its own
    (``cluster.scratch``, removed when it closes).  Raises FieldError ``scheduler`` when the scheduler cannot
    be reached or has no worker.
    """
    from distributed import Client, LocalCluster
    if scheduler:
        try:
            client = Client(scheduler, timeout=CONNECT_TIMEOUT)
        except (OSError, TimeoutError, ValueError) as exc:
            raise FieldError("scheduler", f"cannot connect to {scheduler!r} within {CONNECT_TIMEOUT:g} s "
                                          f"({str(exc).splitlines()[0] if str(exc) else type(exc).__name__})") from None
        try:
            wait_for_workers(client, 1, WORKER_TIMEOUT, held)
        except (TimeoutError, OSError):
            client.close()
            raise FieldError("scheduler", f"the cluster at {scheduler!r} has no worker after "
                                          f"{WORKER_TIMEOUT:g} s") from None
        return client, None
    # dask's own logs stay quiet below CRITICAL: a worker's death (logged as an ERROR with a traceback) reaches
    # the study through its futures, which retry the lost tasks and report what stays lost in one line each
    # dashboard_address ":0": the scheduler's HTTP server on a free port (None still asks for 8787, and dask
    # warns on stderr when another cluster holds it)
    import dask
    scratch = scratch_folder()
    client = cluster = None
    try:
        ignoring = workers_ignore_sigint(scratch)
        ignoring.__enter__()
        with dask.config.set({"temporary-directory": scratch}):
            cluster = LocalCluster(n_workers=0, threads_per_worker=1, processes=True, dashboard_address=":0",
                                   silence_logs=logging.CRITICAL, local_directory=scratch)
            cluster.scratch, cluster.ignoring = scratch, ignoring
            client = Client(cluster)
            cluster.scale(workers or 1)
        wait_for_workers(client, workers or 1, WORKER_TIMEOUT, held)
    except BaseException:
        if client is not None or cluster is not None:
            _close(client, cluster, hurry=True)
        if cluster is None and "ignoring" in locals():
            ignoring.__exit__(None, None, None)
        shutil.rmtree(scratch, ignore_errors=True)
        raise
    return client, cluster


def _versions():
    import dask
    import distributed
    import fmpy
    return {"version.sphrom": __version__, "version.dask": dask.__version__,
            "version.distributed": distributed.__version__, "version.fmpy": fmpy.__version__,
            "version.numpy": numpy.__version__, "version.python": sys.version.split()[0]}


def run_study(spec, out, *, scheduler=None, workers=None, progress=True, checkpoint_s=CHECKPOINT_S,
              log=None) -> StudyResult:
    """Run the entries of ``spec`` not yet done in ``out`` and write the results.

    Parameters
    ----------
    spec : sphrom.sweep.spec.Spec
    out : Path
        RESULTS.h5 (RESULTS.csv and RESULTS.png beside it).
    scheduler : str, optional
        Address of an existing dask scheduler; default a LocalCluster.
    workers : int, optional
        Workers of the LocalCluster (one process and thread each).
    progress : bool
        Progress bar (tqdm, after 2 s).
    checkpoint_s : float
        Seconds between partial writes.
    log : callable, optional
        Told about packaging and connection (one line each).

    Returns
    -------
    StudyResult
    """
    from ..progress import progress_bar
    from .fmus import bundle, ensure_fmus
    from .worker import run_entry

    log = log or (lambda text: None)
    t_start = time.perf_counter()
    out = Path(out)
    previous, old_attrs = read_results(out) if out.exists() else ([], {})
    sessions = json.loads(old_attrs.get("sessions", "[]"))
    session = len(sessions) + 1
    by_id = {row["id"]: row for row in previous}
    ids = {e.id for e in spec.entries}
    todo = [e for e in spec.entries if by_id.get(e.id, {}).get("status") != "ok"]
    skipped = len(spec.entries) - len(todo)
    kept = sum(1 for row in previous if row["id"] not in ids)
    n_probes = len(spec.probes)

    def attrs_for(rows, state):
        in_spec = [r for r in rows if r["id"] in ids]
        record = {"session": session, "utc": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
                  "scheduler": state["scheduler"], "workers": state["workers"], "runs": state["ran"],
                  "compute_wall_s": state["compute"], "throughput_runs_per_s": state["throughput"],
                  "interrupted": state["interrupted"]}
        return {
            "spec.text": spec.text, "spec.source": spec.source, "spec.title": spec.title,
            "scene": spec.scene.name, "probes": list(spec.probes), "window": list(spec.window),
            "scheduler": state["scheduler"], "workers": state["workers"], "threads_per_worker": 1
            if not state["remote"] else -1,
            "package_wall_s": state["package"], "cluster_start_s": state["start"],
            "compute_wall_s": state["compute"], "total_wall_s": time.perf_counter() - t_start,
            "throughput_runs_per_s": state["throughput"], "runs_this_session": state["ran"],
            "entries": len(spec.entries), "ok": sum(r["status"] == "ok" for r in in_spec),
            "failed": sum(r["status"] == "failed" for r in in_spec),
            "complete": int(len(in_spec) == len(spec.entries) and not state["interrupted"]),
            "created_utc": record["utc"], "command": " ".join(sys.argv),
            "sessions": json.dumps(sessions + [record]), **_versions(),
        }

    state = {"scheduler": "none", "workers": 0, "ran": 0, "compute": 0.0, "throughput": float("nan"),
             "package": 0.0, "start": 0.0, "interrupted": 0, "remote": bool(scheduler), "lost": []}
    new_rows = []
    client = cluster = None
    if todo:
        t0 = time.perf_counter()
        variants = ensure_fmus(spec, todo, progress=progress, log=log)
        _stop_if_pending()
        state["package"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        log(f"connecting to {scheduler}" if scheduler else f"starting a LocalCluster of {workers} workers")
        try:
            with deferred() as held:                 # a signal is acted on between results, never inside dask
                client, cluster = connect(scheduler, workers, held)
                state["start"] = time.perf_counter() - t0
                state["scheduler"] = scheduler if scheduler else f"LocalCluster {client.scheduler.address}"
                state["workers"] = len(client.scheduler_info()["workers"])
                try:
                    _compute(client, spec, todo, variants, by_id, session, new_rows, state, progress, checkpoint_s,
                             lambda: write_results(out, merge(previous, new_rows),
                                                   attrs_for(merge(previous, new_rows), state), n_probes),
                             bundle, run_entry, progress_bar, held)
                except BaseException:
                    _close(client, cluster, hurry=True)
                    raise
                else:
                    _close(client, cluster)
                finally:
                    if held:                         # arrived while the cluster closed
                        raise Interrupted(held.pop(0))
        except KeyboardInterrupt as exc:
            state["interrupted"] = int(getattr(exc, "signum", 2))
            guard = current_guard()
            if guard is not None:
                guard.acknowledge()                  # handled here: the finished runs are kept
            if not new_rows:
                raise Interrupted(state["interrupted"]) from None
    rows = merge(previous, new_rows)
    written = []
    plot = None
    if new_rows or not out.exists():
        drawn = {}

        def draw(tmp):
            try:
                drawn["kind"] = summary_plot([r for r in rows if r["id"] in ids], tmp, atomic=False,
                                             title=spec.title or f"{spec.scene.name}: {len(spec.entries)} entries")
            except Exception as exc:            # a plot must never lose the table
                log(f"summary plot not written: {exc}")
        write_results(out, rows, attrs_for(rows, state), n_probes, plot=None if state["interrupted"] else draw)
        written = [out, out.with_suffix(".csv")]
        plot = drawn.get("kind")
        if plot:
            written.append(out.with_suffix(".png"))
    return StudyResult(entries=len(spec.entries), skipped=skipped, ran=state["ran"],
                       ok=sum(r["status"] == "ok" for r in new_rows),
                       failed=sum(r["status"] == "failed" for r in new_rows), kept=kept, workers=state["workers"],
                       scheduler=state["scheduler"], package_wall=state["package"], cluster_start=state["start"],
                       compute_wall=state["compute"], total_wall=time.perf_counter() - t_start,
                       throughput=state["throughput"], interrupted=state["interrupted"], paths=written, plot=plot,
                       lost=list(state["lost"]))


def _stop_if_pending():
    """Interrupted for a signal whose exception was lost (e.g. inside a finaliser while packaging)."""
    signum = pending()
    if signum is not None:
        raise Interrupted(signum)


def _close(client, cluster, hurry=False):
    """Close the client, then the LocalCluster (if ours), with dask's loggers silent meanwhile: a scheduler
    still reporting on cancelled tasks logs each message to the closed client as CRITICAL, with a traceback.
    ``hurry`` (a signal or an error ends the study): the LocalCluster's worker processes are killed first, as
    their results are no longer awaited; a graceful close of workers still starting took the whole
    :data:`CLOSE_TIMEOUT`, on top of the cluster's start that a Ctrl-C waits for (on a loaded machine, more than
    the few seconds a Ctrl-C may take)."""
    if hurry and cluster is not None:
        import multiprocessing
        for proc in multiprocessing.active_children():   # dask's nannies spawn the workers through multiprocessing
            with contextlib.suppress(Exception):
                proc.kill()
    quiet = {name: logging.getLogger(name).level for name in list(logging.root.manager.loggerDict)
             if name == "distributed" or name.startswith("distributed.")}
    for name in quiet:
        logging.getLogger(name).setLevel(logging.CRITICAL + 1)
    try:
        # a close that does not finish in time (workers still starting when a Ctrl-C came) is left: the workers
        # end with their parent (dask's parent-alive pipe); its TimeoutError must not replace the command's end
        try:
            if client is not None:
                with contextlib.suppress(Exception):
                    client.close(timeout=CLOSE_TIMEOUT)
        finally:
            if cluster is not None:
                try:
                    with contextlib.suppress(Exception):
                        cluster.close(timeout=CLOSE_TIMEOUT)
                finally:
                    if getattr(cluster, "ignoring", None) is not None:
                        cluster.ignoring.__exit__(None, None, None)
                    shutil.rmtree(getattr(cluster, "scratch", None) or "", ignore_errors=True)
    finally:
        for name, level in quiet.items():
            logging.getLogger(name).setLevel(level)


def grid_point(entry):
    """The entry's grid point on one line: its index and the swept values (for a lost task's message)."""
    values = {"shape": entry.shape, "amplitude": entry.amplitude, "frequency": entry.frequency, "c": entry.c,
              "d": entry.d, "profile": entry.profile, "k": entry.k, "model": entry.model, "fmi": entry.fmi,
              "n_freeze": entry.n_freeze}
    return f"entry {entry.index} (" + ", ".join(f"{k} = {v}" for k, v in values.items() if v is not None) + ")"


def is_lost(exc):
    """Whether a task's exception means it was lost with a worker, not that the entry failed: dask's
    KilledWorker (its worker died while running it), or a cancellation by the scheduler (a dependency, the
    scattered FMU, died with its worker; the client cancels only on Ctrl-C, which ends the loop first)."""
    from distributed import KilledWorker
    return isinstance(exc, (KilledWorker, CancelledError))


def _completed(pending_futures, held):
    """The futures of ``pending_futures`` (distributed.as_completed) as they finish, looking every POLL_S at
    ``held`` (the signals held meanwhile): Interrupted for the first one."""
    while not pending_futures.is_empty():
        if held:
            raise Interrupted(held.pop(0))
        if not pending_futures.has_ready():
            time.sleep(POLL_S)
            continue
        yield from pending_futures.next_batch(block=False)
    if held:
        raise Interrupted(held.pop(0))


def _scatter(client, value, held=()):
    """``value`` scattered to every worker, in bounded time: a scatter started while a worker dies (the nanny
    restarting it) can wait for it forever, so each of :data:`SCATTER_ATTEMPTS` attempts waits for a worker (at
    most :data:`WORKER_TIMEOUT`) and then scatters (at most :data:`SCATTER_TIMEOUT`); TimeoutError after the last."""
    for attempt in range(SCATTER_ATTEMPTS):
        try:
            wait_for_workers(client, 1, WORKER_TIMEOUT, held)
            # Client.scatter's own timeout did not end a broadcast to a worker that died meanwhile (seen stalled
            # for minutes under load); the client's sync bounds the whole call (callback_timeout: asyncio's
            # wait_for around it)
            return client.sync(client._scatter, [value], hash=False, broadcast=True, timeout=SCATTER_TIMEOUT,
                               callback_timeout=SCATTER_TIMEOUT)[0]
        except (TimeoutError, OSError):
            if attempt == SCATTER_ATTEMPTS - 1:
                raise


def _compute(client, spec, todo, variants, by_id, session, new_rows, state, progress, checkpoint_s, checkpoint,
             bundle, run_entry, progress_bar, held=()):
    """Submit ``todo`` and collect rows into ``new_rows`` (state updated as they come); ``held``: the signals
    held while it runs (:func:`sphrom.signals.deferred`), acted on between results."""
    from distributed import as_completed

    order = {vin: i for i, vin in enumerate(variants)}
    # on every worker: one worker's death does not lose the FMU the other tasks need
    try:
        scattered = {vin: _scatter(client, bundle(v), held) for vin, v in variants.items()}
    except (TimeoutError, OSError):
        raise FieldError("scheduler", f"the FMUs could not be sent to the workers ({SCATTER_ATTEMPTS} attempts of "
                                      f"{SCATTER_TIMEOUT:g} s each after a worker was there)") from None
    tag = uuid.uuid4().hex[:8]
    t0 = time.perf_counter()
    futures = {}
    for entry in sorted(todo, key=lambda e: (order[e.variant_inputs()], e.index)):
        fut = client.submit(run_entry, scattered[entry.variant_inputs()], entry, key=f"sweep-{entry.id}-{tag}",
                            pure=False)
        futures[fut] = entry
    last = time.perf_counter()
    n_failed = 0
    losses = {}                                     # entry id -> times its task was lost with its worker
    try:
        with progress_bar(total=len(futures), desc="sweep", unit="run", enabled=progress) as bar:
            pending = as_completed(futures)
            for fut in _completed(pending, held):
                entry = futures[fut]
                row = input_row(spec, entry, variants[entry.variant_inputs()].key)
                try:
                    row.update(fut.result())
                except Exception as exc:            # the task itself was lost (e.g. a killed worker)
                    if is_lost(exc) and losses.get(entry.id, 0) < LOST_RETRIES:
                        losses[entry.id] = losses.get(entry.id, 0) + 1
                        vin = entry.variant_inputs()
                        try:
                            # the worker that died may have held the scattered FMU: scatter it again, once a
                            # worker is back (the nanny restarts a dead one)
                            scattered[vin] = _scatter(client, bundle(variants[vin]), held)
                            retry = client.submit(run_entry, scattered[vin], entry, pure=False,
                                                  key=f"sweep-{entry.id}-{tag}-retry{losses[entry.id]}")
                        except (TimeoutError, OSError) as again:       # no worker came back
                            losses[entry.id] -= 1
                            exc = again
                        else:
                            futures[retry] = entry
                            pending.add(retry)
                            fut.release()
                            continue
                    if entry.id in losses or is_lost(exc):
                        lost = (f"{grid_point(entry)} was lost {losses.get(entry.id, 0) + 1} times with its "
                                f"worker ({type(exc).__name__}: {' '.join(str(exc).split()).split('. ')[0]})")
                        state["lost"].append(lost)
                        row.update({"status": "failed", "error": lost[:600]})
                    else:
                        row.update({"status": "failed", "error": f"{type(exc).__name__}: {exc}"[:600]})
                row["attempts"] = int(by_id.get(entry.id, {}).get("attempts", 0)) + 1
                row["session"] = session
                new_rows.append(row)
                fut.release()
                n_failed += row["status"] != "ok"
                state["ran"] = len(new_rows)
                state["compute"] = time.perf_counter() - t0
                state["throughput"] = state["ran"] / state["compute"] if state["compute"] > 0 else math.nan
                bar.update(1)
                if n_failed:
                    bar.set_postfix_str(f"{n_failed} failed")
                if time.perf_counter() - last >= checkpoint_s:
                    checkpoint()
                    last = time.perf_counter()
    except KeyboardInterrupt:
        client.cancel(list(futures))
        raise
