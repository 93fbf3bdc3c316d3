"""Where a reference's render calls are rendered: here, or elsewhere (a cluster).

A ``batch`` reference (:mod:`mitsuba_refs.reference.batch`) is ``calls`` render calls, call
``i`` with its own seed (:func:`mitsuba_refs.reference.seeds.pass_seeds`). A *split*
(:func:`calls_split_by`) renders them elsewhere, by
:func:`mitsuba_refs.reference.calls.render_calls`, cut by :func:`chunks`; the client merges
every call's block statistics in call order, so the reference is the same bit for bit whoever
rendered which call, in whatever order they finished. A *site* (:func:`rendering_on`) makes
the split of every reference rendered on demand.
"""

import contextlib
from typing import NamedTuple

#: Test hook (docs/cluster.md): a folder where every task writes ``started-<first call>-<pid>``
#: and then waits until a file ``release`` appears, so that a test kills a worker while a task
#: is known to run, without timing.
ENV_FAULT_DIR = "MITSUBA_REFS_FAULT_DIR"


class ReferenceJob(NamedTuple):
    """What a worker needs to render calls of one reference (all picklable)."""

    scene: str
    params: dict
    integrator: str
    spp: int
    seed: int
    variant: str
    options: dict | None = None
    resolution: tuple | None = None
    fault_dir: str | None = None


def chunks(calls: int, tasks: int) -> list:
    """``calls`` call indices cut into at most ``tasks`` consecutive runs of near-equal length."""
    tasks = max(1, min(int(tasks), calls))
    size, extra = divmod(calls, tasks)
    runs, start = [], 0
    for t in range(tasks):
        stop = start + size + (t < extra)
        runs.append(list(range(start, stop)))
        start = stop
    return runs


#: Where references that have to be rendered are rendered (:func:`rendering_on`); None: here.
_site = None


@contextlib.contextmanager
def rendering_on(site):
    """Render the references needed inside this block on ``site`` (an object with a
    ``variant`` and ``split_for(job)``, e.g. :class:`mitsuba_refs.cluster.build.ClusterSite`):
    :func:`mitsuba_refs.reference.cache.get_reference` and ``build_reference`` hand their
    ``batch`` calls to ``site.split_for(job)``. Process-wide (the grader's threads too)."""
    global _site
    previous, _site = _site, site
    try:
        yield site
    finally:
        _site = previous


def current_site():
    """The site of the innermost :func:`rendering_on`, or None (render here)."""
    return _site


#: The ``split`` of the reference being rendered (:func:`calls_split_by`); None: here.
_split = None


@contextlib.contextmanager
def calls_split_by(split):
    """Inside this block, :func:`mitsuba_refs.reference.render.render_reference` hands its
    ``batch`` render calls to ``split`` (:func:`mitsuba_refs.reference.batch.render_moments`;
    e.g. :meth:`mitsuba_refs.cluster.site.ClusterSite.split_for`); None renders them here."""
    global _split
    previous, _split = _split, split
    try:
        yield split
    finally:
        _split = previous


def current_split():
    """The split of the innermost :func:`calls_split_by`, or None."""
    return _split
