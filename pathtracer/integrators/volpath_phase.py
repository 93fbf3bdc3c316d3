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

In a heterogeneous medium (:mod:`pathtracer.media.heterogeneous`) the free
flight is a tentative collision against the grey majorant; a null collision
(probability P_n, beta *= sigma_n / (majorant P_n)) starts a new segment at
the collision, straight on, without a bounce; a real one scatters
(beta *= sigma_s / mean(sigma_t)) as above.
"""
from __future__ import annotations

import numpy as np

from ..bsdfs.shading import sample_bsdf
from ..core.vec import multiply_rows, put_rows
from ..emitters.scene_emitters import emitted_radiance
from ..media.heterogeneous import has_heterogeneous, track_heterogeneous
from ..media.homogeneous import (
    next_medium,
    null_event,
    phase_sample,
    sample_free_flight,
    scattering_albedo,
)
from ..scene.registry import register
from .base import subset_hit
from .volume import (
    MAX_SEGMENTS,
    SLOT_DIRECTION,
    SLOT_FLIGHT,
    SLOT_LOBE,
    SLOT_NULL,
    VolumeIntegrator,
    move,
)
from .wavefront import Paths


@register("integrator", "volpath_phase")
class VolPathPhaseIntegrator(VolumeIntegrator):
    """Volumetric path tracing with phase and BSDF sampling only."""

    name = "volpath_phase"

    def radiance(self, scene, rays, rng):
        """The segment loop (``volpath`` shares it) -> radiance (n, 3).

        Each segment: roulette, trace to the next surface, sample a free flight in the
        current medium; paths that scatter in the medium go to :meth:`in_medium`, the
        others to :meth:`on_surface`. Both add their estimates with ``add_radiance(value,
        rows)`` (the paths' :meth:`Paths.add_radiance`) and return which of their paths
        continue.
        """
        if self.max_depth == 0:
            return np.zeros((len(rays), 3))
        paths = self.start(scene, rays, rng)
        add_radiance = paths.add_radiance
        tracking = has_heterogeneous(scene)
        goes_on = np.ones(len(paths), dtype=bool)
        for segment in range(MAX_SEGMENTS):
            # The paths that went on from the last segment and survive roulette: one compaction
            paths.keep(goes_on & self.survivors(paths, segment))
            if not paths:
                break
            hit = self.trace_segment(scene, paths)
            # ---- Free flight: scatter in the medium before the surface, or reach it ----
            u_flight = self.uniform(paths, segment, SLOT_FLIGHT)
            flight = sample_free_flight(scene, paths.medium, paths.channel, hit.t, u_flight)
            if tracking:     # heterogeneous media: a tentative collision, null or real
                track_heterogeneous(scene, flight, paths.medium, paths.o, paths.d, hit.t,
                                    u_flight, self.uniform(paths, segment, SLOT_NULL))
            paths.beta = paths.beta * flight.weight       # T / pdf (x sigma_s where it scatters)
            goes_on = np.zeros(len(paths), dtype=bool)
            null_rows = np.flatnonzero(flight.null) if flight.null is not None else ()
            if len(null_rows):
                goes_on[null_rows] = self.null_collision(paths, null_rows, flight.t[null_rows])
            medium_rows = np.flatnonzero(flight.scattered)
            if len(medium_rows):
                goes_on[medium_rows] = self.in_medium(scene, paths, medium_rows,
                                                      flight.t[medium_rows], segment, add_radiance)
            surface_rows = np.flatnonzero(~flight.scattered if flight.null is None
                                          else ~flight.scattered & ~flight.null)
            if len(surface_rows):
                surface_hit = hit if len(surface_rows) == len(paths) else subset_hit(hit, surface_rows)
                goes_on[surface_rows] = self.on_surface(scene, paths, surface_rows, surface_hit,
                                                        segment, add_radiance)
        return paths.L

    @staticmethod
    def null_collision(paths, rows, t):
        """A null collision ``t`` along the ray of paths ``rows`` (a heterogeneous medium):
        the next segment starts there in the same direction, not a scattering event (depth,
        last vertex and roulette's count unchanged) -> all go on."""
        o, d = np.take(paths.o, rows, axis=0), np.take(paths.d, rows, axis=0)
        put_rows(paths.o, rows, o + t[:, None] * d)
        paths.tmax[rows] = paths.tmax[rows] - t
        return np.ones(len(rows), dtype=bool)

    def in_medium(self, scene, paths, rows, t, segment, add_radiance):
        """Scatter inside the medium: sample the phase function (weight 1)."""
        d, medium = np.take(paths.d, rows, axis=0), paths.medium[rows]
        x = np.take(paths.o, rows, axis=0) + t[:, None] * d
        multiply_rows(paths.beta, rows, scattering_albedo(scene, medium, x))
        paths.depth[rows] += 1
        wo, pdf = phase_sample(scene, medium, -d,
                               self.uniform(paths, segment, SLOT_DIRECTION, 2, rows))
        move(paths, rows, x, np.zeros_like(x), wo)
        return (paths.depth[rows] < self.depth_limit) & (pdf > 0)

    def on_surface(self, scene, paths, rows, hit, segment, add_radiance):
        """Add the emission found, then continue by BSDF sampling."""
        d, beta = np.take(paths.d, rows, axis=0), np.take(paths.beta, rows, axis=0)
        Le = emitted_radiance(scene, hit, -d)
        add_radiance(beta * self.visible_emission(paths.depth[rows], Le), rows)
        return self.bounce(scene, paths, rows, hit, segment)

    def bounce(self, scene, paths: Paths, rows: np.ndarray, hit, segment: int) -> np.ndarray:
        """Continue paths ``rows`` at their surface hits by sampling the BSDF -> which go on.

        Updates throughput and eta, and the medium on the other side (medium tracking). A
        null crossing (a ``null`` BSDF, a ``thindielectric``'s straight transmission) keeps
        the depth, the last scattering vertex, its pdf and the specular flag (it is not a
        scattering event, as in Mitsuba); any other sampled lobe updates them.
        """
        valid = hit.valid.copy()
        on = np.flatnonzero(valid)
        if len(on) < len(rows):
            rows, hit = rows[on], subset_hit(hit, on)
        wi = -np.take(paths.d, rows, axis=0)
        bs = sample_bsdf(scene, hit, wi, self.uniform(paths, segment, SLOT_LOBE, rows=rows),
                         self.uniform(paths, segment, SLOT_DIRECTION, 2, rows), self.hemisphere)
        real = ~null_event(scene, hit, wi, bs.wo)
        multiply_rows(paths.beta, rows, bs.weight)
        paths.eta[rows] *= bs.eta
        paths.depth[rows] += real
        scattering = np.flatnonzero(real)
        put_rows(paths.last_p, rows[scattering], np.take(hit.p, scattering, axis=0))
        paths.last_pdf[rows[scattering]] = bs.pdf[scattering]
        paths.specular[rows[scattering]] = bs.delta[scattering]
        # ---- Medium tracking: the medium on the side wo leaves to, null boundaries too ----
        paths.medium[rows] = next_medium(scene, hit, paths.medium[rows], bs.wo)
        move(paths, rows, hit.p, hit.n, bs.wo)
        return valid
