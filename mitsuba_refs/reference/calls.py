"""The task a cluster worker runs: some render calls of one reference
(:mod:`mitsuba_refs.reference.split`)."""

import os
import time
from pathlib import Path

from .batch import batch_sensor, call_takes, copies_per_call, render_call
from .render import integrator_dict, load_mitsuba_scene, reference_settings, stream_id
from .seeds import pass_seeds
from .split import ReferenceJob
from .variant import set_variant


def render_calls(job: ReferenceJob, indices):
    """Block statistics ``(n, mean, M2)`` of the render calls ``indices`` of ``job``, in
    that order (:func:`mitsuba_refs.reference.batch.render_call`)."""
    _hold(job.fault_dir, indices[0])
    import mitsuba as mi  # Mitsuba: optional and heavy, imported where it renders
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
