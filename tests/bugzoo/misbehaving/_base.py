"""Submissions that misbehave instead of computing a wrong image (isolation tests)."""
from pathtracer.camera import camera_rays  # noqa: F401  (re-exported)
from pathtracer.integrators import INTEGRATORS as REFERENCE
from pathtracer.integrators.path import PathIntegrator


def registry(radiance):
    """The reference INTEGRATORS with ``path``'s radiance replaced by ``radiance``."""
    cls = type("Misbehaving", (PathIntegrator,), {"radiance": radiance})
    return {**REFERENCE, "path": cls}
