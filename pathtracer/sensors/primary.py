"""Primary rays of whichever sensor the scene has.

The perspective camera's rays come from ``camera_rays(camera, pixel, u_film)`` (Mitsuba's
pinhole, or the function a caller passes instead, e.g. a student's); the other sensors
(:mod:`.orthographic`, :mod:`.thinlens`) give their own through ``sample_rays``, which may
take more random numbers of the samples' streams (the thin lens takes two for its lens
point). A perspective camera draws nothing more, so its images do not change.
"""
from __future__ import annotations

import numpy as np

from ..core.rays import Rays
from .perspective import camera_rays


def sample_camera_rays(camera, pixel: np.ndarray, u_film: np.ndarray, rng,
                       pinhole_rays=camera_rays) -> Rays:
    """The rays of the camera samples (flat pixel indices ``pixel``, positions ``u_film``
    in their pixels, the samples' random streams ``rng``)."""
    if camera.pinhole:
        return pinhole_rays(camera, pixel, u_film)
    return camera.sample_rays(pixel, u_film, rng)


def require_pinhole(camera, integrator: str) -> None:
    """Raise ``ValueError`` (one line naming the sensor) unless light paths can connect to
    ``camera``: the splatting integrators join vertices to a pinhole (its importance,
    :mod:`.importance`), which an orthographic or thin-lens sensor is not."""
    if not camera.pinhole:
        raise ValueError(f"the {integrator} integrator does not support the {camera.kind} sensor "
                         f"(light paths connect to a perspective pinhole camera only)")
