"""The MIS path tracer, with every contribution routed to Heckbert path classes.

The same estimator as :mod:`pathtracer.integrators.path` (the same random
numbers in the same order: with the same seed, the class ``L.*E`` is the
``path`` image bit for bit), plus a DFA state per path and per class
(:mod:`pathtracer.core.pathclasses`)::

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
:func:`pathtracer.render.classes.render_classes` renders all classes of one integrator in one pass.
"""
from __future__ import annotations

import numpy as np

from ..bsdfs.shading import sample_bsdf
from ..core.pathclasses import LETTER, compile_classes
from ..core.sampling import power_heuristic
from ..emitters.scene_emitters import pdf_emitter_direction
from .base import CameraIntegrator
from .path_letters import bsdf_letters, parse_glossy

_L, _E = LETTER["L"], LETTER["E"]


class PathClassIntegrator(CameraIntegrator):
    """MIS path tracer that keeps one image per path class.

    Parameters
    ----------
    classes : str or list of str
        Path expressions in Heckbert's notation, light first (``"LS+DE"``).
    glossy : {'G', 'D', 'S'} or float
        Letter of rough conductors, or an alpha threshold (<= t: S, else D);
        see :mod:`pathtracer.core.pathclasses`.
    **options
        As for every integrator (max_depth, rr_depth, roulette, ...).
    """

    name = "pathclass"

    def __init__(self, classes="L.*E", glossy="G", **options):
        super().__init__(**options)
        self.classes = compile_classes(classes)
        if not self.classes:
            raise ValueError("at least one path class is needed")
        self.glossy = parse_glossy(glossy)

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
        K = len(self.classes)
        L = np.zeros((len(rays), K, 3))
        letters = bsdf_letters(scene, self.glossy)
        deltas = [c.delta for c in self.classes]
        accepts = [c.accept for c in self.classes]

        def add_radiance(paths, value):
            """Add ``value`` (m, 3) to the classes that accept the paths' states + L."""
            for k in range(K):
                ok = accepts[k][deltas[k][paths.state[:, k], _L]]
                if ok.any():
                    L[paths.row, k] += np.where(ok[:, None], value, 0.0)

        paths = self.camera_paths(scene, rays, rng)
        eye = np.array([c.delta[c.start, _E] for c in self.classes], dtype=np.int32)
        paths.declare(state=np.tile(eye, (len(rays), 1)),   # each class's DFA state after E
                      prev_p=rays.o,       # the previous vertex (for the light pdf of a hit)
                      prev_pdf=1.0,        # pdf of the BSDF sample that left it
                      prev_delta=True)     # was that sample Dirac? (the camera counts as one)
        while paths:
            # ---- Emission found by BSDF sampling, weighted against light sampling ----
            Le = self.emission(scene, paths.hit, paths.wi, paths.depth)
            pdf_light = np.where(paths.prev_delta, 0.0, pdf_emitter_direction(
                scene, paths.prev_p, paths.hit, -paths.wi))
            add_radiance(paths, paths.beta * Le * power_heuristic(paths.prev_pdf, pdf_light)[:, None])

            # ---- Paths that escaped, or whose next segment max_depth forbids, end ----
            paths.keep(paths.hit.valid & (paths.depth + 1 < self.depth_limit))
            if not paths:
                break

            # ---- This vertex's letter, appended to every class's automaton ----
            letter = letters[scene.shape_bsdf[paths.hit.shape]]
            paths.state = np.stack([deltas[k][paths.state[:, k], letter] for k in range(K)], axis=1)

            # ---- Direct light: a shadow ray, weighted against BSDF sampling ----
            add_radiance(paths, self.sample_direct(scene, paths, mis_weight=power_heuristic))

            # ---- BSDF sample: the next direction ----
            bs = sample_bsdf(scene, paths.hit, paths.wi, paths.rng.next_1d(), paths.rng.next_2d(),
                             self.hemisphere)
            paths.scatter(bs.wo, bs.weight, bs.eta)
            paths.prev_p, paths.prev_pdf, paths.prev_delta = paths.hit.p, bs.pdf, bs.delta

            # ---- Russian roulette, then the next hit ----
            self.russian_roulette(paths)
            paths.next_hit(scene)
        return L
