"""What a scene file asks to be rendered, without building its geometry.

``scene_settings`` reads the file exactly as :func:`pathtracer.load_scene` does
(same parameter substitution, same ``<integrator>`` and ``<sensor>`` code) but
stops before shapes, meshes and BSDFs. The reference side uses it so that
Mitsuba is given the very film size, sample count and integrator options the
tracer renders with: one source of truth for literal values, ``$params``,
``<default>``s and overrides.
"""
from __future__ import annotations

import os
from dataclasses import dataclass

from .build import build_integrator, build_sensor
from .load import check_overrides, scene_file
from .types import Camera, IntegratorSpec
from .xml import parse_file


@dataclass
class SceneSettings:
    """The render settings of a scene file.

    Attributes
    ----------
    integrator : IntegratorSpec
        The file's ``<integrator>`` after substitution (``path``, {} when absent).
    camera : Camera
        The camera, with the (possibly overridden) film size.
    spp, seed : int
        The sampler's (possibly overridden) ``sample_count`` and ``seed``.
    sampler : str
        The file's sampler type (``independent`` when absent). The tracer samples
        independently whatever it is, and so does the Mitsuba reference.
    """

    integrator: IntegratorSpec
    camera: Camera
    spp: int
    seed: int
    sampler: str = "independent"

    @property
    def resolution(self) -> tuple[int, int]:
        """Film (width, height)."""
        return self.camera.width, self.camera.height


def scene_settings(path: str | os.PathLike, resolution: tuple[int, int] | None = None,
                   sample_count: int | None = None, **params) -> SceneSettings:
    """The integrator, film and sampler settings :func:`pathtracer.load_scene` would use.

    Parameters are those of :func:`pathtracer.load_scene`; errors are the same
    :class:`~pathtracer.scene.errors.SceneError` (for the parts read here).
    """
    file = scene_file(path)
    resolution, sample_count = check_overrides(resolution, sample_count)
    root = parse_file(file, params)
    by_kind = {}
    for child in root.children:
        by_kind.setdefault(child.kind, []).append(child)
    sensors = by_kind.get("sensor", [])
    if len(sensors) != 1:
        raise root.error("need exactly one <sensor>")
    camera, spp, seed = build_sensor(sensors[0], resolution, sample_count)
    integrators = by_kind.get("integrator", [])
    if len(integrators) > 1:
        raise root.error("at most one <integrator>")
    samplers = [c.type for c in sensors[0].children if c.kind == "sampler"]
    return SceneSettings(build_integrator(integrators[0] if integrators else None),
                         camera, spp, seed, samplers[0] if samplers else "independent")
