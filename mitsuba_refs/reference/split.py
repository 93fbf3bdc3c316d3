"""A reference's render calls, rendered anywhere: the task a cluster worker runs.

A ``batch`` reference (:mod:`mitsuba_refs.reference.batch`) is ``calls`` render calls, call
``i`` with its own seed (:func:`mitsuba_refs.reference.seeds.pass_seeds`). :func:`render_calls`
loads the scene as :func:`mitsuba_refs.reference.render.render_reference` does and renders the
calls it is given; the client merges every call's block statistics in call order, so the
reference is the same bit for bit whoever rendered which call, in whatever order they finished.
"""

import contextlib
import os
import time
from pathlib import Path
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


def render_calls(job: ReferenceJob, indices):
    """Block statistics ``(n, mean, M2)`` of the render calls ``indices`` of ``job``, in
    that order (:func:`mitsuba_refs.reference.batch.render_call`)."""
    _hold(job.fault_dir, indices[0])
    import mitsuba as mi  # Mitsuba: optional and heavy, imported where it renders

    from .batch import batch_sensor, call_takes, copies_per_call, render_call
    from .render import integrator_dict, load_mitsuba_scene, reference_settings, stream_id
    from .seeds import pass_seeds
    from .variant import set_variant

    set_variant(job.variant)
    path = Path(job.scene)
    scene_kw, transport, settings = reference_settings(path, job.params, job.options,
                                                       job.resolution)
    scene = load_mitsuba_scene(path, scene_kw, job.resolution)
    integrator = mi.load_dict(integrator_dict(job.integrator, transport, settings.integrator))
    sensor = scene.sensors()[0]
    width, height = (int(v) for v in sensor.film().crop_size())
    k, calls = copies_per_call(job.spp, width, height)
    batch = batch_sensor(sensor, k, width, height)
    stream = stream_id(job.integrator, job.params, job.options, job.resolution)
    seeds = pass_seeds(job.seed, calls, k * width, height, stream)
    takes = call_takes(job.spp, k, calls)
    return [render_call(scene, batch, integrator, seeds[i], takes[i]) for i in indices]


def _hold(fault_dir, first_call):
    """The test hook of :data:`ENV_FAULT_DIR` (nothing when ``fault_dir`` is None)."""
    if not fault_dir:
        return
    folder = Path(fault_dir)
    (folder / f"started-{first_call}-{os.getpid()}").touch()
    while not (folder / "release").exists():
        time.sleep(0.05)


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
