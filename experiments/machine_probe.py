"""What a machine charges for the kinds of work the tracer is made of, one figure each.

    python -m experiments.machine_probe [--json OUT] [--core N]

The tracer's speed moves from one CPU to another far more than a compiled renderer's
(docs/performance.md, "Machines"). A render is millions of small NumPy calls on arrays of a
few thousand to 32k rows, gathers through index arrays, and the Python between them; this
probe times each kind alone, pinned to one core, so that two machines' tables say which kind
costs more where:

* ``interpreter``: a pure-Python loop (ns per iteration): the integrators' own Python;
* ``ufunc call``: ``np.add`` on 8 float64 elements into ``out`` (ns per call): NumPy's fixed
  cost, paid by every call whatever its size;
* ``ufunc row``: ``np.multiply`` on 32k float64 elements (ns per element): arithmetic on a
  pool of paths, in L2 on most CPUs;
* ``gather``: ``np.take`` of 32k random rows of a 1M-element float64 array (ns per row):
  reading vertices, BVH nodes and textures;
* ``boolean mask``: ``a[mask]`` selecting half of 32k rows (ns per row): compacting live paths;
* ``transcendental``: ``np.sin`` on 32k float64 elements (ns per element).

Each figure is the best of ``--repeats`` timings of a loop long enough to last ~50 ms. The
machine's CPU (``/proc/cpuinfo``), caches (``/sys/devices/system/cpu``) and the NumPy kernels
dispatched for the float64 loops are printed with it.
"""
from __future__ import annotations

import argparse
import os
import platform
import time
from pathlib import Path

import numpy as np
from numpy.lib.introspect import opt_func_info

from experiments.bench import write_report
from pathtracer.core.machine import this_machine

#: Rows of a pool of paths (``pathtracer.render.scheduling.DEFAULT_BATCH``).
ROWS = 1 << 15


def best_ns(work, count: int, repeats: int) -> float:
    """Least time of ``work()`` over ``repeats`` runs, divided by ``count``, in ns."""
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        work()
        best = min(best, time.perf_counter() - start)
    return best / count * 1e9


def probe(repeats: int = 5) -> dict:
    """Every figure of the module docstring, in ns."""
    rng = np.random.default_rng(1)
    small_a, small_b, small_out = (np.ones(8) for _ in range(3))
    row_a, row_b, row_out = rng.random(ROWS), rng.random(ROWS), np.empty(ROWS)
    table = rng.random(1 << 20)
    index = rng.integers(0, len(table), ROWS)
    mask = rng.random(ROWS) < 0.5
    calls, passes, loop = 20_000, 200, 1_000_000

    def interpreter():
        total = 0
        for i in range(loop):
            total += i & 7
        return total

    def ufunc_call():
        for _ in range(calls):
            np.add(small_a, small_b, out=small_out)

    def ufunc_row():
        for _ in range(passes):
            np.multiply(row_a, row_b, out=row_out)

    def gather():
        for _ in range(passes):
            np.take(table, index, out=row_out)

    def boolean_mask():
        for _ in range(passes):
            _ = row_a[mask]

    def transcendental():
        for _ in range(passes // 4):
            np.sin(row_a, out=row_out)

    return {
        "interpreter (ns per loop iteration)": best_ns(interpreter, loop, repeats),
        "ufunc call (ns per np.add on 8 elements)": best_ns(ufunc_call, calls, repeats),
        "ufunc row (ns per element of np.multiply, 32k)": best_ns(ufunc_row, passes * ROWS, repeats),
        "gather (ns per row of np.take, 32k of 1M)": best_ns(gather, passes * ROWS, repeats),
        "boolean mask (ns per row, half of 32k)": best_ns(boolean_mask, passes * ROWS, repeats),
        "transcendental (ns per element of np.sin, 32k)":
            best_ns(transcendental, passes // 4 * ROWS, repeats),
    }


def kernels() -> dict:
    """The kernel NumPy dispatches for the float64 loops the probe times."""
    info = opt_func_info(func_name="^(add|multiply|sin)$", signature="^ddd?$")
    return {name: sorted({entry["current"] for entry in sigs.values()})
            for name, sigs in sorted(info.items())}


def main(argv=None) -> int:
    """Print the machine and its figures (and write them as JSON with ``--json``)."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--json", type=Path, default=None, help="write the figures here")
    parser.add_argument("--core", type=int, default=0, help="core to pin to (default 0)")
    parser.add_argument("--repeats", type=int, default=5, help="timings per figure (best kept)")
    args = parser.parse_args(argv)
    if hasattr(os, "sched_setaffinity") and args.core in os.sched_getaffinity(0):
        os.sched_setaffinity(0, {args.core})
    here = this_machine()
    report = dict(cpu=here.cpu, machine=platform.machine(), cores=here.cores,
                  caches=dict(L1d=here.L1d, L2=here.L2, L3=here.L3), numpy=np.__version__,
                  kernels=kernels(), python=platform.python_version(), ns=probe(args.repeats))
    print(f"{here.describe()} ({report['machine']}), Python {report['python']}, "
          f"NumPy {report['numpy']}")
    for name, ns in report["ns"].items():
        print(f"  {name}: {ns:.2f}")
    write_report(report, args.json)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
