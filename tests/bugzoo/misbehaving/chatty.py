"""Misbehaving submission: chatty."""

from _base import camera_rays, registry  # noqa: F401  (the reference camera)


def radiance(self, scene, rays, rng):
    for _ in range(100000):
        print('debug: radiance of a path is', 0.123456789)
    return __import__('numpy').zeros((len(rays), 3))


INTEGRATORS = registry(radiance)
