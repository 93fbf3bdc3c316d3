"""Rendering an image from a scene and an integrator; ``render`` and ``RenderResult`` are the
public API.

driver (options, ``render``), result (``RenderResult``), scheduling (units of samples over
worker processes: workers, allocator, resources), jobs (a unit's camera samples), moments
(the one home of per-pixel means and variances), splats (splatting integrators as
replicas), classes (one image per path class), strategies (one image per bdpt strategy)."""
from .driver import RenderResult, render

__all__ = ["RenderResult", "render"]
