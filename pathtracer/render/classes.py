"""Path classes: one image per Heckbert path class in a single render pass."""

from __future__ import annotations

import os
import time

from ..integrators.pathclass import PathClassIntegrator
from ..scene.load import load_scene
from ..scene.types import Scene
from ..shapes import intersect
from .jobs import CameraJob
from .moments import mean_and_variance, pixel_statistics
from .scheduling import plan_units, run_units
from .sizes import BatchSize, render_batch


def class_batch(classes: int, processes: int) -> BatchSize:
    """The batch of a render of ``classes`` path classes: the machine's (:func:`.sizes.render_batch`)
    over ``classes / 2``, since each path carries 3 values per class (at least 1024 paths)."""
    batch = render_batch(processes)
    share = max(1, classes // 2)
    return BatchSize(max(1024, batch.paths // share), f"{batch.reason}; / {share} for {classes} classes")


class _ClassJob(CameraJob):
    """Renders one unit of all path classes: (n, 3 K) values per camera ray."""

    def estimate(self, rays, rng):
        """(n, 3 K) values: the path-class integrator's radiance in each of its K classes."""
        return self.integrator.radiance_classes(self.scene, rays, rng)


def render_classes(scene, classes, spp: int = 16, seed: int = 0, processes: int | None = 1,
                   batch_size: int | None = None, progress: bool = False, glossy="G", **options):
    """Render one image per Heckbert path class in a single pass.

    Random numbers are keyed exactly as in :func:`.driver.render`, so with the same ``seed`` and
    options the classes are a split of the ``path`` image (of its box-filtered image: the
    classes ignore the film's reconstruction filter).

    Parameters
    ----------
    scene : Scene or str
        A loaded scene, or a path / built-in name passed to ``load_scene``.
    classes : str or list of str
        Path-class expressions, light first (``"LS+DE"``; :mod:`pathtracer.core.pathclasses`).
    spp, seed, processes, batch_size, progress
        As for :func:`.driver.render` (``batch_size`` None: smaller batches for many classes).
    glossy : str
        Letter of rough conductors, or an alpha threshold
        (:class:`~pathtracer.integrators.pathclass.PathClassIntegrator`).
    **options
        Options of the MIS path tracer (max_depth, rr_depth, ...).

    Returns
    -------
    dict
        ``classes`` (list of str), ``mean`` and ``variance`` ((n_classes, H, W, 3) each),
        ``spp``, ``seed``, ``seconds``, ``options``.
    """
    if not isinstance(scene, Scene):
        scene = load_scene(scene)
    integrator = PathClassIntegrator(classes, glossy=glossy, **options)
    K = len(integrator.classes)
    n_pixels = scene.camera.width * scene.camera.height
    processes = (os.cpu_count() or 1) if processes is None else max(1, int(processes))
    units = plan_units(n_pixels, int(spp), batch_size or class_batch(K, processes).paths)
    intersect.prepare(scene)
    start = time.perf_counter()
    stats = run_units(_ClassJob(scene, integrator, int(spp), int(seed)), [(u,) for u in units],
                      pixel_statistics(n_pixels, 3 * K), processes, progress)
    mean, variance = mean_and_variance(stats)
    h, w = scene.camera.height, scene.camera.width

    def per_class(a):
        return a.reshape(h, w, K, 3).transpose(2, 0, 1, 3)

    return dict(classes=integrator.expressions, mean=per_class(mean), variance=per_class(variance),
                spp=int(spp), seed=int(seed), seconds=time.perf_counter() - start,
                options=integrator.options())
