r"""Volumetric path tracing with shadow rays through media and MIS (Mitsuba's ``volpath``).

``volpath_phase`` plus next-event estimation at every scattering event, in
the medium and on surfaces, combined with phase / BSDF sampling by the power
heuristic. A shadow ray's visibility becomes a transmittance: it is estimated
by the same free-flight sampling (0 if a collision falls before the light,
:math:`T / T_c` otherwise; in a heterogeneous medium ratio tracking, the
product of :math:`\sigma_n / \bar\sigma` over the tentative collisions),
passes through ``null`` (index-matched)
boundaries, updating the medium it is in, and is blocked by any other surface,
a dielectric with :math:`\eta = 1.00001` included: that is why a medium behind
such a boundary is lit only by the paths that find the light on their own.

At a scattering point x (in a medium: f = phase p, on a surface: f = BSDF f cos),
reached with throughput beta::

    (x_l, p_light) ~ uniform emitter, then a point on it
    L += beta * f(x -> x_l) * Le * Tr(x, x_l) / p_light * w_light
                         w_light = p_light^2 / (p_light^2 + p_f^2)   (1 for point lights)
    w ~ f;  beta *= f / p_f                                 (volpath_phase's step)

and when the path hits an emitter with the direction sampled at its last
scattering event x_j (null crossings in between do not count)::

    L += beta * Le * w_f,    w_f = p_f^2 / (p_f^2 + p_light(x_j -> x)^2)

with w_f = 1 on the camera segment and after a Dirac bounce (or a scatter in a
medium with ``sample_emitters`` false). Only BSDFs with a smooth lobe get a
shadow ray. The free-flight weights and roulette are those of
:mod:`pathtracer.integrators.volpath_phase`; per-pixel variance matches
Mitsuba's ``volpath`` as well as the mean (same estimator).
"""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from ..bsdfs.shading import eval_bsdf, has_smooth
from ..core.sampling import power_heuristic
from ..core.vec import any_row, put_rows
from ..emitters.scene_emitters import emitted_radiance, pdf_emitter_direction, sample_emitter
from ..media.homogeneous import (
    next_medium,
    phase_eval,
    phase_sample,
    samples_emitters,
    scattering_albedo,
    shadow_transmittance,
)
from ..scene.registry import register
from .base import subset_hit
from .volpath_phase import VolPathPhaseIntegrator
from .volume import SLOT_DIRECTION, SLOT_LIGHT, SLOT_SHADOW, move


@register("integrator", "volpath")
class VolPathIntegrator(VolPathPhaseIntegrator):
    """Volumetric path tracing with NEE through media and MIS, Mitsuba's ``volpath``.

    ``volpath_phase``'s segment loop (``radiance``) and surface step (``bounce``), with
    shadow rays added where a path scatters.
    """

    name = "volpath"

    def in_medium(self, scene, paths, rows, t, segment, add_radiance):
        """Scatter inside the medium: a shadow ray (phase MIS), then sample the phase function."""
        d, medium = np.take(paths.d, rows, axis=0), paths.medium[rows]
        x = np.take(paths.o, rows, axis=0) + t[:, None] * d
        wi = -d
        beta = np.take(paths.beta, rows, axis=0) * scattering_albedo(scene, medium, x)
        put_rows(paths.beta, rows, beta)
        paths.depth[rows] += 1
        alive = paths.depth[rows] < self.depth_limit
        emitters = samples_emitters(scene, medium)
        nee = np.flatnonzero(alive & emitters & any_row(beta > 0))
        x_nee, medium_nee = np.take(x, nee, axis=0), medium[nee]
        self.shadow_ray(scene, paths, rows[nee], x_nee, np.zeros_like(x_nee), lambda wo: medium_nee,
                        phase_f_pdf(scene, medium_nee, np.take(wi, nee, axis=0)), segment,
                        add_radiance)
        wo, pdf = phase_sample(scene, medium, wi, self.uniform(paths, segment, SLOT_DIRECTION, 2, rows))
        put_rows(paths.last_p, rows, x)
        paths.last_pdf[rows] = pdf
        paths.specular[rows] = ~emitters
        move(paths, rows, x, np.zeros_like(x), wo)
        return alive & (pdf > 0)

    def on_surface(self, scene, paths, rows, hit, segment, add_radiance):
        """Emission found (MIS against the light sample of the last scattering event), a
        shadow ray (BSDF MIS) on smooth BSDFs, then continue by BSDF sampling."""
        d, beta = np.take(paths.d, rows, axis=0), np.take(paths.beta, rows, axis=0)
        Le = self.visible_emission(paths.depth[rows], emitted_radiance(scene, hit, -d))
        lit = np.flatnonzero(any_row(Le > 0))
        if len(lit):
            r = rows[lit]
            pdf_light = pdf_emitter_direction(scene, np.take(paths.last_p, r, axis=0),
                                              subset_hit(hit, lit), np.take(d, lit, axis=0))
            full = (paths.depth[r] == 0) | paths.specular[r]
            w = np.where(full, 1.0, power_heuristic(paths.last_pdf[r], pdf_light))
            add_radiance(np.take(beta, lit, axis=0) * np.take(Le, lit, axis=0) * w[:, None], r)
        # Misses index the last shape's BSDF here; hit.valid drops them.
        smooth = np.flatnonzero(hit.valid & (paths.depth[rows] + 1 < self.depth_limit)
                                & any_row(beta > 0) & has_smooth(scene, hit))
        if len(smooth):
            h, r = subset_hit(hit, smooth), rows[smooth]
            wi = -np.take(d, smooth, axis=0)
            self.shadow_ray(scene, paths, r, h.p, h.n,
                            lambda wo: next_medium(scene, h, paths.medium[r], wo),
                            lambda wo: eval_bsdf(scene, h, wi, wo, self.hemisphere), segment,
                            add_radiance)
        return self.bounce(scene, paths, rows, hit, segment)

    def shadow_ray(self, scene, paths, rows, x, n, start_medium, f_pdf, segment, add_radiance):
        """Next-event estimation from points ``x`` (normals ``n``, zero inside a medium) of
        paths ``rows``, weighted against sampling ``f`` by the power heuristic.

        ``start_medium(wo)``: the medium a shadow ray along ``wo`` starts in (on a medium
        boundary it depends on the side); ``f_pdf(wo)``: ``(f, pdf)``, the BSDF's
        ``f cos`` or the phase function's value, and the density of sampling ``wo``;
        ``add_radiance(value, rows)`` adds the estimates to the paths' radiance.
        """
        if not len(rows):
            return
        u = self.uniform(paths, segment, SLOT_LIGHT, rows=rows)
        u2 = self.uniform(paths, segment, SLOT_LIGHT + 1, 2, rows)
        light = sample_emitter(scene, SimpleNamespace(p=x), u, u2, test_visibility=False)
        f, pdf_f = f_pdf(light.wo)
        contribution = np.take(paths.beta, rows, axis=0) * f * light.weight
        live = np.flatnonzero((light.pdf > 0) & any_row(contribution > 0))
        if not len(live):
            return
        start = start_medium(light.wo)
        if len(live) < len(rows):
            rows, x, n, contribution, pdf_f, start = (np.take(a, live, axis=0) for a in (
                rows, x, n, contribution, pdf_f, start))
            light = subset_hit(light, live)
        Tr = shadow_transmittance(scene, x, n, light.wo, light.dist, start, paths.channel[rows],
                                  paths.rng.subset(rows), self.counter(paths, segment, SLOT_SHADOW))
        w = np.where(light.delta, 1.0, power_heuristic(light.pdf, pdf_f))
        add_radiance(contribution * Tr * w[:, None], rows)


def phase_f_pdf(scene, medium, wi):
    """``(f, pdf)`` of the media's phase functions as a function of ``wo``: the phase
    function is its own sampling density, so ``f`` is ``pdf`` in every channel."""
    def f_pdf(wo):
        p = phase_eval(scene, medium, wi, wo)
        return p[:, None] * np.ones(3), p
    return f_pdf
