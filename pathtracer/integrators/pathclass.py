"""The MIS path tracer, with every contribution routed to Heckbert path classes.

The same estimator as :mod:`pathtracer.integrators.path` (the same random
numbers in the same order: with the same seed, the class ``L.*E`` is the
``path`` image bit for bit), plus a DFA state per path and per class
(:mod:`pathtracer.pathclasses`)::

    state = delta[start, E]                         at the camera
    state = delta[state, letter(BSDF at x_k)]       when the path scatters at x_k
    emitter hit at x_k:   counts in class c  iff  accept_c[delta_c[state, L]]
    shadow ray from x_k:  counts in class c  iff  accept_c[delta_c[delta_c[state, letter(x_k)], L]]

A path's contribution at vertex k is ``beta * Le * w`` (emission found by
BSDF sampling) or ``beta * f * Le / p * w`` (the shadow ray), exactly as in
``path``; it is added to every class whose automaton accepts. Classes that
partition path space therefore sum to the ``path`` image up to float rounding.

``radiance`` (the integrator contract) returns the first class only, so
``render(scene, PathClassIntegrator("LS+DE"))`` renders the caustics alone;
:func:`pathtracer.render.render_classes` renders all classes of one integrator in one pass.
"""
from __future__ import annotations

import numpy as np

from ..emitters import pdf_emitter_direction, sample_emitter
from ..pathclasses import LETTER, _parse_glossy, bsdf_letters, compile_classes
from ..sampling import power_heuristic
from ..shading import eval_bsdf, has_smooth, sample_bsdf
from .base import Integrator, spawn, subset_hit, trace

_L, _E = LETTER["L"], LETTER["E"]


class PathClassIntegrator(Integrator):
    """MIS path tracer that keeps one image per path class.

    Parameters
    ----------
    classes : str or list of str
        Path expressions in Heckbert's notation, light first (``"LS+DE"``).
    glossy : {'G', 'D', 'S'} or float
        Letter of rough conductors, or an alpha threshold (<= t: S, else D);
        see :mod:`pathtracer.pathclasses`.
    **options
        As for every integrator (max_depth, rr_depth, roulette, ...).
    """

    name = "pathclass"

    def __init__(self, classes="L.*E", glossy="G", **options):
        super().__init__(**options)
        self.classes = compile_classes(classes)
        if not self.classes:
            raise ValueError("at least one path class is needed")
        self.glossy = _parse_glossy(glossy)

    @property
    def expressions(self) -> list[str]:
        return [c.expression for c in self.classes]

    def options(self):
        return dict(super().options(), classes=self.expressions, glossy=self.glossy)

    def radiance(self, scene, rays, rng):
        """The first class's radiance sample per ray -> (n, 3)."""
        return self.radiance_classes(scene, rays, rng)[:, 0, :]

    def radiance_classes(self, scene, rays, rng):
        """One radiance sample per ray and class -> (n, n_classes, 3)."""
        n = len(rays)
        K = len(self.classes)
        L = np.zeros((n, K, 3))
        if self.max_depth == 0:
            return L
        letters = bsdf_letters(scene, self.glossy)
        deltas = [c.delta for c in self.classes]
        accepts = [c.accept for c in self.classes]
        # state after the eye, one column per class
        state = np.tile(np.array([c.delta[c.start, _E] for c in self.classes], dtype=np.int32), (n, 1))

        def add(rows, states, value):
            """Add ``value`` (m, 3) to the classes accepting ``states`` + L."""
            for k in range(K):
                ok = accepts[k][deltas[k][states[:, k], _L]]
                if ok.any():
                    L[rows, k] += np.where(ok[:, None], value, 0.0)

        row = np.arange(n)
        beta, eta = np.ones((n, 3)), np.ones(n)
        prev_p = rays.o.copy()
        prev_pdf, prev_delta = np.ones(n), np.ones(n, dtype=bool)
        d = rays.d
        hit = self.trace_camera(scene, rays)
        depth = 0
        while len(row):
            wi = -d
            Le = self.emission(scene, hit, wi, depth)
            pdf_light = np.where(prev_delta, 0.0, pdf_emitter_direction(scene, prev_p, hit, d))
            add(row, state, beta * Le * power_heuristic(prev_pdf, pdf_light)[:, None])

            live = np.flatnonzero(hit.valid & (depth + 1 < self.depth_limit))
            row, beta, eta, wi, state = row[live], beta[live], eta[live], wi[live], state[live]
            hit, rng = subset_hit(hit, live), rng.subset(live)
            if not len(row):
                break

            # this vertex's letter, appended to every class's automaton
            letter = letters[scene.shape_bsdf[hit.shape]]
            state = np.stack([deltas[k][state[:, k], letter] for k in range(K)], axis=1)

            light = sample_emitter(scene, hit, rng.next_1d(), rng.next_2d())
            f_light, pdf_bsdf = eval_bsdf(scene, hit, wi, light.wo, self.hemisphere)
            w_light = np.where(light.delta, 1.0, power_heuristic(light.pdf, pdf_bsdf))
            use = has_smooth(scene, hit) & (light.pdf > 0)
            add(row, state, np.where(use[:, None], beta * f_light * light.weight * w_light[:, None], 0.0))

            bs = sample_bsdf(scene, hit, wi, rng.next_1d(), rng.next_2d(), self.hemisphere)
            beta, eta = beta * bs.weight, eta * bs.eta
            prev_p, prev_pdf, prev_delta = hit.p, bs.pdf, bs.delta
            depth += 1

            throughput_max = beta.max(axis=1)
            survive, beta = self.roulette_survivors(beta, eta, depth, rng.next_1d())
            keep = np.flatnonzero(survive & (throughput_max > 0))
            row, beta, eta, state = row[keep], beta[keep], eta[keep], state[keep]
            prev_p, prev_pdf, prev_delta = prev_p[keep], prev_pdf[keep], prev_delta[keep]
            rng = rng.subset(keep)
            next_rays = spawn(subset_hit(hit, keep), bs.wo[keep])
            d = next_rays.d
            hit = trace(scene, next_rays)
        return L
