"""Misbehaving submission: raises."""

from _base import camera_rays, registry  # noqa: F401  (the reference camera)


def radiance(self, scene, rays, rng):
    raise ValueError('student bug: index out of range')


INTEGRATORS = registry(radiance)
