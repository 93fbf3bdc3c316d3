"""Scheduling: units of camera samples, run in order or over forked worker processes.

Work is cut into *units*: a range of pixels times a block of at most
``SAMPLE_BLOCK`` samples of each. A job turns a group of units into one block of
statistics per unit (:mod:`.jobs`); blocks merge in unit order, so the result does not
depend on the number of processes or on the grouping. The workers never outlive the
render (:mod:`.workers`).
"""

from __future__ import annotations

import collections
import multiprocessing
import os
import sys
from concurrent.futures import ProcessPoolExecutor

from ..core.progress import Progress
from . import workers
from .moments import merge_block

#: Samples of one pixel reduced together; fixed so results never depend on batching.
SAMPLE_BLOCK = 256
#: Camera paths per batch (bounded memory: about 1 KB per path in flight).
DEFAULT_BATCH = 1 << 15

#: The job of this worker process (any object with ``run(group)``): set by
#: :func:`_install_job` in each forked worker, never in the parent process.
_worker_job = None


def run_units(job, groups, stats, processes: int, progress: bool, merge=None):
    """Run ``job.run(group)`` for every group of units and merge the blocks it returns (one
    per unit) into ``stats`` (returned).

    ``merge(stats, unit, block)`` defaults to the per-pixel (count, mean, M2) update
    (:func:`.moments.merge_block`).

    With ``processes`` > 1 the groups go to forked workers that receive ``job`` at fork
    (inherited, never pickled, no global in this process: renders running concurrently
    in threads cannot swap jobs). Blocks are merged in unit order, so the result does not
    depend on the number of processes or on the grouping. The workers die with this
    process and are killed at once when the render is interrupted
    (:mod:`.workers`).
    """
    bar = _progress_bar(sum(map(len, groups)), progress)
    try:
        _run_units(job, groups, stats, processes, bar, merge or merge_block)
    finally:
        bar.close()
    return stats


def _run_units(job, groups, stats, processes: int, bar, merge) -> None:
    if processes == 1 or len(groups) == 1:
        for group in groups:
            for unit, block in zip(group, job.run(group)):
                merge(stats, unit, block)
            bar.update(len(group))
    else:
        ctx = multiprocessing.get_context("fork")
        with ProcessPoolExecutor(processes, mp_context=ctx, initializer=_install_job,
                                 initargs=(job, os.getpid())) as pool:
            try:
                # Futures of our own, not pool.map: its iterator cancels the pending futures
                # from this thread when interrupted, racing the pool's manager thread, which
                # then fails them as broken once stop_pool kills the workers (Python 3.11's
                # InvalidStateError traceback). Only the manager thread settles them here.
                with workers.signals_blocked():   # the workers are forked by the first submit
                    pending = collections.deque(pool.submit(_run_current, group) for group in groups)
                for group in groups:
                    blocks = pending.popleft().result()   # popped: a merged block is freed
                    for unit, block in zip(group, blocks):
                        merge(stats, unit, block)
                    bar.update(len(group))
            except BaseException:
                # Ctrl-C, SIGTERM or an error: do not wait for the units in flight.
                workers.stop_pool(pool)
                raise


def plan_units(n_pixels: int, spp: int, batch_size: int) -> list[tuple[int, int, int, int]]:
    """Units (pixel_begin, pixel_end, sample_begin, sample_end), sample blocks outermost per pixel range."""
    block = min(spp, SAMPLE_BLOCK)
    pixels_per_unit = max(1, batch_size // block)
    units = []
    for p0 in range(0, n_pixels, pixels_per_unit):
        p1 = min(n_pixels, p0 + pixels_per_unit)
        for s0 in range(0, spp, SAMPLE_BLOCK):
            units.append((p0, p1, s0, min(spp, s0 + SAMPLE_BLOCK)))
    return units


def group_units(units: list, per_group: int, processes: int) -> list[tuple]:
    """Consecutive units in groups of ``per_group``, fewer where the processes would
    otherwise wait: every process gets a group while there are units."""
    size = max(1, min(per_group, -(-len(units) // max(1, processes))))
    return [tuple(units[i:i + size]) for i in range(0, len(units), size)]


def _install_job(job, parent_pid):
    global _worker_job
    workers.init_worker(parent_pid)
    _worker_job = job


def _run_current(group):
    return _worker_job.run(group)


class _NoBar:
    def update(self, n=1):
        pass

    def close(self):
        pass


def _progress_bar(total: int, enabled: bool):
    if not enabled:
        return _NoBar()
    # A bar with the time left on a terminal, a plain line every few seconds in a pipe.
    return Progress(total, "rendering", "batches", stream=sys.stderr)
