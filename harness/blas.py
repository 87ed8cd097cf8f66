"""BLAS threads sized to the problem (threadpoolctl).

A dense LAPACK call on a small matrix (the POD's thin SVD of a 400 x 100 snapshot matrix, a k x k solve) gains
nothing from a second thread and loses much on a loaded machine: OpenBLAS's two threads took 147-2843 ms for an
SVD that takes 5.5-9 ms on one thread.  Below :data:`SERIAL_FLOPS` the call runs on one thread; above
it BLAS keeps its own setting (all cores).
"""

from __future__ import annotations

import contextlib

SERIAL_FLOPS = 1e9      # a dense call of fewer floating-point operations runs on one BLAS thread


def svd_flops(rows, cols):
    """Floating-point operations of a thin SVD of a rows x cols matrix (Golub-Van Loan's R-SVD count, about
    4 m n^2 + 22 n^3 with n the smaller side)."""
    m, n = max(rows, cols), min(rows, cols)
    return 4.0 * m * n * n + 22.0 * n ** 3


def dense_flops(n):
    """Floating-point operations of the dense O(n^3) work on an n x n matrix (a solve, a Schur form, an
    exponential: about 10 n^3 at most)."""
    return 10.0 * float(n) ** 3


def threads_for(flops):
    """BLAS threads for a call of ``flops`` operations: 1 below SERIAL_FLOPS, else None (BLAS's own setting)."""
    return 1 if flops < SERIAL_FLOPS else None


@contextlib.contextmanager
def sized(flops):
    """Run the block with BLAS threads sized to ``flops`` operations (:func:`threads_for`); the previous
    setting is restored after it."""
    threads = threads_for(flops)
    if threads is None:
        yield
        return
    from threadpoolctl import threadpool_limits
    with threadpool_limits(limits=threads, user_api="blas"):
        yield
