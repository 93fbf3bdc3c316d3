r"""Volumetric path tracing with spectral MIS over the channels' free flights (Mitsuba's
``volpathmis``).

``volpath`` draws every free flight of a path with the extinction of one RGB channel and
divides the throughput by that channel's density. Where the extinction differs by channel,
the weight of a channel of smaller extinction grows with the distance flown: with
:math:`\sigma_t = (10, 2, 10)` a flight drawn with red carries a green factor
:math:`0.1\,e^{8t}`, whose square the exponential density does not tame, so renders miss the
rare long flights and come out dark in green. Here each flight draws its channel afresh and
divides by the mixture's density (the balance heuristic over the channels; a path of channel
:data:`~pathtracer.media.homogeneous.MIXTURE`, :mod:`pathtracer.media.homogeneous`,
"Spectral MIS")::

    c ~ uniform {R, G, B};  t ~ sigma_t,c exp(-sigma_t,c t)
    t < s:  scatter at x:  beta *= T(t) sigma_s / mean_k(T_k(t) sigma_t,k)
    else:   surface at s:  beta *= T(s) / mean_k T_k(s)

every factor at most 3 in every channel; shadow rays estimate the transmittance the same way
(``T / mean_k T_k`` past the segment, 0 on a collision). The rest is ``volpath``'s:
next-event estimation at every scattering event, the power heuristic against phase and BSDF
sampling, roulette. For a grey medium the mixture is the one exponential and the estimate is
``volpath``'s. Heterogeneous media are tracked against their grey majorant, which no channel
enters (:mod:`pathtracer.media.heterogeneous`).

Mitsuba's ``volpathmis`` averages the densities of the whole path over one channel per path;
the expectation is the same and both weights are bounded, but the noise differs, so a
comparison with it is of the mean only.
"""
from __future__ import annotations

import numpy as np

from ..media.homogeneous import MIXTURE
from ..scene.registry import register
from .volpath import VolPathIntegrator


@register("integrator", "volpathmis")
class VolPathMISIntegrator(VolPathIntegrator):
    """``volpath`` whose paths draw each free flight from, and weight it by, the channels'
    mixture."""

    name = "volpathmis"

    def flight_channel(self, u):
        """:data:`~pathtracer.media.homogeneous.MIXTURE` for every path (``u``, drawn all the
        same, keeps the random streams in line with ``volpath``'s)."""
        return np.full(len(u), MIXTURE)
