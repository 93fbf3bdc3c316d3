"""One BLAS thread per process: the small matrix products of the all-pairs tests
do not pay for threads."""
from __future__ import annotations

try:
    from threadpoolctl import threadpool_limits
except ImportError:   # pragma: no cover - a declared dependency
    threadpool_limits = None

_blas_limited = False


def single_threaded_blas() -> None:
    """Limit this process's BLAS to one thread (once; needs ``threadpoolctl``).

    :class:`~pathtracer.accel.small_mesh.SmallMesh`'s matrix products are far too small
    for threads to pay, and OpenBLAS's idle threads spin: with every core busy (render
    workers, parallel tests, a grader beside a sweep) a render took 17x the CPU time
    of the same render with one BLAS thread. The tracer parallelises over
    processes instead, so this process-wide setting costs it nothing.
    """
    global _blas_limited
    if _blas_limited:
        return
    _blas_limited = True
    if threadpool_limits is None:
        return
    threadpool_limits(1, user_api="blas")
