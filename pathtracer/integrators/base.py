"""What every integrator shares: the contract, options, tracing and roulette.

The contract (also what a student implements)::

    class MyIntegrator(Integrator):
        name = "my_integrator"
        def radiance(self, scene, rays, rng) -> np.ndarray:  # (n, 3)

``rays`` is a :class:`pathtracer.camera.Rays` batch of camera rays and ``rng``
a :class:`pathtracer.rng.RandomStream` with one independent stream per ray.
The result is one Monte Carlo sample of the radiance arriving along each ray;
the renderer averages the samples of a pixel and estimates their variance.
Geometry, BSDFs, emitters and sampling are shared modules: an integrator only
composes them.
"""
from __future__ import annotations

import numpy as np

from .. import geometry
from ..emitters import emitted_radiance, hit_emitter
from ..camera import Rays
from ..scene.types import Scene

#: Hard cap on the number of bounces when ``max_depth`` is infinite, so that a
#: path inside a closed, white furnace without roulette still ends. Its bias is
#: at most rho^1000 of the total.
MAX_BOUNCES = 1000

ROULETTE_RULES = ("mitsuba", "constant", "off")
HEMISPHERE_RULES = ("cosine", "uniform")


class Integrator:
    """Base class holding the options the lecture discusses.

    Parameters
    ----------
    max_depth : int
        Mitsuba's meaning: the longest path has ``max_depth`` segments;
        1 = directly visible emitters only, 2 = direct lighting, 3 = one
        indirect bounce; -1 = unlimited.
    rr_depth : int
        Russian roulette starts once a path has this many segments.
    roulette : {'mitsuba', 'constant', 'off'}
        'mitsuba': continue with q = min(max(beta) * eta^2, 0.95), divide by q
        (Mitsuba's rule). 'constant': the lecture's slide, terminate with
        probability ``rr_q`` and divide survivors by 1 - rr_q. 'off': never.
    rr_q : float
        Termination probability of the 'constant' rule.
    hemisphere : {'cosine', 'uniform'}
        Sampling of the diffuse lobe: same mean, different variance.
    hide_emitters : bool
        Camera rays pass through directly visible area emitters and see
        no environment where they escape (Mitsuba's meaning).
    """

    name = "base"

    def __init__(self, max_depth: int = -1, rr_depth: int = 5, roulette: str = "mitsuba",
                 rr_q: float = 0.5, hemisphere: str = "cosine", hide_emitters: bool = False):
        if roulette not in ROULETTE_RULES:
            raise ValueError(f"roulette must be one of {ROULETTE_RULES}, got {roulette!r}")
        if hemisphere not in HEMISPHERE_RULES:
            raise ValueError(f"hemisphere must be one of {HEMISPHERE_RULES}, got {hemisphere!r}")
        if not 0.0 <= rr_q < 1.0:
            raise ValueError(f"rr_q must lie in [0, 1), got {rr_q}")
        if int(max_depth) < -1:
            raise ValueError(f"max_depth must be -1 (unlimited) or >= 0, got {max_depth}")
        self.max_depth = int(max_depth)
        self.rr_depth = int(rr_depth)
        self.roulette = roulette
        self.rr_q = float(rr_q)
        self.hemisphere = hemisphere
        self.hide_emitters = bool(hide_emitters)

    @property
    def depth_limit(self) -> int:
        """``max_depth`` with -1 replaced by :data:`MAX_BOUNCES`."""
        return MAX_BOUNCES if self.max_depth < 0 else self.max_depth

    def options(self) -> dict:
        """The options as a dict (written into EXR headers and reports)."""
        return dict(max_depth=self.max_depth, rr_depth=self.rr_depth, roulette=self.roulette,
                    rr_q=self.rr_q, hemisphere=self.hemisphere, hide_emitters=self.hide_emitters)

    def radiance(self, scene: Scene, rays: Rays, rng) -> np.ndarray:
        """One radiance sample per ray -> (n, 3). Subclasses implement it."""
        raise NotImplementedError

    # -- shared steps ---------------------------------------------------------

    def trace_camera(self, scene: Scene, rays: Rays):
        """First intersection of camera rays, skipping area emitters if hidden."""
        hit = trace(scene, rays)
        if not self.hide_emitters:
            return hit
        return skip_emitters(scene, rays, hit)

    def emission(self, scene: Scene, hit, wi: np.ndarray, depth: int) -> np.ndarray:
        """Radiance emitted towards ``wi`` at the hits of segment ``depth`` + 1.

        With ``hide_emitters``, camera rays (``depth`` 0) that escape see no
        environment, as in Mitsuba (area lights are skipped by :meth:`trace_camera`).
        """
        radiance = emitted_radiance(scene, hit, wi)
        if depth == 0 and self.hide_emitters:
            radiance[~hit.valid] = 0.0
        return radiance

    def roulette_survivors(self, beta: np.ndarray, eta: np.ndarray, depth: int,
                           u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Russian roulette after ``depth`` segments.

        Returns the survival mask and the throughput divided by the survival
        probability (so that E[beta'] = beta: the estimator stays unbiased).
        """
        if self.roulette == "off" or depth < self.rr_depth:
            return np.ones(len(u), dtype=bool), beta
        if self.roulette == "constant":
            q_continue = np.full(len(u), 1.0 - self.rr_q)
        else:
            q_continue = np.minimum(beta.max(axis=1) * eta ** 2, 0.95)
        survive = u < q_continue
        return survive, beta / np.where(q_continue > 0, q_continue, 1.0)[:, None]


def trace(scene: Scene, rays: Rays):
    """Closest hit of every ray."""
    return geometry.intersect(scene, rays.o, rays.d, rays.tmax)


def spawn(hit, wo: np.ndarray) -> Rays:
    """Rays leaving the hits along ``wo``, offset against self-intersection."""
    o = geometry.spawn_ray(hit.p, hit.n, wo)
    return Rays(o, wo, np.full(len(wo), np.inf))


def skip_emitters(scene: Scene, rays: Rays, hit):
    """Continue rays through area emitters until they hit something else (hide_emitters)."""
    for _ in range(64):
        on_light = hit_emitter(scene, hit) >= 0
        if not on_light.any():
            break
        rows = np.flatnonzero(on_light)
        again = spawn(subset_hit(hit, rows), rays.d[rows])
        hit = replace_hits(hit, rows, trace(scene, again))
    return hit


def subset_hit(hit, rows):
    """The hits ``rows`` of a batch (works on any dataclass of arrays).

    ``rows`` are integer indices (``np.take`` along axis 0 is several times
    faster than fancy indexing of (n, 3) arrays) or a boolean mask.
    """
    rows = np.asarray(rows)
    if rows.dtype == bool:
        rows = np.flatnonzero(rows)
    return type(hit)(**{k: np.take(v, rows, axis=0) for k, v in vars(hit).items()})


def replace_hits(hit, rows, new):
    """A copy of ``hit`` with rows ``rows`` overwritten by ``new``."""
    out = {}
    for k, v in vars(hit).items():
        v = v.copy()
        v[rows] = getattr(new, k)
        out[k] = v
    return type(hit)(**out)
