"""The lecture's algorithms, one module each, and the table of them by name.

Each module registers its integrator (``@register("integrator", name)``,
:mod:`pathtracer.scene.registry`); importing the modules here fills the registry, and
:data:`INTEGRATORS` (like the loader's supported names, the command line's choices and the
harness's splatting integrators) is read from it: an integrator is added by its module, its
test and its line in the imports below.
"""
from __future__ import annotations

from ..core.names import suggestion
from ..scene.registry import factory, names
from .base import CameraIntegrator, Integrator, SplattingIntegrator

# Importing a module registers its integrator (a new integrator: its module, and its line
# here; explicit, so that the import graph shows it). The classes stay importable from here.
from .bdpt import BDPTIntegrator
from .direct import DirectIntegrator
from .light import LightIntegrator
from .path import PathIntegrator
from .path_bsdf import PathBSDFIntegrator
from .path_nee import PathNEEIntegrator
from .recursive import RecursiveIntegrator
from .smallpt import SmallptIntegrator
from .volpath import VolPathIntegrator
from .volpath_phase import VolPathPhaseIntegrator
from .volpathmis import VolPathMISIntegrator


def registered_integrators() -> dict:
    """name -> class of every registered integrator, under its own ``name``, in registration
    order: the tracer's, and any a user's module has registered since (the Mitsuba names a
    class also renders, such as ``ptracer`` for ``light``, are the loader's business)."""
    table = {}
    for registered in names("integrator"):
        cls = factory("integrator", registered)
        if cls.name == registered:
            table[registered] = cls
    unnamed = {factory("integrator", n).__name__ for n in names("integrator")} - {
        cls.__name__ for cls in table.values()}
    if unnamed:
        raise RuntimeError(f"integrators registered without their own name: {sorted(unnamed)}")
    return table


#: name -> class of every integrator of the tracer.
INTEGRATORS = registered_integrators()


def make_integrator(name: str, **options) -> Integrator:
    """An integrator by name with its options (see :class:`Integrator`): any registered one,
    the tracer's or a user's.

    Raises
    ------
    ValueError
        For an unknown name or option, naming the valid ones.
    """
    available = registered_integrators()
    if name not in available:
        raise ValueError(f"unknown integrator {name!r} ({suggestion(name, available)}"
                         f"available: {', '.join(available)})")
    try:
        return available[name](**options)
    except TypeError as error:
        raise ValueError(f"integrator {name!r}: {error}") from None


__all__ = ["Integrator", "CameraIntegrator", "SplattingIntegrator", "INTEGRATORS", "make_integrator",
           "registered_integrators",
           "BDPTIntegrator", "DirectIntegrator", "LightIntegrator", "PathIntegrator", "PathBSDFIntegrator",
           "PathNEEIntegrator", "RecursiveIntegrator", "SmallptIntegrator", "VolPathIntegrator",
           "VolPathPhaseIntegrator", "VolPathMISIntegrator"]
