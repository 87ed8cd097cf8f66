"""SIGINT and SIGTERM on the command line: one line, exit status 128 + the signal, and a true account of what
was written.

The command line (:func:`sphrom.cli.main`) installs a :class:`Guard` as the handler of both signals before
anything else.  The guard raises :class:`~sphrom.errors.Interrupted` in the main thread and remembers the
signal: an exception raised inside a finaliser or a callback (h5py, dask, zipfile) is lost (Python would print
it as "Exception ignored"; the guard keeps that report quiet), but the guard still knows, so the next output is
not committed (:func:`sphrom.runio.atomic_path` checks :func:`pending` before its rename) and the command
exits 128 + the signal when it returns.  Raised inside an import, the exception would break the import (numpy's
C extension reports a failed import): there the guard delivers the signal again once the import is done.  The
guard also lists the outputs committed, so the one-line message says what was written before the signal ("no
output written" only when that is true).

:func:`deferred` holds both signals while a block runs (an HDF5 write, a rename, a cluster start) and
delivers them to the previous handler when it ends.  Only the main thread can set handlers; elsewhere
nothing is held and no guard is found.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading

from .errors import Interrupted

SIGNALS = (signal.SIGINT, signal.SIGTERM)
RETRY_S = 0.01          # a signal that arrived inside an import is delivered again after this long [s]


class Guard:
    """The command line's handler of SIGINT and SIGTERM.

    Attributes
    ----------
    received : list of int
        Every signal received, in order.
    handled : int
        How many of ``received`` were handled on purpose (:meth:`acknowledge`); the rest are :attr:`pending`.
    written : list of Path
        Outputs committed by :func:`sphrom.runio.atomic_path` while the guard was installed.
    raising : bool
        Raise :class:`Interrupted` (while the command runs); False: only record (its message is printed).
    finished : bool
        The command has returned: a signal now ends the process at once (exit 128 + the signal, one line).
    """

    def __init__(self):
        self.received = []
        self.handled = 0
        self.written = []
        self.raising = True
        self.finished = False
        self.command = None
        self._retrying = set()
        self._previous_hook = None

    def __call__(self, signum, frame):
        if signum in self._retrying:         # the same signal, delivered again after an import
            self._retrying.discard(signum)
        else:
            self.received.append(signum)
        if self.finished:                  # interpreter shutdown (dask's atexit hooks): leave now, one line
            self.finished = False
            with contextlib.suppress(Exception):
                sys.stdout.flush()
                sys.stderr.write(interrupt_line(self.command, signum, self.written_text()) + "\n")
                sys.stderr.flush()
            os._exit(128 + int(signum))
        if not self.raising:
            return
        if _inside_import(frame):
            # an exception raised inside an import breaks it (numpy's C extension reports a failed import,
            # importlib's lock callbacks print "Exception ignored"): deliver the signal again once it is done
            self._retrying.add(signum)
            timer = threading.Timer(RETRY_S, os.kill, (os.getpid(), signum))
            timer.daemon = True
            timer.start()
            return
        raise Interrupted(signum)

    @property
    def pending(self):
        """Signals received and not handled on purpose (their exception may have been lost)."""
        return self.received[self.handled:]

    def acknowledge(self):
        """The signals received so far are handled (e.g. a sweep that keeps its finished runs)."""
        self.handled = len(self.received)

    def written_text(self):
        """What the command wrote before the signal, for the one-line message."""
        paths = list(dict.fromkeys(str(p) for p in self.written if _exists(p)))
        if not paths:
            return "no output written"
        if len(paths) > 3:
            return f"{len(paths)} outputs already written ({', '.join(paths[:3])}, ...)"
        return "already written: " + ", ".join(paths)

    @contextlib.contextmanager
    def installed(self, restore=True):
        """The guard as the handler of SIGINT and SIGTERM, each unless ignored (main thread only); the
        previous handlers back afterwards when ``restore``, else the guard stays (``finished``) through the
        interpreter's shutdown."""
        if threading.current_thread() is not threading.main_thread():
            yield self
            return
        previous = {sig: signal.getsignal(sig) for sig in SIGNALS}
        for sig, handler in previous.items():
            if handler is not signal.SIG_IGN:          # a job started with the signal ignored keeps it so
                signal.signal(sig, self)
        hook = self._previous_hook = sys.unraisablehook
        sys.unraisablehook = self._unraisable
        try:
            yield self
        finally:
            self.raising = False
            if restore:
                sys.unraisablehook = hook
                for sig, handler in previous.items():
                    signal.signal(sig, handler if handler is not None else signal.SIG_DFL)
            else:
                self.finished = True

    def _unraisable(self, unraisable):
        """Python's report of an exception a finaliser could not raise: silent for the guard's own Interrupted
        (the guard acts on that signal: :attr:`pending`), the default report for anything else."""
        if isinstance(unraisable.exc_value, Interrupted) and unraisable.exc_value.signum in self.received:
            return
        (self._previous_hook or sys.__unraisablehook__)(unraisable)


def _inside_import(frame, depth=400):
    """Whether ``frame`` (the one a signal handler interrupted) runs inside an import (importlib's frames)."""
    while frame is not None and depth > 0:
        if frame.f_code.co_filename.startswith("<frozen importlib"):
            return True
        frame = frame.f_back
        depth -= 1
    return False


def _exists(path):
    try:
        return os.path.exists(path)
    except (OSError, ValueError):
        return False


def interrupt_line(command, signum, what):
    """``sphrom COMMAND: interrupted (SIGINT); no output written`` (``what``: :meth:`Guard.written_text`)."""
    name = signal.Signals(signum).name
    return f"sphrom{' ' + command if command else ''}: interrupted ({name}); {what}"


def current_guard():
    """The :class:`Guard` installed (also beneath a :func:`deferred` block), or None (a library call, a
    thread other than the main one, a dask worker)."""
    for sig in SIGNALS:
        handler = signal.getsignal(sig)
        for _ in range(64):                     # deferred blocks nest: follow their ``previous``
            if isinstance(handler, Guard):
                return handler
            handler = getattr(handler, "previous", None)
            if handler is None:
                break
    return None


def pending():
    """The first signal received and not handled (its Interrupted lost in a finaliser), or None."""
    guard = current_guard()
    return guard.pending[0] if guard is not None and guard.pending else None


def record_written(path):
    """Tell the guard (if any) that ``path`` was committed."""
    guard = current_guard()
    if guard is not None:
        guard.written.append(path)


class _Holder:
    """The handler of a :func:`deferred` block: records the signal, keeps the handler it replaced."""

    def __init__(self, previous, caught):
        self.previous = previous
        self.caught = caught

    def __call__(self, signum, frame):
        self.caught.append(signum)


@contextlib.contextmanager
def deferred(signums=SIGNALS):
    """Hold SIGINT/SIGTERM while the block runs, then deliver them to the previous handlers.

    Yields the list of the signals held so far; a block that acts on them itself (raises Interrupted for one)
    empties the list, and nothing is delivered again.  A signal raised as an exception inside h5py, zipfile
    or dask can land in a finaliser, where Python prints "Exception ignored" and carries on; held here, it
    is delivered after the block.  Only the main thread can set handlers; elsewhere nothing is held.
    """
    if threading.current_thread() is not threading.main_thread():
        yield []
        return
    caught = []
    previous = {}
    for sig in signums:
        previous[sig] = signal.getsignal(sig)
        if previous[sig] is not signal.SIG_IGN and previous[sig] is not None:
            signal.signal(sig, _Holder(previous[sig], caught))
    try:
        yield caught
    finally:
        for sig, handler in previous.items():
            if handler is not signal.SIG_IGN and handler is not None:
                signal.signal(sig, handler)
        held = list(dict.fromkeys(caught))
        caught.clear()
        for sig in held:                 # also over an exception of the block: the signal came first
            signal.raise_signal(sig)     # the restored handler raises (or ends the process)
