"""Bidirectional path tracing: a camera subpath, a light subpath, every way of joining them, MIS.

Veach's thesis (ch. 10) in the path-space form. A path of length k (k segments) is
x_0 ... x_k, x_0 on a light, x_k the pinhole; its contribution to pixel j is the
integral over the path space with the *area-product measure*
``d mu(x) = dA(x_0) ... dA(x_k)`` (the pinhole is a Dirac point)::

    I_j = int Le(x_0 -> x_1) G(x_0, x_1) prod_{i=1}^{k-1} f(x_i) G(x_i, x_{i+1}) We_j(x_{k-1} -> x_k) d mu
    G(x, y) = V(x, y) |cos_x| |cos_y| / |x - y|^2      (no cosine at a point light or at the pinhole)

Each sample traces a light subpath y_0 y_1 ... (y_0 ~ uniform light, uniform point,
directions by the emitter, then the adjoint BSDF) and a camera subpath z_0 z_1 ...
(z_0 the pinhole, z_1 along the pixel's camera ray, then the BSDF), with Russian
roulette on both. Strategy (s, t) joins the first s light vertices to the first t
camera vertices (path length k = s + t - 1):

    s = 0:        the camera subpath hits a light:   C = beta_z(t-1) Le(z_{t-1} -> z_{t-2})
    t = 1:        y_{s-1} joined to the pinhole, splatted to the pixel it projects to
                  (the light tracer):                C = beta_y(s-1) f*(y_{s-1}) We / d^2 V
    s = 1:        next-event estimation from z_{t-1} to the light vertex y_0:
                  C = beta_z f(z_{t-1}) Le(y_0 -> z_{t-1}) |cos_y0| / (p_A(y_0) d^2) V
    s, t >= 2:    C = beta_y f*(y_{s-1}) f(z_{t-1}) beta_z / d^2 V

where beta are the subpath throughputs (products of f cos / p and 1/q of roulette), f
and f* carry the cosine at their own vertex (f* with the shading-normal correction of
:func:`pathtracer.integrators.light.shading_correction`, which turns it into the
geometric cosine), and d the connecting segment's length.

Vertex densities are kept in *area measure*: a direction sampled at x_{i} with
solid-angle density p_w becomes the density of the next vertex

    p_A(x_{i+1}) = p_w |cos_{i+1}| / |x_i - x_{i+1}|^2

Every vertex stores ``pdf_fwd``, the area density with which its own subpath generated
it, and ``pdf_rev``, the area density with which the *other* direction would have
generated it (the BSDF density of the reversed direction at the next vertex; at the
light, the emitter's position density; at the first camera vertex, the camera's). A
connection overwrites ``pdf_rev`` at its two end vertices and their predecessors.

The strategy (s, t) samples the path with density p_s = prod of the densities of its
s light and t camera vertices; with the power heuristic its weight is
``w_s = p_s^2 / sum_i p_i^2`` (balance: exponent 1). Veach (eq. 10.9) computes the
ratios r_i = p_i / p_s by walking out from the connection:

    towards the light:  r_{s-1} = pdf_rev(y_{s-1}) / pdf_fwd(y_{s-1})
                        r_{i-1} = r_i pdf_rev(y_{i-1}) / pdf_fwd(y_{i-1})   (strategy s' = i - 1)
    towards the camera: likewise with the camera vertices z_{t-1} ... z_1    (t' = i - 1)
    w_s = 1 / (1 + sum_i r_i^2)

A density that is zero because a vertex is a Dirac one (mirror, glass, a point light's
position) is replaced by 1 in the ratios, and every strategy that would have to
connect *at* a Dirac vertex (r_i with a Dirac y_i, y_{i-1}, z_i or z_{i-1}; s = 0 with a
point light) is left out of the sum: it cannot sample the path (its contribution is
zero, which the BSDF and emitter evaluation give). The camera subpath can never hit the
pinhole, so no strategy has t = 0. Strategies of paths longer than ``max_depth``
segments are not evaluated; the subpaths are long enough (t <= max_depth + 1,
s <= max_depth) that every other strategy of an allowed length is.

Unlike pbrt, s = 1 joins z_{t-1} to the light subpath's own first vertex y_0 (one
uniform point on the lights per sample, the same for every t): its density is then
exactly the light subpath's ``pdf_fwd(y_0)``.

A point or spot light is not imaged by the pinhole (s = t = 1 is zero for it), as in
Mitsuba, whose ``path`` and ``ptracer`` cannot see a Dirac light either.

With ``paths`` (a Heckbert class, :mod:`pathtracer.core.pathclasses`) the light subpath reads
the class's automaton from its ``L`` end and the camera subpath the reversed one from the
``E`` end; a strategy counts iff the two states at its connection accept together
(:class:`pathtracer.core.pathclasses.JoinedClass`), so each class image holds exactly the
MIS-weighted contributions of the class's paths.

The light subpaths' splats (t = 1) reach any pixel, so the integrator renders like the
light tracer (:func:`pathtracer.render.splats.render_splats`): sample i of a replica runs its
camera subpath through pixel ``i mod (W H)``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..bsdfs.shading import eval_bsdf, has_smooth, sample_bsdf
from ..core.vec import dot
from ..emitters.scene_emitters import (
    EmitterPosition,
    emitted_radiance,
    emitted_towards,
    emitter_position_at,
    pdf_emitter_ray,
    sample_emitter_ray,
    shadowed,
)
from ..scene.registry import register
from ..sensors.importance import connect_to_camera
from ..sensors.perspective import camera_rays
from .base import SplattingIntegrator
from .class_selection import ClassSelection
from .light import leaving, shading_correction
from .wavefront import Paths, concatenate_hits, subset_hit, trace

#: MIS heuristics and the exponent of their density ratios.
MIS_EXPONENT = {"power": 2.0, "balance": 1.0}


@dataclass
class Vertices:
    """Vertex i of the subpaths of a batch that have one (compact: one row per such subpath).

    Attributes
    ----------
    rows : (m,) the samples (rows of the batch) these vertices belong to.
    p, n : (m, 3) position and geometric normal (n = 0 at the pinhole and at point lights).
    on_surface : (m,) bool, area densities carry the cosine at this vertex.
    wi : (m, 3) unit direction towards the previous vertex of the subpath.
    beta : (m, 3) throughput of the subpath up to this vertex.
    pdf_fwd, pdf_rev : (m,) area densities (see the module docstring).
    delta : (m,) bool, the subpath scattered here by a Dirac lobe.
    hit : the hits (surface vertices), None at the pinhole and on the lights' first vertex.
    """

    rows: np.ndarray
    p: np.ndarray
    n: np.ndarray
    on_surface: np.ndarray
    wi: np.ndarray
    beta: np.ndarray
    pdf_fwd: np.ndarray
    pdf_rev: np.ndarray
    delta: np.ndarray
    hit: object = None

    @classmethod
    def endpoint(cls, count: int, p, n, on_surface, beta, pdf_fwd) -> "Vertices":
        """The first vertex of ``count`` subpaths (pinhole or light), broadcast to rows."""
        return cls(np.arange(count), np.broadcast_to(p, (count, 3)).copy(),
                   np.broadcast_to(n, (count, 3)).copy(), np.broadcast_to(on_surface, count).copy(),
                   np.zeros((count, 3)), np.broadcast_to(beta, (count, 3)).copy(),
                   np.broadcast_to(pdf_fwd, count).copy(), np.zeros(count), np.zeros(count, bool))


#: The per-vertex arrays of :class:`Vertices` that :class:`Subpaths` concatenates.
VERTEX_FIELDS = ("p", "n", "on_surface", "wi", "beta", "pdf_fwd", "pdf_rev", "delta")


class Subpaths:
    """The vertices of a batch of subpaths, every depth concatenated.

    ``slot[i, row]`` is where vertex i of sample ``row`` lies in the concatenated arrays
    (the :data:`VERTEX_FIELDS` of :class:`Vertices`), -1 where the subpath is shorter.
    """

    def __init__(self, vertices: list[Vertices], count: int):
        self.length = len(vertices)
        self.slot = np.full((self.length, count), -1)
        offset = 0
        for depth, vertex in enumerate(vertices):
            self.slot[depth, vertex.rows] = offset + np.arange(len(vertex.rows))
            offset += len(vertex.rows)
        for name in VERTEX_FIELDS:
            setattr(self, name, np.concatenate([getattr(v, name) for v in vertices]))
        self.first_hit = len(vertices[0].rows)           # vertex 0 has no hit
        surfaces = [v.hit for v in vertices[1:]]
        self.hit = concatenate_hits(surfaces) if surfaces else None

    def vertices_per_sample(self) -> np.ndarray:
        """(count,) number of vertices of each sample's subpath."""
        return np.sum(self.slot >= 0, axis=0)

    def hits(self, index: np.ndarray):
        """The hits of vertices ``index`` (slots of surface vertices)."""
        return subset_hit(self.hit, index - self.first_hit)


def to_area(pdf_dir: np.ndarray, dist2: np.ndarray, n: np.ndarray, w: np.ndarray,
            on_surface: np.ndarray) -> np.ndarray:
    """Solid-angle density -> area density at a vertex of normal ``n`` reached along ``w``."""
    cos = np.where(on_surface, np.abs(dot(n, w)), 1.0)
    return pdf_dir * cos / np.maximum(dist2, 1e-300)


def _distance2(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.sum((a - b) ** 2, axis=1)


def _remap0(pdf: np.ndarray) -> np.ndarray:
    """Dirac vertices have density 0 in the ratios' bookkeeping: count them as 1."""
    return np.where(pdf > 0, pdf, 1.0)


@register("integrator", "bdpt")
class BDPTIntegrator(ClassSelection, SplattingIntegrator):
    """Bidirectional path tracer with multiple importance sampling (Veach's BDPT).

    Parameters
    ----------
    mis : {'power', 'balance'}
        The heuristic combining the strategies.
    replicas : int
        Independent renders whose spread gives each pixel's variance (splats, as ``light``).
    paths : str, optional
        A Heckbert class (``"LS+DE"``, :mod:`pathtracer.core.pathclasses`): only the strategies'
        contributions of paths in it count (see :meth:`class_mask`).
    glossy : {'G', 'D', 'S'} or float
        Letter of glossy BSDFs for ``paths``.
    **options
        As :class:`~pathtracer.integrators.base.Integrator` (``hide_emitters`` is refused:
        light subpaths would still reach the camera through the hidden lights).
    """

    name = "bdpt"
    #: render_splats passes each sample's pixel (its camera subpath starts there).
    camera_subpaths = True

    def __init__(self, mis: str = "power", replicas: int = 8, paths: str | None = None,
                 glossy="G", **options):
        super().__init__(**options)
        if int(replicas) < 1:
            raise ValueError(f"replicas must be >= 1, got {replicas}")
        self.mis = mis
        self.replicas = int(replicas)
        self.select_paths(paths, glossy)
        self.check_options()

    def options(self) -> dict:
        return dict(super().options(), mis=self.mis, replicas=self.replicas, **self.class_options())

    def check_options(self) -> None:
        """Refuse what the options say but bdpt cannot do (render() may set options on a copy)."""
        if self.mis not in MIS_EXPONENT:
            raise ValueError(f"mis must be one of {tuple(MIS_EXPONENT)}, got {self.mis!r}")
        if self.hide_emitters:
            raise ValueError("bdpt does not support hide_emitters: light subpaths would still "
                             "reach the camera through the hidden lights")

    # -- the estimator ---------------------------------------------------------

    def splat(self, scene, rng, pixels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """One camera subpath through each of ``pixels`` and one light subpath per random
        stream, joined by every strategy -> splats ``(pixel (m,), value (m, 3))``."""
        _, _, pixel, value = self.contributions(scene, rng, pixels)
        return pixel, value

    def contributions(self, scene, rng, pixels: np.ndarray, weighted: bool = True):
        """Every strategy's non-zero contributions -> ``(s, t, pixel, value)``, arrays of m.

        ``weighted=False`` gives each strategy's own (unweighted) estimate of the paths of
        length s + t - 1: what it alone would compute.
        """
        self.check_options()
        count = len(pixels)
        parts = []
        if self.max_depth != 0 and count:
            streams = rng.branch(2)
            camera = self.camera_subpath(scene, streams.subset(2 * np.arange(count)), pixels)
            light, position = self.light_subpath(scene, streams.subset(2 * np.arange(count) + 1))
            s, t, row = self.strategy_rows(camera, light)
            classes = self.subpath_class(scene)
            states = None if classes is None else (subpath_states(camera, classes.camera_states(count),
                                                                  classes.camera_vertex),
                                                   subpath_states(light, classes.light_states(count),
                                                                  classes.light_vertex))
            for case, connect in ((s == 0, self.hit_light), (t == 1, self.to_camera),
                                  ((s > 0) & (t > 1), self.join)):
                ends = Ends(s[case], t[case], row[case], pixels)
                if not len(ends.row):
                    continue
                value, pixel, rev = connect(scene, camera, light, position, ends)
                if weighted:
                    value = value * self.mis_weight(camera, light, position, ends, rev)[:, None]
                if classes is not None:
                    value = value * self.class_mask(classes, states, ends)[:, None]
                keep = (pixel >= 0) & np.any(value != 0, axis=1)
                parts.append((ends.s[keep], ends.t[keep], pixel[keep], value[keep]))
        if not parts:
            return (np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0, np.int64),
                    np.zeros((0, 3)))
        return tuple(np.concatenate([part[k] for part in parts]) for k in range(4))

    @staticmethod
    def class_mask(classes, states, ends) -> np.ndarray:
        """Whether the path of each strategy in ``ends`` lies in the selected class.

        ``states`` are the camera and the light subpaths' automaton states per vertex
        (:func:`subpath_states`). Strategy (s, t) joins the light prefix y_0 ... y_{s-1}
        to the camera prefix z_0 ... z_{t-1}; for s = 0 the camera's z_{t-1} is the light
        vertex, so its prefix ends at z_{t-2} and the light side is ``L`` alone. Every
        strategy that samples a path reads the same letters, so the MIS weights of a path in
        the class still sum to one.
        """
        camera_states, light_states = states
        hits_light = ends.s == 0
        camera_vertex = np.where(hits_light, ends.t - 2, ends.t - 1)
        light_state = np.where(hits_light, classes.after_light,
                               light_states[np.maximum(ends.s - 1, 0), ends.row])
        return classes.accepts(light_state, camera_states[camera_vertex, ends.row])

    def strategy_rows(self, camera: Subpaths, light: Subpaths):
        """Every (s, t, row) that both subpaths of sample ``row`` allow, s + t - 1 <= max_depth."""
        light_count = light.vertices_per_sample()
        s_all, t_all, row_all = [], [], []
        for t in range(1, camera.length + 1):
            rows = np.flatnonzero(camera.slot[t - 1] >= 0)
            s_min = 1 if t == 1 else 0
            s_max = np.minimum(light_count[rows], self.depth_limit + 1 - t)
            counts = np.maximum(s_max - s_min + 1, 0)
            starts = np.repeat(np.cumsum(counts) - counts, counts)
            s_all.append(np.arange(counts.sum()) - starts + s_min)
            t_all.append(np.full(counts.sum(), t))
            row_all.append(np.repeat(rows, counts))
        return np.concatenate(s_all), np.concatenate(t_all), np.concatenate(row_all)

    # -- subpaths --------------------------------------------------------------

    def camera_subpath(self, scene, rng, pixels: np.ndarray) -> Subpaths:
        """z_0 (the pinhole) ... z_{t-1}, at most ``max_depth`` + 1 vertices."""
        camera = scene.camera
        rays = camera_rays(camera, pixels, rng.next_2d())
        pinhole = Vertices.endpoint(len(pixels), camera.to_world[:3, 3], 0.0, False, 1.0, 1.0)
        paths = Paths(rays, rng, trace(scene, rays))
        seen = connect_to_camera(camera, np.where(paths.hit.valid[:, None], paths.hit.p, rays.o))
        paths.declare(pdf_dir=seen.importance * seen.dist ** 2)       # We: the rays' density
        vertices = self.walk(scene, paths, [pinhole], self.depth_limit + 1, adjoint=False)
        return Subpaths(vertices, len(pixels))

    def light_subpath(self, scene, rng) -> tuple[Subpaths, EmitterPosition]:
        """y_0 (on a light) ... y_{s-1}, at most ``max_depth`` vertices; and y_0 as emitter data."""
        count = len(rng)
        ray = sample_emitter_ray(scene, rng.next_1d(), rng.next_2d(), rng.next_2d())
        position = ray.position
        # Le (or I) comes with each connection to y_0: its throughput is 1 / p_A(y_0).
        origin = Vertices.endpoint(count, position.p, position.n, ~position.delta,
                                   position.inverse_pdf()[:, None], position.pdf)
        first = leaving(position.p, position.n, ray.d)
        paths = Paths(first, rng, trace(scene, first))
        paths.beta = ray.weight                               # Le cos / (p_A(y_0) p_dir)
        paths.declare(pdf_dir=ray.pdf_dir)
        vertices = self.walk(scene, paths, [origin], self.depth_limit, adjoint=True)
        return Subpaths(vertices, count), position

    def walk(self, scene, paths: Paths, vertices: list[Vertices], limit: int,
             adjoint: bool) -> list[Vertices]:
        """Extend subpaths from their first hits to at most ``limit`` vertices.

        ``paths`` carries ``pdf_dir``, the solid-angle density of the segment just traced.
        Each new vertex gets its ``pdf_fwd``; the BSDF sample leaving it sets the previous
        vertex's ``pdf_rev`` (Dirac samples: both 0).
        """
        slot = np.full(len(vertices[0].rows), -1)
        slot[vertices[0].rows] = np.arange(len(vertices[0].rows))
        while paths and len(vertices) < limit:
            paths.keep(paths.hit.valid)
            if not paths:
                break
            hit, prev, at = paths.hit, vertices[-1], slot[paths.row]
            dist2 = _distance2(hit.p, prev.p[at])
            vertex = Vertices(paths.row.copy(), hit.p, hit.n, np.ones(len(paths), bool), paths.wi,
                              paths.beta, to_area(paths.pdf_dir, dist2, hit.n, paths.wi, True),
                              np.zeros(len(paths)), np.zeros(len(paths), bool), hit)
            vertices.append(vertex)
            slot[paths.row] = np.arange(len(paths))
            if len(vertices) >= limit:
                break
            bs = sample_bsdf(scene, hit, paths.wi, paths.rng.next_1d(), paths.rng.next_2d(),
                             self.hemisphere, adjoint=adjoint)
            weight = bs.weight
            if adjoint:
                weight = weight * shading_correction(hit, paths.wi, bs.wo)[:, None]
            _, pdf_back = eval_bsdf(scene, hit, bs.wo, paths.wi, self.hemisphere)
            vertex.delta[:] = bs.delta
            prev.pdf_rev[at] = to_area(np.where(bs.delta, 0.0, pdf_back), dist2, prev.n[at],
                                       paths.wi, prev.on_surface[at])
            paths.scatter(bs.wo, weight, bs.eta)
            paths.pdf_dir = np.where(bs.delta, 0.0, bs.pdf)
            self.russian_roulette(paths)
            paths.next_hit(scene)
        return vertices

    # -- connections -----------------------------------------------------------

    def hit_light(self, scene, camera, light, position, ends):
        """s = 0: the camera subpath's vertex z_{t-1} lies on a light."""
        z, before = ends.camera(camera, 1), ends.camera(camera, 2)
        hit = camera.hits(z)
        value = camera.beta[z] * emitted_radiance(scene, hit, camera.wi[z])
        emitter = emitter_position_at(scene, hit)
        on_light = emitter.pdf > 0
        pdf_dir = np.zeros(len(z))
        if on_light.any():
            pdf_dir[on_light] = pdf_emitter_ray(scene, emitter.take(on_light), camera.wi[z][on_light])
        rev = {"camera_end": emitter.pdf,
               "camera_before": to_area(pdf_dir, _distance2(camera.p[z], camera.p[before]),
                                        camera.n[before], camera.wi[z], camera.on_surface[before])}
        return value, ends.pixels(), rev

    def to_camera(self, scene, camera, light, position, ends):
        """t = 1: the light subpath's vertex y_{s-1} joined to the pinhole (splatted)."""
        y = ends.light(light, 1)
        seen = connect_to_camera(scene.camera, light.p[y])
        value, _, pdf_back = self.light_end(scene, light, position, ends, seen.wi)
        # A point light's own image (s = 1) is left out, as by Mitsuba's path and ptracer.
        seen_light = (ends.s == 1) & position.delta[ends.row]
        value = value * np.where(seen_light, 0.0, seen.importance)[:, None]
        visible = self.unblocked(scene, light.p[y], light.n[y], seen.wi, seen.free_dist, value)
        value[~visible] = 0.0
        cos = np.where(light.on_surface[y], np.abs(dot(light.n[y], seen.wi)), 1.0)
        rev = {"light_end": seen.importance * cos,
               "light_before": self.back_pdf(light, ends.light(light, 1), ends.light(light, 2),
                                             pdf_back)}
        return value, seen.pixel, rev

    def join(self, scene, camera, light, position, ends):
        """s >= 1, t >= 2: a shadow ray between z_{t-1} and y_{s-1}."""
        y, z = ends.light(light, 1), ends.camera(camera, 1)
        to_light = light.p[y] - camera.p[z]
        dist2 = np.sum(to_light ** 2, axis=1)
        dist = np.sqrt(dist2)
        w = to_light / np.maximum(dist, 1e-300)[:, None]
        light_value, pdf_light, pdf_light_back = self.light_end(scene, light, position, ends, -w)
        camera_value, pdf_camera, pdf_camera_back = self.camera_end(scene, camera, z, w)
        value = light_value * camera_value / np.maximum(dist2, 1e-300)[:, None]
        visible = self.unblocked(scene, camera.p[z], camera.n[z], w, dist, value)
        value[~visible] = 0.0
        rev = {"light_end": to_area(pdf_camera, dist2, light.n[y], w, light.on_surface[y]),
               "camera_end": to_area(pdf_light, dist2, camera.n[z], w, True),
               "camera_before": self.back_pdf(camera, z, ends.camera(camera, 2), pdf_camera_back),
               "light_before": self.back_pdf(light, y, ends.light(light, 2), pdf_light_back)}
        return value, ends.pixels(), rev

    def light_end(self, scene, light, position, ends, w_out):
        """At y_{s-1}, towards unit ``w_out``: (beta f* cos, or beta Le cos at y_0; solid-angle
        density of ``w_out``; density of going on to y_{s-2} when reached along ``w_out``)."""
        y = ends.light(light, 1)
        value, pdf, pdf_back = np.zeros((len(y), 3)), np.zeros(len(y)), np.zeros(len(y))
        first = ends.s == 1
        if first.any():
            origin = position.take(ends.row[first])
            cos = np.where(origin.delta, 1.0, np.maximum(dot(origin.n, w_out[first]), 0.0))
            value[first] = light.beta[y[first]] * emitted_towards(scene, origin, w_out[first]) \
                * cos[:, None]
            pdf[first] = pdf_emitter_ray(scene, origin, w_out[first])
        rest = np.flatnonzero(~first)
        if len(rest):
            at = y[rest]
            hit = light.hits(at)
            f, pdf[rest] = eval_bsdf(scene, hit, light.wi[at], w_out[rest], self.hemisphere,
                                     adjoint=True)
            _, pdf_back[rest] = eval_bsdf(scene, hit, w_out[rest], light.wi[at], self.hemisphere)
            f = f * shading_correction(hit, light.wi[at], w_out[rest])[:, None]
            value[rest] = np.where(has_smooth(scene, hit)[:, None], light.beta[at] * f, 0.0)
        return value, pdf, pdf_back

    def camera_end(self, scene, camera, z, w_out):
        """At z_{t-1}, towards unit ``w_out``: (beta f cos; density of ``w_out``; density of
        going on to z_{t-2} when reached along ``w_out``)."""
        hit = camera.hits(z)
        f, pdf = eval_bsdf(scene, hit, camera.wi[z], w_out, self.hemisphere)
        _, pdf_back = eval_bsdf(scene, hit, w_out, camera.wi[z], self.hemisphere)
        value = np.where(has_smooth(scene, hit)[:, None], camera.beta[z] * f, 0.0)
        return value, pdf, pdf_back

    @staticmethod
    def back_pdf(subpaths, end, before, pdf_dir):
        """Area density of vertices ``before`` generated (reversed) from the next ones, ``end``
        (0 where there is no vertex before)."""
        out = np.zeros(len(end))
        has = before >= 0
        if pdf_dir is not None and has.any():
            e, b = end[has], before[has]
            out[has] = to_area(pdf_dir[has], _distance2(subpaths.p[e], subpaths.p[b]),
                               subpaths.n[b], subpaths.wi[e], subpaths.on_surface[b])
        return out

    @staticmethod
    def unblocked(scene, p, n, w, dist, value) -> np.ndarray:
        """True where ``value`` is non-zero and the segment from ``p`` along ``w`` is free."""
        out = np.zeros(len(p), dtype=bool)
        live = np.flatnonzero(np.any(value != 0, axis=1))
        out[live] = ~shadowed(scene, p[live], n[live], w[live], dist[live])
        return out

    # -- multiple importance sampling --------------------------------------------

    def mis_weight(self, camera, light, position, ends, rev) -> np.ndarray:
        """Veach's weight of the strategies ``ends`` from the density ratios (module docstring).

        ``rev`` holds the ``pdf_rev`` the connection gives the end vertices ("camera_end":
        z_{t-1}, "camera_before": z_{t-2}, "light_end", "light_before").
        """
        exponent = MIS_EXPONENT[self.mis]
        total = np.zeros(len(ends.row))
        for side, subpaths, count in (("camera", camera, ends.t), ("light", light, ends.s)):
            ratio = np.ones(len(ends.row))
            # towards the camera: r_i for strategies t' = i (i >= 1); towards the light: s' = i
            for i in range(count.max() - 1, 0 if side == "camera" else -1, -1):
                act = np.flatnonzero(count - 1 >= i)
                at = subpaths.slot[i, ends.row[act]]
                pdf_rev = subpaths.pdf_rev[at]
                if side + "_end" in rev:
                    pdf_rev = np.where(count[act] - 1 == i, rev[side + "_end"][act], pdf_rev)
                if side + "_before" in rev:
                    pdf_rev = np.where(count[act] - 2 == i, rev[side + "_before"][act], pdf_rev)
                ratio[act] *= _remap0(pdf_rev) / _remap0(subpaths.pdf_fwd[at])
                if i > 0:
                    before = subpaths.delta[subpaths.slot[i - 1, ends.row[act]]]
                else:
                    before = position.delta[ends.row[act]]       # a point light's position
                dirac = before | (subpaths.delta[at] & (i < count[act] - 1))
                total[act] += np.where(dirac, 0.0, ratio[act] ** exponent)
        return 1.0 / (1.0 + total)


@dataclass
class Ends:
    """A batch of strategies: ``s``, ``t`` and the sample ``row`` of each; the samples' pixels."""

    s: np.ndarray
    t: np.ndarray
    row: np.ndarray
    sample_pixel: np.ndarray

    def pixels(self) -> np.ndarray:
        """The pixel of each strategy's camera subpath."""
        return self.sample_pixel[self.row]

    def camera(self, camera: Subpaths, back: int) -> np.ndarray:
        """Slots of z_{t - back} (-1 where t - back < 0)."""
        depth = self.t - back
        return np.where(depth >= 0, camera.slot[np.maximum(depth, 0), self.row], -1)

    def light(self, light: Subpaths, back: int) -> np.ndarray:
        """Slots of y_{s - back} (-1 where s - back < 0)."""
        depth = self.s - back
        return np.where(depth >= 0, light.slot[np.maximum(depth, 0), self.row], -1)


def subpath_states(subpaths: Subpaths, first: np.ndarray, step) -> np.ndarray:
    """(length, count) automaton states of a batch of subpaths after each of their vertices.

    ``first`` are the states after vertex 0 (the eye or the light), ``step(state, shape)``
    reads a scattering vertex on ``shape``. Rows past a subpath's end keep its last state.
    """
    states = np.empty((subpaths.length, len(first)), dtype=np.int32)
    states[0] = first
    for depth in range(1, subpaths.length):
        states[depth] = states[depth - 1]
        rows = np.flatnonzero(subpaths.slot[depth] >= 0)
        shapes = subpaths.hit.shape[subpaths.slot[depth, rows] - subpaths.first_hit]
        states[depth, rows] = step(states[depth - 1, rows], shapes)
    return states
