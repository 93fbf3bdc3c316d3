"""What every integrator shares: the contract, options, tracing, roulette and shadow rays.

Three classes, one contract. :class:`Integrator` holds the options, the steps every
estimator of the lecture shares and the capabilities the renderer reads (class
attributes, each with its default here). The two kinds of integrator are its subclasses:

* :class:`CameraIntegrator`: one radiance sample per camera ray (``path``, ``direct``,
  ``volpath`` ...)::

      class MyIntegrator(CameraIntegrator):
          name = "my_integrator"
          def radiance(self, scene, rays, rng) -> np.ndarray:  # (n, 3)

* :class:`SplattingIntegrator`: light paths whose vertices land on any pixel (``light``,
  ``bdpt``)::

      class MyLightTracer(SplattingIntegrator):
          name = "my_light_tracer"
          def splat(self, scene, rng) -> tuple[np.ndarray, np.ndarray]:  # pixels, values

A student subclasses :class:`Integrator` itself (``pathtracer.Integrator``, the contract
of :mod:`autograder.contract`) and writes ``radiance``, or sets ``splats = True`` and
writes ``splat``: the renderer reads only ``splats`` to know which, so both kinds work on
the shared base as they do on the two subclasses.

``rays`` is a :class:`pathtracer.core.rays.Rays` batch of camera rays and ``rng``
a :class:`pathtracer.core.rng.RandomStream` with one independent stream per ray.
The result is one Monte Carlo sample of the radiance arriving along each ray;
the renderer averages the samples of a pixel and estimates their variance.
Geometry, BSDFs, emitters and sampling are shared modules: an integrator only
composes them. The batch of paths itself (which paths are alive, their
throughputs and random streams) is a :class:`~pathtracer.integrators.wavefront.Paths`,
started by :meth:`Integrator.camera_paths`; the steps every estimator of the
lecture shares are methods here: :meth:`~Integrator.emission`,
:meth:`~Integrator.sample_direct` (a shadow ray, pbrt-v4's ``SampleLd``) and
:meth:`~Integrator.russian_roulette`.

An integrator of the tracer registers itself under its name (and any Mitsuba name it
renders) with ``@register("integrator", name)`` of :mod:`pathtracer.scene.registry`;
``pathtracer.INTEGRATORS``, the loader, the command lines and the harness read that table.
"""
from __future__ import annotations

import numpy as np

from ..bsdfs.shading import eval_bsdf, has_smooth
from ..core.rays import Rays
from ..core.vec import any_row, max_component, scale, select, unscale
from ..emitters.scene_emitters import emitted_radiance, hit_emitter, sample_emitter, shadowed
from ..scene.types import Scene

# trace, spawn, subset_hit and replace_hits are names of this module too: submissions and the
# bug zoo import them from here.
from .wavefront import Paths, replace_hits, spawn, subset_hit, trace

#: Hard cap on the number of bounces when ``max_depth`` is infinite, so that a
#: path inside a closed, white furnace without roulette still ends. Its bias is
#: at most rho^1000 of the total.
MAX_BOUNCES = 1000

ROULETTE_RULES = ("mitsuba", "constant", "off")
HEMISPHERE_RULES = ("cosine", "uniform")


class Integrator:
    """Base class of every integrator: the options the lecture discusses, the shared steps
    and the capabilities the renderer reads.

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
    #: Writes ``splat(scene, rng)`` instead of ``radiance``: light paths splat into the film.
    splats = False
    #: ``splat`` also takes the pixel of each sample (its camera subpath starts there).
    camera_subpaths = False
    #: Renders participating media (the renderer refuses media scenes for the others).
    handles_media = False
    #: Renders ``null`` BSDFs in a scene without media (a Dirac pass-through event, as
    #: Mitsuba's ``path`` does); media scenes still need :attr:`handles_media`.
    handles_null = False
    #: ``radiance`` may run on a refilled pool of paths (:meth:`Paths.pool
    #: <.wavefront.Paths.pool>`): the renderer then hands it several units of camera rays at
    #: once. Safe when per-path arrays live in the :class:`Paths` (or are recomputed after
    #: ``next_hit``) and ``depth`` is used as an array (masks, not ``if depth > ...``). Set
    #: in the class that writes that ``radiance``; a subclass that writes its own does not
    #: inherit it (:meth:`__init_subclass__`).
    refills = False
    #: Live paths at once when ``radiance`` runs on more camera rays than that (a
    #: :meth:`Paths.pool`); None: all of them. The renderer sets it on its own copy of an
    #: integrator that :attr:`refills`.
    pool_size: int | None = None

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

    def __init_subclass__(cls, **kwargs):
        """A class that writes its own ``radiance`` refills only where it sets :attr:`refills`
        itself: an override of a pooled ``radiance`` (a student's subclass) runs batch by
        batch, since nothing says it is safe in a pool."""
        super().__init_subclass__(**kwargs)
        if "radiance" in vars(cls) and "refills" not in vars(cls):
            cls.refills = False

    # -- shared steps ---------------------------------------------------------

    def camera_paths(self, scene: Scene, rays: Rays, rng) -> Paths:
        """The paths of a batch of camera rays, at their first hits.

        With ``max_depth`` = 0 (no segment allowed) no ray is traced and no path is
        alive: the radiance is zero. With :attr:`pool_size` set (by the renderer, for an
        integrator that :attr:`refills`) and more rays than that, a
        :meth:`Paths.pool` that starts the rays ``pool_size`` at a time.
        """
        if self.max_depth == 0:
            return Paths(rays, rng)
        if self.pool_size is not None and len(rays) > self.pool_size:
            return Paths.pool(rays, rng, self.pool_size,
                              lambda camera: self.trace_camera(scene, camera))
        return Paths(rays, rng, self.trace_camera(scene, rays))

    def trace_camera(self, scene: Scene, rays: Rays):
        """First intersection of camera rays, skipping area emitters if hidden."""
        hit = trace(scene, rays)
        if not self.hide_emitters:
            return hit
        return skip_emitters(scene, rays, hit)

    def emission(self, scene: Scene, hit, wi: np.ndarray, depth) -> np.ndarray:
        """Radiance emitted towards ``wi`` at the hits of segment ``depth`` + 1
        (``depth``: an int, or one per hit).

        With ``hide_emitters``, camera rays (``depth`` 0) that escape see no
        environment, as in Mitsuba (area lights are skipped by :meth:`trace_camera`).
        """
        radiance = emitted_radiance(scene, hit, wi)
        if self.hide_emitters:
            radiance[(np.asarray(depth) == 0) & ~hit.valid] = 0.0
        return radiance

    def roulette_survivors(self, beta: np.ndarray, eta: np.ndarray, depth,
                           u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Russian roulette after ``depth`` segments (an int, or one per path).

        Returns the survival mask and the throughput divided by the survival
        probability (so that E[beta'] = beta: the estimator stays unbiased).
        """
        playing = np.asarray(depth) >= self.rr_depth
        if self.roulette == "off" or not playing.any():
            return np.ones(len(u), dtype=bool), beta
        if self.roulette == "constant":
            q_continue = np.full(len(u), 1.0 - self.rr_q)
        else:
            q_continue = np.minimum(max_component(beta) * eta ** 2, 0.95)
        survive = (u < q_continue) | ~playing
        # Paths not yet playing keep beta: divided by 1, which is exact.
        return survive, unscale(beta, np.where(playing & (q_continue > 0), q_continue, 1.0))

    def russian_roulette(self, paths: Paths) -> None:
        """End the paths that lose the roulette (see :meth:`roulette_survivors`), and
        those that carry no throughput; survivors divide by their survival probability."""
        carries_light = max_component(paths.beta) > 0
        survive, paths.beta = self.roulette_survivors(paths.beta, paths.eta, paths.depth,
                                                      paths.rng.next_1d())
        paths.keep(survive & carries_light)

    def sample_direct(self, scene: Scene, paths: Paths, beta=None, mis_weight=None,
                      emitter: int | None = None) -> np.ndarray:
        """A shadow ray from every path's hit: its contribution ``beta f Le / p_light * w``.

        Next-event estimation, pbrt-v4's ``SampleLd``: pick a light (uniformly, or
        ``emitter``) and a point on it, test visibility, evaluate the BSDF towards it.
        Paths at BSDFs without a smooth lobe (mirror, glass) get zero: a Dirac BSDF
        cannot scatter towards a sampled point.

        Parameters
        ----------
        beta : (m, 3) array, optional
            Throughput to multiply by (default ``paths.beta``).
        mis_weight : callable, optional
            ``mis_weight(pdf_light, pdf_bsdf)``, the light sample's MIS weight against
            BSDF sampling (e.g. :func:`pathtracer.core.sampling.power_heuristic`); a Dirac
            light always has weight 1. Without it the weight is 1 (no MIS).
        emitter : int, optional
            Sample this emitter instead of choosing one.

        Returns
        -------
        (m, 3) array of contributions, to add to the paths' radiance.
        """
        beta = paths.beta if beta is None else beta
        hit = paths.hit
        light = sample_emitter(scene, hit, paths.rng.next_1d(), paths.rng.next_2d(),
                               test_visibility=False, emitter=emitter)
        f, pdf_bsdf = eval_bsdf(scene, hit, paths.wi, light.wo, self.hemisphere)
        beta_f = beta * f
        contribution = beta_f * light.weight
        usable = has_smooth(scene, hit) & (light.pdf > 0)
        # ---- Visibility: a shadow ray only where the sample adds something (not where the
        # BSDF is zero towards it, nor at Dirac BSDFs); a blocked sample has weight 0 ----
        tested = np.flatnonzero(usable & (max_component(light.weight) > 0)
                                & any_row(contribution != 0))
        blocked = tested[shadowed(scene, *(np.take(a, tested, axis=0) for a in (
            hit.p, hit.n, light.wo, light.dist)))]
        contribution[blocked] = beta_f[blocked] * 0.0
        if mis_weight is not None:
            w_light = np.where(light.delta, 1.0, mis_weight(light.pdf, pdf_bsdf))
            contribution = scale(contribution, w_light)
        return select(usable, contribution)


class CameraIntegrator(Integrator):
    """An integrator that estimates the radiance along camera rays: it writes ``radiance``."""

    def radiance(self, scene: Scene, rays: Rays, rng) -> np.ndarray:
        """One radiance sample per ray -> (n, 3). Subclasses implement it."""
        raise NotImplementedError


class SplattingIntegrator(Integrator):
    """An integrator whose paths start at the lights and splat into any pixel: it writes
    ``splat``, and the renderer adds the splats to the film (:func:`pathtracer.render.render`)."""

    splats = True

    def splat(self, scene: Scene, rng) -> tuple[np.ndarray, np.ndarray]:
        """One light path per random stream -> splats ``(pixel (m,), value (m, 3))``.
        Subclasses implement it; one that sets ``camera_subpaths`` takes a third argument,
        the pixel of each sample (``bdpt``)."""
        raise NotImplementedError


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
