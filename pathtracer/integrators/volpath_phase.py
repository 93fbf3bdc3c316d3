r"""Volumetric path tracing by phase-function and BSDF sampling only (no shadow rays).

The lecture's path tracer with participating media: along a ray, the next
event is a scattering point in the medium or the next surface, whichever
comes first. A free-flight distance :math:`t` is drawn with the pdf
:math:`\sigma_{t,c}\,e^{-\sigma_{t,c} t}` of one RGB channel :math:`c` chosen per
path (Mitsuba's rule, see :mod:`pathtracer.media`); at a surface :math:`s`
away, :math:`P(t > s) = e^{-\sigma_{t,c} s}`. Per segment::

    t ~ free flight in the current medium (vacuum: t = infinity)
    t < s:  scatter at x = o + t d:  beta *= T(t) sigma_s / (T_c(t) sigma_t,c)
            w ~ phase p(w_i, w);     beta *= p / p_phase = 1   (the pdf cancels)
    else:   surface at s:            beta *= T(s) / T_c(s)
            L += beta * Le(x_s, -d)                 (emission picked up when hit)
            w ~ BSDF;  beta *= f cos / p;  eta *= eta_crossed
            null BSDF: the ray goes on straight, not a scattering event
            interior / exterior: the medium on the side w leaves to
    roulette after rr_depth scattering events: q = min(max(beta) eta^2, 0.95)

For a grey medium the two throughput factors are the albedo and 1. Light
reaches the camera only through paths that happen to hit an emitter, so a
light a medium hides is found rarely; ``volpath`` adds shadow rays.
"""
from __future__ import annotations

import numpy as np

from ..emitters import emitted_radiance
from ..media import phase_sample
from .volume import SLOT_DIRECTION, VolumeIntegrator, move


class VolPathPhaseIntegrator(VolumeIntegrator):
    """Volumetric path tracing with phase and BSDF sampling only."""

    name = "volpath_phase"

    def in_medium(self, scene, paths, rows, t, segment, L):
        """Scatter inside the medium: sample the phase function (weight 1)."""
        x = paths.o[rows] + t[:, None] * paths.d[rows]
        paths.depth[rows] += 1
        wo, pdf = phase_sample(scene, paths.medium[rows], -paths.d[rows],
                               self.uniform(paths, segment, SLOT_DIRECTION, 2)[rows])
        move(paths, rows, x, np.zeros_like(x), wo)
        return (paths.depth[rows] < self.depth_limit) & (pdf > 0)

    def on_surface(self, scene, paths, rows, hit, segment, L):
        """Add the emission found, then continue by BSDF sampling."""
        Le = emitted_radiance(scene, hit, -paths.d[rows])
        L[paths.row[rows]] += paths.beta[rows] * self.visible_emission(paths.depth[rows], Le)
        return self.bounce(scene, paths, rows, hit, segment)
