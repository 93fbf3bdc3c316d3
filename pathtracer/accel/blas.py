"""One BLAS thread per process: the small matrix products of the all-pairs tests
do not pay for threads."""
from __future__ import annotations

_blas_limited = False


def single_threaded_blas() -> None:
    """Limit this process's BLAS to one thread (once; needs ``threadpoolctl``).

    :class:`SmallMesh`'s matrix products are far too small for threads to pay,
    and OpenBLAS's idle threads spin: with every core busy (render workers,
    parallel tests, a grader beside a sweep) a render took 17x the CPU time
    of the same render with one BLAS thread. The tracer parallelises over
    processes instead, so this process-wide setting costs it nothing.
    """
    global _blas_limited
    if _blas_limited:
        return
    _blas_limited = True
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:   # pragma: no cover - a declared dependency
        return
    threadpool_limits(1, user_api="blas")
