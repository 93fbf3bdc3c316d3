"""Mitsuba's ``null`` BSDF: an invisible, index-matched boundary.

A ray crossing it continues in the same direction with unchanged throughput,
``wo = -wi``: the surface only marks where a participating medium begins or
ends. It has no smooth lobe (no next-event estimation on it) and a shadow ray
passes through it with transmission 1 (``eval_null_transmission``), which is what
lets shadow rays leave a medium enclosed by a null boundary. Volumetric
integrators also do not count the crossing as a scattering event (the path's
depth, its last scattering vertex and its MIS pdf stay those of the previous
real event).
"""
from __future__ import annotations

import numpy as np

from ..scene.properties import Props
from ..scene.registry import register
from .base import DeltaBSDF, make_sample
from .parameters import textures_only


class NullBSDF(DeltaBSDF):
    """Pass-through boundary (Mitsuba's ``null``)."""

    is_null = True
    #: Its one lobe is a null event (see :attr:`ThinDielectric.null_lobe`).
    null_lobe = True

    def eval_null_transmission(self, cos_theta_i: np.ndarray) -> np.ndarray:
        """A shadow ray crossing it keeps everything -> (n, 3) ones."""
        return np.ones((len(cos_theta_i), 3))

    def sample(self, wi: np.ndarray, u1: np.ndarray, u2: np.ndarray):
        """``wo = -wi`` with weight 1 and probability 1 (a Dirac event)."""
        n = wi.shape[0]
        return make_sample(-wi, np.ones((n, 3)), np.ones(n), True, 1.0, np.ones(n, dtype=bool))


@register("bsdf", "null")
def create(props: Props) -> NullBSDF:
    """No parameters."""
    textures_only(props)
    return NullBSDF()
