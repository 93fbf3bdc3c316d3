"""Inverted eta: the glass BSDF uses ext_ior / int_ior instead of int_ior / ext_ior, so
light entering the glass bends away from the normal and total internal reflection happens
on the way *in*.

Only scenes with glass are wrong.
Expected hint: the dielectric code (eta inverted).
"""
from _glass import with_dielectric
from _mutate import (
    camera_rays,  # noqa: F401  (the reference camera)
    registry,
)

from pathtracer.bsdfs.dielectric import Dielectric
from pathtracer.integrators import path

BUG = "relative index of refraction inverted"
CHECK = "path-glass"
EXPECTED = ("eta",)


def _inverted(original):
    glass = Dielectric.__new__(Dielectric)
    glass.__dict__.update(original.__dict__)
    glass.eta = 1.0 / original.eta
    return glass


INTEGRATORS = registry(with_dielectric(path.PathIntegrator, _inverted))
