"""Mitsuba-side integrators for the lecture's estimators Mitsuba lacks.

``register()`` makes them loadable as ``lecture_path_bsdf`` and
``lecture_path_nee`` in the active Mitsuba variant (call it again after
switching variants; it is cheap and idempotent per variant).
"""

import mitsuba as mi

from ._common import make_class
from .direct import mitsuba_direct_dict
from .path_bsdf import PathBSDFIntegrator
from .path_nee import PathNEEIntegrator

_registered = set()


def register():
    """Register the lecture integrators with the active variant."""
    variant = mi.variant()
    if variant in _registered:
        return
    for mixin in (PathBSDFIntegrator, PathNEEIntegrator):
        cls = make_class(mixin)
        mi.register_integrator(mixin.NAME, lambda props, cls=cls: cls(props))
    _registered.add(variant)


__all__ = ["PathBSDFIntegrator", "PathNEEIntegrator", "mitsuba_direct_dict",
           "register"]
