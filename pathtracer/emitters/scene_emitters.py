"""The scene's emitters together: which one a ray hit, next-event estimation over all of
them, and the rays that start light paths.

Each function chooses the lights, gathers the rows of a batch that concern each one and asks
it (:class:`pathtracer.emitters.base.Emitter`); what an emitter declares (its flags) says
which question applies. Mitsuba's conventions (tests/test_emitters.py and
tests/test_delta_lights.py compare them with Mitsuba's own emitters):

* one emitter is chosen uniformly, with probability 1 / N_emitters;
* area lights are one-sided (:mod:`pathtracer.emitters.area`);
* point and spot lights are Dirac in position: weight ``I falloff / r^2``
  with pdf 1 (MIS weight 1); a directional light is Dirac in direction:
  weight ``E`` (its irradiance), a shadow ray to infinity, pdf 1;
* the environment (``constant`` or ``envmap``) is seen by every ray that
  escapes; it samples its own directions (:class:`ConstantEmitter` uniformly,
  :class:`pathtracer.emitters.envmap.EnvironmentMap` by luminance).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.vec import dot, max_component, rows_by_value, scale
from ..scene.types import Scene
from ..shapes import intersect
from .area import AreaEmitter
from .base import EmitterSample
from .constant import ConstantEmitter
from .directional import DirectionalEmitter
from .envmap import EnvironmentMap
from .point import PointEmitter
from .projector import ProjectorEmitter
from .spot import SpotEmitter

#: Every emitter class (the order of the supported list in the loader's messages).
EMITTER_CLASSES = (AreaEmitter, PointEmitter, SpotEmitter, DirectionalEmitter, ConstantEmitter,
                   EnvironmentMap, ProjectorEmitter)


def hit_emitter(scene: Scene, hit) -> np.ndarray:
    """Index of the area emitter at each hit, -1 where none (a miss or a non-emitting shape)."""
    if len(scene.shape_emitter) == 0:
        return np.full(len(hit.valid), -1)
    return np.where(hit.valid, scene.shape_emitter[np.maximum(hit.shape, 0)], -1)


def emitted_radiance(scene: Scene, hit, wi: np.ndarray) -> np.ndarray:
    """Radiance leaving the hit points towards ``wi`` (unit, pointing away from the surface).

    Area lights count on their front side only; rays that escaped (along
    ``-wi``) see the environment, if any.
    """
    radiance = np.zeros((len(wi), 3))
    on_emitter = hit_emitter(scene, hit) >= 0
    front = on_emitter & (dot(hit.sh_n, wi) > 0)
    if front.any():
        table = _surface_radiance_table(scene)
        radiance[front] = table[scene.shape_emitter[hit.shape[front]]]
        for e in _textured_emitters(scene):
            rows = np.flatnonzero(front & (hit.shape == scene.emitters[e].shape))
            if len(rows):
                radiance[rows] = scene.emitters[e].radiance_at(intersect.texture_uv(scene, hit, rows))
    miss = ~hit.valid
    if scene.environment is not None and miss.any():
        radiance[miss] = scene.environment.eval(-wi[miss])
    return radiance


def _surface_radiance_table(scene: Scene) -> np.ndarray:
    """Radiance of each emitter as an (N_emitters, 3) table (zero for those not on a surface
    and for textured ones, evaluated at their hits): one gather serves every light a batch hit."""
    return np.array([e.radiance if e.on_surface and not e.textured else np.zeros(3)
                     for e in scene.emitters])


def _textured_emitters(scene: Scene) -> list[int]:
    """Indices of the area emitters whose radiance is a texture."""
    return [i for i, e in enumerate(scene.emitters) if e.on_surface and e.textured]


def pdf_emitter_direction(scene: Scene, ref_p: np.ndarray, hit, d: np.ndarray) -> np.ndarray:
    """Solid-angle pdf with which next-event estimation from ``ref_p`` would pick the hit.

    Parameters
    ----------
    ref_p : (n, 3) reference points (the previous path vertex).
    hit : Hit reached from ``ref_p`` along unit directions ``d``.

    Returns
    -------
    (n,) pdf including the 1 / N_emitters selection; 0 where the hit is not an
    emitter or is seen from its back.
    """
    pdf = np.zeros(len(d))
    n_emitters = scene.num_emitters
    if n_emitters == 0:
        return pdf
    miss = ~hit.valid
    if scene.environment is not None and miss.any():
        pdf[miss] = scene.environment.pdf(d[miss]) / n_emitters
    lit = (hit_emitter(scene, hit) >= 0) & (dot(hit.sh_n, d) < 0)
    for s in np.unique(hit.shape[lit]):
        rows = np.flatnonzero(lit & (hit.shape == s))
        light = scene.emitters[scene.shape_emitter[s]]
        if getattr(light, "by_texture", False):
            pdf[rows] = light.pdf_hit(scene, ref_p[rows], hit.p[rows], hit.sh_n[rows], d[rows],
                                      intersect.texture_uv(scene, hit, rows))
        else:
            pdf[rows] = light.pdf_hit(scene, ref_p[rows], hit.p[rows], hit.sh_n[rows], d[rows])
    pdf[lit] /= n_emitters
    return pdf


def sample_emitter(scene: Scene, hit, u_choice: np.ndarray, u: np.ndarray,
                   test_visibility: bool = True, emitter: int | None = None) -> EmitterSample:
    """Next-event estimation: pick a light uniformly and a point on it.

    Parameters
    ----------
    hit : Hit with the reference points (``hit.p``, geometric normal ``hit.n``).
    u_choice : (n,) uniform numbers choosing the emitter.
    u : (n, 2) uniform numbers choosing the point on it.
    test_visibility : bool
        Trace shadow rays and zero the weight of occluded samples.
    emitter : int, optional
        Sample this emitter instead of choosing one (no 1 / N_emitters factor);
        ``u_choice`` is then ignored.
    """
    count = len(u_choice)
    n_emitters = scene.num_emitters
    sample = EmitterSample(np.zeros((count, 3)), np.full(count, np.inf), np.zeros(count),
                           np.zeros((count, 3)), np.zeros(count, dtype=bool))
    if n_emitters == 0 or count == 0:
        return sample
    if emitter is None:
        which = np.minimum((u_choice * n_emitters).astype(np.int64), n_emitters - 1)
    else:
        which = np.full(count, emitter)
    # One light (the common case) is every row, as a slice (no gathers).
    for e, rows in rows_by_value(which):
        part = scene.emitters[e].sample_direction(scene, hit.p[rows], u[rows])
        sample.wo[rows], sample.dist[rows], sample.pdf[rows] = part.wo, part.dist, part.pdf
        sample.weight[rows], sample.delta[rows] = part.weight, part.delta
    if emitter is None:
        # Uniform emitter choice: pdf divided, weight multiplied, by N (Dirac pdf stays 1).
        sample.pdf = np.where(sample.delta, sample.pdf, sample.pdf / n_emitters)
        sample.weight *= n_emitters
    if test_visibility:
        live = np.flatnonzero(max_component(sample.weight) > 0)
        if len(live) == count:   # no gathers when every sample needs its shadow ray
            sample.weight[shadowed(scene, hit.p, hit.n, sample.wo, sample.dist)] = 0.0
        else:
            blocked = shadowed(scene, np.take(hit.p, live, axis=0), np.take(hit.n, live, axis=0),
                               np.take(sample.wo, live, axis=0), np.take(sample.dist, live))
            sample.weight[live[blocked]] = 0.0
    return sample


def shadowed(scene: Scene, p: np.ndarray, n: np.ndarray, wo: np.ndarray,
             dist: np.ndarray) -> np.ndarray:
    """True where the segment from ``p`` (normal ``n``) along ``wo`` for ``dist`` is blocked."""
    finite = np.isfinite(dist)
    if finite.all():   # lights at finite distance only: no gathers
        target = p + scale(wo, dist)
        o, d, tmax = intersect.spawn_ray_to(p, n, target)
        return intersect.occluded(scene, o, d, tmax)
    blocked = np.zeros(len(dist), dtype=bool)
    if finite.any():
        target = p[finite] + wo[finite] * dist[finite, None]
        o, d, tmax = intersect.spawn_ray_to(p[finite], n[finite], target)
        blocked[finite] = intersect.occluded(scene, o, d, tmax)
    if (~finite).any():
        o = intersect.spawn_ray(p[~finite], n[~finite], wo[~finite])
        blocked[~finite] = intersect.occluded(scene, o, wo[~finite], np.full((~finite).sum(), np.inf))
    return blocked


# ----------------------------------------------------------------------
# Rays leaving the lights: the first vertex of light paths (light tracing, BDPT)

#: Emitters a light path can start on (the others are refused by :func:`check_light_paths`).
LIGHT_PATH_EMITTERS = tuple(cls.kind for cls in EMITTER_CLASSES if cls.starts_light_paths)


def check_light_paths(scene: Scene) -> None:
    """Raise ``ValueError`` naming the first emitter light paths cannot start on.

    Environment and directional lights emit from infinitely far away: a light path
    would have to start on a disk covering the scene, which is not implemented yet.
    """
    for light in scene.emitters:
        if not light.starts_light_paths:
            name = light.light_path_name or f"{light.kind} emitters"
            raise ValueError(f"light tracing does not support {name} yet "
                             f"(supported: {', '.join(LIGHT_PATH_EMITTERS)})")


@dataclass
class EmitterPosition:
    """Points sampled on the lights.

    Attributes
    ----------
    p : (n, 3) the points (the light's position for point and spot lights).
    n : (n, 3) unit normal of the emitting side (0 for point and spot lights).
    emitter : (n,) int index into ``scene.emitters``.
    pdf : (n,) area density, including the 1 / N_emitters choice (1 / N for Dirac lights);
        0 where a light found no point (a textured light's coordinates off its mesh).
    delta : (n,) True for point, spot and projector lights (Dirac in position).
    emission : (n, 3) the spatial factor of what leaves the points: an area light's radiance
        there (its texture at the point), 1 for the Dirac lights (their intensity depends on
        the direction only).
    """

    p: np.ndarray
    n: np.ndarray
    emitter: np.ndarray
    pdf: np.ndarray
    delta: np.ndarray
    emission: np.ndarray

    def inverse_pdf(self) -> np.ndarray:
        """(n,) ``1 / pdf``, 0 where no point was found."""
        return np.divide(1.0, self.pdf, out=np.zeros(len(self.pdf)), where=self.pdf > 0)

    def take(self, rows) -> "EmitterPosition":
        """The rows ``rows`` (indices or mask)."""
        return EmitterPosition(self.p[rows], self.n[rows], self.emitter[rows], self.pdf[rows],
                               self.delta[rows], self.emission[rows])


@dataclass
class EmitterRay:
    """Rays leaving the lights, with their densities (Mitsuba's ``sample_emitter_ray``).

    Attributes
    ----------
    position : EmitterPosition where the rays start.
    d : (n, 3) unit directions.
    pdf_dir : (n,) solid-angle density of ``d`` given the position.
    weight : (n, 3) ``Le cos / (pdf * pdf_dir)`` for area lights, ``I falloff /
        (pdf * pdf_dir)`` for point and spot lights: the power the path carries (0 where
        no point was found).
    """

    position: EmitterPosition
    d: np.ndarray
    pdf_dir: np.ndarray
    weight: np.ndarray


def choose_emitter(scene: Scene, u_choice: np.ndarray) -> np.ndarray:
    """Uniform choice of one emitter per sample -> (n,) indices (probability 1 / N)."""
    count = scene.num_emitters
    return np.minimum((u_choice * count).astype(np.int64), count - 1)


def sample_emitter_position(scene: Scene, u_choice: np.ndarray,
                            u: np.ndarray) -> EmitterPosition:
    """A uniformly chosen light and a point on it, uniform in area.

    Meshes pick a triangle proportionally to area, disks a concentric-mapped point,
    spheres a uniform point on the whole sphere (``pdf = 1 / (N area)``); a spatially
    varying radiance draws the point from its texture; point, spot and projector lights
    return their position (``pdf = 1 / N``, Dirac).
    """
    check_light_paths(scene)
    count = len(u_choice)
    which = choose_emitter(scene, u_choice)
    out = EmitterPosition(np.zeros((count, 3)), np.zeros((count, 3)), which,
                          np.zeros(count), np.zeros(count, dtype=bool), np.zeros((count, 3)))
    for e, rows in rows_by_value(which):
        light = scene.emitters[e]
        out.p[rows], out.n[rows], out.pdf[rows], out.emission[rows] = \
            light.sample_position(scene, u[rows])
        out.delta[rows] = light.delta_position
    out.pdf /= scene.num_emitters
    return out


def sample_emitter_ray(scene: Scene, u_choice: np.ndarray, u_pos: np.ndarray,
                       u_dir: np.ndarray) -> EmitterRay:
    """Rays leaving uniformly chosen lights (the first segment of light paths).

    Area lights: a uniform point, then a cosine-weighted direction on the emitting
    side (``pdf_dir = cos / pi``, weight ``N Le area pi``); point lights: a uniform
    direction (``1 / 4 pi``, weight ``N 4 pi I``); spot lights: a uniform direction in
    the cutoff cone (weight ``N I falloff / pdf_cone``). As Mitsuba's emitters do.
    """
    position = sample_emitter_position(scene, u_choice, u_pos)
    count = len(u_choice)
    d, pdf_dir, weight = np.zeros((count, 3)), np.zeros(count), np.zeros((count, 3))
    for e, rows in rows_by_value(position.emitter):
        light = scene.emitters[e]
        d[rows], pdf_dir[rows], weight[rows] = light.sample_ray_direction(position.n[rows], u_dir[rows])
    # Area lights: Le cos / (pdf_pos pdf_dir) = Le pi / pdf_pos; Dirac ones: / (1 / N).
    weight = np.divide(weight * position.emission, position.pdf[:, None],
                       out=np.zeros((count, 3)), where=position.pdf[:, None] > 0)
    return EmitterRay(position, d, pdf_dir, weight)


def pdf_emitter_ray(scene: Scene, position: EmitterPosition, d: np.ndarray) -> np.ndarray:
    """Solid-angle density with which :func:`sample_emitter_ray` picks ``d`` at ``position``."""
    pdf = np.zeros(len(d))
    for e, rows in rows_by_value(position.emitter):
        pdf[rows] = scene.emitters[e].pdf_ray_direction(position.n[rows], d[rows])
    return pdf


def emitted_towards(scene: Scene, position: EmitterPosition, d: np.ndarray) -> np.ndarray:
    """Radiance (area lights) or intensity (point, spot) leaving ``position`` along ``d``.

    Area lights emit on the side their normal faces only, as for :func:`emitted_radiance`.
    """
    out = np.zeros((len(d), 3))
    for e, rows in rows_by_value(position.emitter):
        out[rows] = scene.emitters[e].eval_towards(position.n[rows], d[rows])
    return out * position.emission


def emitter_position_at(scene: Scene, hit) -> EmitterPosition:
    """The hits on area lights as :class:`EmitterPosition` s, with the area density with which
    :func:`sample_emitter_position` would have picked them (``1 / (N area)``, or the texture's
    density for a spatially varying radiance) and the radiance there.

    Hits that are not on an emitter get ``emitter`` -1, pdf 0 and emission 0. The normal is
    the shading normal, the one :func:`emitted_radiance` tests the emitting side against.
    """
    which = hit_emitter(scene, hit)
    pdf, emission = np.zeros(len(which)), np.zeros((len(which), 3))
    for e in np.unique(which[which >= 0]):
        rows = np.flatnonzero(which == e)
        light = scene.emitters[e]
        surface = intersect.texture_uv(scene, hit, rows) if light.textured else np.zeros((len(rows), 2))
        pdf[rows] = light.position_pdf(scene, surface, scene.num_emitters)
        emission[rows] = light.radiance_at(surface)
    return EmitterPosition(hit.p, hit.sh_n, which, pdf, np.zeros(len(which), dtype=bool), emission)
