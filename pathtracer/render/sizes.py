"""Camera paths per batch, chosen at run time from what the machine reports.

A batch (a pool, for the integrators that refill theirs) costs a fixed time per call
of its NumPy kernels and a time per path: measured on three hosts (docs/performance.md,
"Sizes from the machine"), batches of 8k paths pay 15-30 % more per path than 32k, 16k up
to 15 %, and 32k-128k are equally fast within each machine's run-to-run spread, whatever
its caches (L2 512 KB to 2 MB per core, L3 8 MB to 260 MB). What the machine does decide is the
memory: a batch holds :data:`~.resources.BYTES_PER_PATH` plus its units' camera samples
per path, in every process. So the batch is the largest power of two up to
:data:`BATCH_CAP` whose batches, in all processes, take at most :data:`MEMORY_SHARE` of
the memory the machine has available, and never below :data:`BATCH_FLOOR`.

The image does not depend on the batch size for camera integrators (random numbers are
keyed by pixel and sample); light tracers splat in batch order, so their batch stays
:data:`~.scheduling.DEFAULT_BATCH` on every machine.
"""
from __future__ import annotations

from dataclasses import dataclass

from ..core.machine import Machine, this_machine
from . import resources
from .scheduling import DEFAULT_BATCH

#: Largest batch: 64k paths were no faster on any machine measured and double the memory
#: (1024 x 1024 at 64 spp over two processes would pass 300 MB).
BATCH_CAP = DEFAULT_BATCH
#: Smallest batch: at 4k paths the per-call costs are about half of a Cornell box render.
BATCH_FLOOR = 1 << 12
#: Fraction of the available memory that the batches of all processes may hold: the rest
#: is the images, the scene and whatever else runs on the machine.
MEMORY_SHARE = 0.25


@dataclass(frozen=True)
class BatchSize:
    """A batch size and why it was chosen (shown by ``pathtracer render --verbose`` and the bench)."""

    paths: int
    reason: str


def choose_batch(processes: int, available: int | None) -> BatchSize:
    """The camera paths per batch for ``processes`` processes with ``available`` bytes free
    (None: unknown, the cap).

    Examples
    --------
    >>> choose_batch(2, 16 << 30).paths
    32768
    >>> choose_batch(2, 256 << 20).paths
    16384
    """
    per_path = resources.BYTES_PER_PATH + resources.BYTES_PER_UNIT_SAMPLE
    if available is None:
        return BatchSize(BATCH_CAP, "the cap; the available memory is unknown")
    processes = max(1, processes)
    budget = available * MEMORY_SHARE / processes
    paths = BATCH_CAP
    while paths > BATCH_FLOOR and paths * per_path > budget:
        paths //= 2
    if paths * per_path > budget:
        why = "the floor, though memory is short"
    else:
        why = "the cap" if paths == BATCH_CAP else "bound by memory"
    held = resources.format_bytes(paths * per_path)
    return BatchSize(paths, f"{why}: {processes} x {held} of "
                            f"{resources.format_bytes(available)} available")


def machine_batch(processes: int) -> BatchSize:
    """:func:`choose_batch` with the memory this machine has available now."""
    return choose_batch(processes, resources.available_memory())


def render_batch(processes: int, splats: bool = False) -> BatchSize:
    """The batch a render uses: the machine's (:func:`machine_batch`), or for a light tracer
    (``splats``) the fixed :data:`~.scheduling.DEFAULT_BATCH`."""
    if splats:
        return BatchSize(DEFAULT_BATCH, "fixed for light tracers: their splat sums depend on it")
    return machine_batch(processes)


def describe(batch: BatchSize, accel=None, machine: Machine | None = None) -> list[str]:
    """Lines saying the machine and the sizes a render on it uses (``--verbose``, the bench).

    ``batch``: the render's (:func:`render_batch`); ``accel``: the scene's triangle
    accelerator, for its all-pairs chunk where it has one.
    """
    machine = machine or this_machine()
    lines = [f"machine: {machine.describe()}",
             f"batch: {batch.paths} paths per process ({batch.reason})"]
    small = getattr(accel, "small", accel)
    if getattr(small, "chunk", None):
        lines.append(f"all-pairs chunk: {small.chunk_reason}")
    return lines
