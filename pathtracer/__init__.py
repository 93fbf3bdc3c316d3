"""A pure Python + NumPy path tracer for the path-tracing lecture.

It renders Mitsuba 3 XML scene files with the lecture's algorithms (recursive
ray tracing, path tracing with BSDF sampling, with shadow rays, with MIS,
smallpt, direct lighting), so that each can be checked against Mitsuba 3.

>>> from pathtracer import load_scene, render
>>> scene = load_scene("cornell-box", width=64, height=64)
>>> result = render(scene, integrator="path", spp=16, seed=1)
>>> result.mean.shape, result.variance.shape
((64, 64, 3), (64, 64, 3))
"""
from . import (
    _console,  # noqa: F401  (first: a Ctrl-C while the commands start)
    legacy_names,  # noqa: F401  (the student contract's old module names)
)
from .integrators import INTEGRATORS, Integrator, make_integrator
from .render.driver import RenderResult, render
from .scene.errors import SceneError
from .scene.load import load_scene

__all__ = ["load_scene", "render", "RenderResult", "SceneError", "make_integrator",
           "Integrator", "INTEGRATORS"]
__version__ = "0.1.0"
