"""The lecture's algorithms, one module each, and a registry by name."""
from __future__ import annotations

from .base import Integrator
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

INTEGRATORS = {cls.name: cls for cls in (
    PathIntegrator, PathBSDFIntegrator, PathNEEIntegrator, RecursiveIntegrator,
    SmallptIntegrator, DirectIntegrator, LightIntegrator, VolPathIntegrator,
    VolPathPhaseIntegrator, BDPTIntegrator)}


def make_integrator(name: str, **options) -> Integrator:
    """An integrator by name with its options (see :class:`Integrator`).

    Raises
    ------
    ValueError
        For an unknown name or option, naming the valid ones.
    """
    if name not in INTEGRATORS:
        raise ValueError(f"unknown integrator {name!r} (available: {', '.join(INTEGRATORS)})")
    try:
        return INTEGRATORS[name](**options)
    except TypeError as error:
        raise ValueError(f"integrator {name!r}: {error}") from None


__all__ = ["Integrator", "INTEGRATORS", "make_integrator"] + [c.__name__ for c in INTEGRATORS.values()]
