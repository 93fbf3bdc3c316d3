"""Which Mitsuba estimator a comparison is judged against, and what follows from it.

Our integrators whose reference runs the same estimator get the variance verdict; mean-only
ones are compared with the closest; splatting ones lose the mean test's whole-image components.
:func:`resolved` turns a :class:`~mitsuba_refs.settings.Settings` whose estimator fields are
left to the integrator into one where they are set.
"""
from __future__ import annotations

import dataclasses

from pathtracer.integrators import INTEGRATORS

from ..settings import Settings

__all__ = ["SAME_ESTIMATOR", "SPLATTING", "CLOSEST_ESTIMATOR", "BOUNCE_REFERENCE",
           "reference_integrator", "resolved"]

#: Our integrators whose Mitsuba reference runs the same estimator (variance comparable).
SAME_ESTIMATOR = ("path", "path_bsdf", "path_nee", "direct", "light", "volpath")
#: Integrators whose paths splat into many pixels: pixels are correlated across the image,
#: so the mean test leaves out its whole-image components (docs/statistics.md, section 8).
SPLATTING = tuple(name for name, cls in INTEGRATORS.items() if cls.splats)
#: Mean-only integrators are compared with the Mitsuba estimator closest to theirs.
#: The tile test pools both sides' variances; against a much smoother estimator, a
#: tile where rare light hits happened not to occur (estimated variance 0) would look
#: significant. smallpt samples BSDFs only, recursive uses shadow rays without MIS.
#: ``volpathmis`` has Mitsuba's estimator of that name, weighted per path, not per flight.
CLOSEST_ESTIMATOR = {"smallpt": "path_bsdf", "recursive": "path_nee", "volpath_phase": "volpath",
                     "volpathmis": "volpathmis"}
#: Mitsuba estimator of the per-bounce references: ``path``, but ``volpath`` for the
#: volumetric integrators (``path`` ignores media).
BOUNCE_REFERENCE = {"volpath": "volpath", "volpath_phase": "volpath", "volpathmis": "volpath"}


def reference_integrator(name: str) -> str:
    """The Mitsuba estimator a comparison uses: the same one, or the closest (mean only)."""
    return name if name in SAME_ESTIMATOR else CLOSEST_ESTIMATOR.get(name, "path")


def resolved(settings: Settings, name: str) -> Settings:
    """``settings`` with ``reference``, ``same_estimator``, ``splatting`` and
    ``heavy_tail_guard`` set: those left None (or an empty reference) follow from our
    integrator ``name``; the guard follows the estimator."""
    same = name in SAME_ESTIMATOR if settings.same_estimator is None else bool(settings.same_estimator)
    return dataclasses.replace(
        settings, reference=settings.reference or reference_integrator(name), same_estimator=same,
        splatting=name in SPLATTING if settings.splatting is None else bool(settings.splatting),
        heavy_tail_guard=same if settings.heavy_tail_guard is None else bool(settings.heavy_tail_guard))
