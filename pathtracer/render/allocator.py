"""Keep freed array memory in the process heap instead of returning it to the kernel.

A wavefront step allocates and frees dozens of temporaries of a few hundred KB
each (one float64 plane of a 32k-ray batch is 256 KB). glibc serves blocks above
its mmap threshold (128 KB at first) with a fresh ``mmap`` and unmaps them on
``free``, so every temporary paid page faults and the kernel's zeroing of its
pages: 12 % of a Cornell box render's CPU time (``perf``, 2026-11-30). Raising
the mmap and trim thresholds makes ``malloc`` reuse the heap's freed blocks;
the process keeps its peak heap size instead (bounded batches keep that small).
"""
from __future__ import annotations

import ctypes
import sys

_M_TRIM_THRESHOLD = -1
_M_MMAP_THRESHOLD = -3
#: glibc's largest mmap threshold on 64-bit systems (blocks above it are mmapped anyway).
MMAP_THRESHOLD = 32 << 20
#: Free memory at the top of the heap kept before it is given back (about one batch's
#: temporaries; more only raises the peak memory).
TRIM_THRESHOLD = 32 << 20

_done = False


def keep_freed_memory() -> bool:
    """Set glibc's allocator thresholds (once per process); False where not glibc."""
    global _done
    if _done:
        return True
    _done = True
    if not sys.platform.startswith("linux"):
        return False
    try:
        # The process's own symbols (libc is loaded): no library search, which would start
        # ``ldconfig`` and is refused inside the autograder's sandbox.
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):   # musl and others: no mallopt, nothing to tune
        return False
    mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    return all(mallopt(param, value) == 1 for param, value in (
        (_M_MMAP_THRESHOLD, MMAP_THRESHOLD), (_M_TRIM_THRESHOLD, TRIM_THRESHOLD)))
