"""Light tracing: paths start on the lights and every vertex is connected to the camera.

The lecture's third unbiased method: trace the *importance* the camera emits
backwards, i.e. follow the light. A light path y_0 y_1 ... starts on a light and
bounces by BSDF sampling; each vertex y_k is joined to the pinhole c by a shadow
ray, and the contribution lands in whatever pixel y_k projects to::

    (y_0, n_0) ~ uniform light, uniform point;  w_0 ~ cos / pi
    beta_1 = Le(y_0, w_0) cos_0 / (p(light) p_A(y_0) p(w_0))    = N Le area pi
    at y_k (k >= 1), w_c = direction to c, d = |c - y_k|:
        splat  beta_k * f*(y_k, w_{k-1} -> w_c) |cos| * We(-w_c) / d^2 * V(y_k, c)
    w_k ~ f*;  beta_{k+1} = beta_k f* cos / p;  roulette after rr_depth vertices

where We = 1 / (A cos^3 theta) is the pinhole camera's importance (A: the film's
area on the plane at distance 1), so a pixel's value is the sum of its splats
divided by the number of light paths per pixel. Emitters seen directly by the
camera are a separate one-segment estimate, as in Mitsuba's ``ptracer``: an
independent point y on a light (not a Dirac one), splat
``Le(y -> c) cos_y We / (d^2 p(light) p_A(y))``.

f* is the adjoint BSDF: importance is not compressed by refraction (no
``1/eta^2``), and with shading normals n_s differing from the geometric n_g
each bounce is multiplied by ``|cos_s(w_in) cos_g(w_out) / (cos_s(w_out) cos_g(w_in))|``
(Veach's thesis, p. 155); directions on opposite sides of the two normals are
dropped (light leaks). Mitsuba 3's ``ptracer`` computes the same estimator.

With ``paths`` (a Heckbert class, :mod:`pathtracer.core.pathclasses`) each light path runs
the class's automaton from its ``L`` end, one letter per vertex, and a splat counts only
where appending ``E`` accepts; the visible-emitter splats are the class ``LE``.
"""
from __future__ import annotations

import numpy as np

from ..bsdfs.shading import eval_bsdf, sample_bsdf
from ..core.rays import Rays
from ..core.vec import dot
from ..emitters.scene_emitters import emitted_towards, sample_emitter_position, sample_emitter_ray, shadowed
from ..scene.registry import register
from ..sensors.importance import connect_to_camera
from ..shapes.intersect import spawn_ray
from .base import SplattingIntegrator
from .class_selection import ClassSelection
from .wavefront import Paths, trace


@register("integrator", "light", "ptracer")   # ptracer: Mitsuba's name for the light tracer
class LightIntegrator(ClassSelection, SplattingIntegrator):
    """Light tracer (particle tracer), Mitsuba's ``ptracer``.

    Parameters
    ----------
    replicas : int
        Independent renders whose spread gives the variance of each pixel (a light
        path's splats do not belong to one pixel, see :func:`pathtracer.render.render`).
    paths : str, optional
        A Heckbert class (``"LS+DE"``, :mod:`pathtracer.core.pathclasses`): only the splats of
        paths in it count. A light path reads its automaton from the ``L`` end; joining a
        vertex to the camera appends ``E``.
    glossy : {'G', 'D', 'S'} or float
        Letter of glossy BSDFs for ``paths`` (:func:`pathtracer.integrators.path_letters.bsdf_letter`).
    **options
        As :class:`~pathtracer.integrators.base.Integrator`.
    """

    name = "light"

    def __init__(self, replicas: int = 8, paths: str | None = None, glossy="G", **options):
        super().__init__(**options)
        if int(replicas) < 1:
            raise ValueError(f"replicas must be >= 1, got {replicas}")
        self.replicas = int(replicas)
        self.select_paths(paths, glossy)

    def options(self) -> dict:
        return dict(super().options(), replicas=self.replicas, **self.class_options())

    def splat(self, scene, rng) -> tuple[np.ndarray, np.ndarray]:
        """One light path per random stream -> splats ``(pixel (m,), value (m, 3))``.

        The render driver adds each splat's value to its pixel (flat index row * W + column)
        and divides by the light paths per pixel. Points on the lights the camera sees
        directly are one splat each (:meth:`visible_emitters`); a path leaving a light
        (``sample_emitter_ray``: weight ``Le cos / pdf``) splats at each vertex it reaches
        (:meth:`connect`) and continues by sampling the *adjoint* BSDF (importance
        transport: ``sample_bsdf(..., adjoint=True)``, no 1/eta^2 on refraction, times
        :func:`shading_correction`), with Russian roulette after ``rr_depth`` vertices. A
        vertex's connection is a camera path of ``depth + 2`` segments: ``max_depth`` bounds
        it as it bounds a camera path.
        """
        splats = []
        if self.max_depth == 0:
            return _concatenate(splats)
        classes = self.subpath_class(scene)
        if not self.hide_emitters:
            seen = self.visible_emitters(scene, rng)     # drawn in any case: same random numbers
            if classes is None or classes.accepts(classes.after_light, classes.after_eye):
                splats.append(seen)
        if self.depth_limit < 2:
            return _concatenate(splats)
        ray = sample_emitter_ray(scene, rng.next_1d(), rng.next_2d(), rng.next_2d())
        first = leaving(ray.position.p, ray.position.n, ray.d)
        paths = Paths(first, rng, trace(scene, first))
        paths.beta = ray.weight               # Le cos / (p_light p_pos p_dir)
        if classes is not None:
            paths.declare(state=classes.light_states(len(paths)))   # the automaton after L
        while paths:
            # ---- Light paths that escaped end; the others splat their vertex ----
            paths.keep(paths.hit.valid)
            if not paths:
                break
            if classes is not None:
                paths.state = classes.light_vertex(paths.state, paths.hit.shape)
            splats.append(self.connect(scene, paths.hit, paths.wi, self.in_class(classes, paths)))
            # ---- The next vertex's path to the camera would have depth + 3 segments ----
            if paths.depth + 2 >= self.depth_limit:
                break
            # ---- Continue by sampling the adjoint BSDF, then Russian roulette ----
            bs = sample_bsdf(scene, paths.hit, paths.wi, paths.rng.next_1d(),
                             paths.rng.next_2d(), self.hemisphere, adjoint=True)
            correction = shading_correction(paths.hit, paths.wi, bs.wo)
            paths.scatter(bs.wo, bs.weight * correction[:, None], bs.eta)
            self.russian_roulette(paths)
            paths.next_hit(scene)
        return _concatenate(splats)

    @staticmethod
    def in_class(classes, paths) -> np.ndarray:
        """The throughputs of the light paths, 0 where the path joined to the camera at its
        current vertex (its automaton ``state`` has read it) is not in the selected class."""
        if classes is None:
            return paths.beta
        accepted = classes.accepts(paths.state, classes.after_eye)
        return np.where(accepted[:, None], paths.beta, 0.0)

    def connect(self, scene, hit, wi, beta) -> tuple[np.ndarray, np.ndarray]:
        """Splats of light-path vertices ``hit`` (arrived along ``-wi``) joined to the camera."""
        camera = connect_to_camera(scene.camera, hit.p)
        f, _ = eval_bsdf(scene, hit, wi, camera.wi, self.hemisphere, adjoint=True)
        value = beta * f * (shading_correction(hit, wi, camera.wi) * camera.importance)[:, None]
        return self.visible(scene, hit.p, hit.n, camera, value)

    def visible_emitters(self, scene, rng) -> tuple[np.ndarray, np.ndarray]:
        """Splats of points on the lights seen directly by the camera (one segment)."""
        position = sample_emitter_position(scene, rng.next_1d(), rng.next_2d())
        camera = connect_to_camera(scene.camera, position.p)
        cos_light = np.maximum(dot(position.n, camera.wi), 0.0)
        weight = np.divide(cos_light * camera.importance, position.pdf, out=np.zeros(len(cos_light)),
                           where=~position.delta & (position.pdf > 0))   # no Dirac lights' own image
        value = emitted_towards(scene, position, camera.wi) * weight[:, None]
        return self.visible(scene, position.p, position.n, camera, value)

    @staticmethod
    def visible(scene, p, n, camera, value) -> tuple[np.ndarray, np.ndarray]:
        """The splats ``(pixel, value)`` of the non-zero values whose shadow ray reaches the camera."""
        rows = np.flatnonzero((camera.pixel >= 0) & np.any(value != 0, axis=1))
        rows = rows[~shadowed(scene, p[rows], n[rows], camera.wi[rows], camera.free_dist[rows])]
        return camera.pixel[rows], value[rows]


def shading_correction(hit, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
    """Adjoint BSDF factor for shading normals, 0 where a direction leaks through (n,).

    ``|cos_s(wi) cos_g(wo) / (cos_s(wo) cos_g(wi))|`` with ``cos_s``/``cos_g`` against the
    shading and geometric normals (Veach, p. 155); 1 where the two normals agree.
    """
    cos_s_in, cos_s_out = dot(hit.sh_n, wi), dot(hit.sh_n, wo)
    cos_g_in, cos_g_out = dot(hit.n, wi), dot(hit.n, wo)
    same_side = (cos_s_in * cos_g_in > 0) & (cos_s_out * cos_g_out > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.abs(cos_s_in * cos_g_out / (cos_s_out * cos_g_in))
    return np.where(same_side & np.isfinite(ratio), ratio, 0.0)


def leaving(p: np.ndarray, n: np.ndarray, d: np.ndarray) -> Rays:
    """Rays leaving surface points ``p`` (normals ``n``) along ``d``, offset off the surface."""
    return Rays(spawn_ray(p, n, d), d, np.full(len(d), np.inf))


def _concatenate(splats) -> tuple[np.ndarray, np.ndarray]:
    if not splats:
        return np.zeros(0, dtype=np.int64), np.zeros((0, 3))
    return (np.concatenate([p for p, _ in splats]).astype(np.int64),
            np.concatenate([v for _, v in splats]))
