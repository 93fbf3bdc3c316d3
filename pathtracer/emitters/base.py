"""The interface every emitter implements, and what the lights at infinity share.

An emitter declares what kind of light it is (its flags) and answers the questions the
scene-wide functions of :mod:`pathtracer.emitters.scene_emitters` put to it, for the rows
of a batch that concern it:

* seen by a ray: :meth:`Emitter.eval` and :meth:`Emitter.pdf` for rays that escape the
  scene (environments), :meth:`Emitter.pdf_hit` for rays that hit the emitter's shape;
* next-event estimation: :meth:`Emitter.sample_direction`, a point on the light seen from
  reference points, with its solid-angle pdf and weight;
* light paths (light tracing, BDPT): :meth:`Emitter.sample_position`,
  :meth:`Emitter.sample_ray_direction`, :meth:`Emitter.pdf_ray_direction` and
  :meth:`Emitter.eval_towards`, for the emitters with :attr:`Emitter.starts_light_paths`.

No pdf here includes the choice of the emitter among the scene's (1 / N_emitters): the
scene-wide functions make that choice and account for it.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..scene import transform


@dataclass
class EmitterSample:
    """A sampled light position seen from reference points.

    Attributes
    ----------
    wo : (n, 3) unit direction from the reference point to the light.
    dist : (n,) distance (inf for the environment).
    pdf : (n,) solid-angle pdf, including the 1 / N_emitters choice (1 for Dirac lights).
    weight : (n, 3) radiance / pdf, zero when the light faces away or is occluded.
    delta : (n,) True for Dirac lights (point, spot, directional).
    """

    wo: np.ndarray
    dist: np.ndarray
    pdf: np.ndarray
    weight: np.ndarray
    delta: np.ndarray


class Emitter:
    """What every emitter declares and answers.

    Attributes
    ----------
    kind : str
        Mitsuba's plugin name (``'area'``, ``'point'``, ...).
    delta_position : bool
        The light is one point (point, spot): rays never hit it, its next-event pdf is 1.
    delta_direction : bool
        The light arrives from one direction (directional): rays never see it either.
    environment : bool
        The light surrounds the scene at infinity (constant, envmap): rays that escape see it.
    on_surface : bool
        The light is attached to a shape (area), whose index it keeps in ``shape``.
    starts_light_paths : bool
        Light tracing and BDPT can start paths on it (area, point and spot lights).
    """

    kind = ""
    #: Not on a surface, or on one with a constant radiance (area lights set it per light).
    textured = False
    #: How light tracing's refusal names it, when not ``"<kind> emitters"``.
    light_path_name = None
    delta_position = False
    delta_direction = False
    environment = False
    on_surface = False
    starts_light_paths = False

    # -- seen by rays ------------------------------------------------------------

    def eval(self, d_world: np.ndarray) -> np.ndarray:
        """Radiance (n, 3) that rays escaping along ``d_world`` receive from this light
        (0 unless it is an environment)."""
        return np.zeros((len(d_world), 3))

    def pdf(self, d_world: np.ndarray) -> np.ndarray:
        """Solid-angle density (n,) with which :meth:`sample_direction` picks the escape
        directions ``d_world`` (0 unless it is an environment)."""
        return np.zeros(len(d_world))

    def pdf_hit(self, scene, ref_p: np.ndarray, p: np.ndarray, n: np.ndarray,
                d: np.ndarray) -> np.ndarray:
        """Solid-angle density (n,) with which :meth:`sample_direction` from ``ref_p`` picks the
        points ``p`` (shading normals ``n``) reached along unit ``d`` (0 unless it is on a surface)."""
        return np.zeros(len(d))

    # -- next-event estimation ------------------------------------------------------

    def sample_direction(self, scene, ref_p: np.ndarray, u: np.ndarray) -> EmitterSample:
        """A point on the light seen from each reference point ``ref_p`` (n, 3), chosen by the
        uniform numbers ``u`` (n, 2); occlusion is not tested."""
        raise NotImplementedError(f"{type(self).__name__} does not implement sample_direction")

    # -- light paths -----------------------------------------------------------------

    def sample_position(self, scene, u: np.ndarray) -> tuple[np.ndarray, ...]:
        """Points where light paths start, from uniform ``u`` (n, 2): ``(p, n, pdf, emission)``,
        the points, the unit normals of their emitting side (0 for a point light), the area
        density (1 for a Dirac position; 0 where no point was found) and ``emission`` (n, 3),
        the spatial factor of what leaves each point: the radiance there for a surface, 1 for
        a point light (whose intensity depends on the direction only)."""
        raise NotImplementedError(f"{self.kind} emitters do not start light paths")

    def sample_ray_direction(self, n: np.ndarray,
                             u: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Directions leaving points of :meth:`sample_position` (normals ``n``), from uniform
        ``u`` (n, 2): ``(d, pdf_dir, weight)``, ``weight`` being the directional factor of
        what leaves along ``d`` (:meth:`eval_towards`, times the cosine for a surface) over
        ``pdf_dir``; the point's ``emission`` multiplies it."""
        raise NotImplementedError(f"{self.kind} emitters do not start light paths")

    def pdf_ray_direction(self, n: np.ndarray, d: np.ndarray) -> np.ndarray:
        """Solid-angle density (n,) with which :meth:`sample_ray_direction` picks ``d``."""
        raise NotImplementedError(f"{self.kind} emitters do not start light paths")

    def eval_towards(self, n: np.ndarray, d: np.ndarray) -> np.ndarray:
        """The directional factor (n, 3) of what leaves points of normals ``n`` along ``d``:
        1 on a surface's emitting side and 0 behind it, a point light's intensity. Times the
        point's ``emission`` it is the radiance (a surface) or intensity (a point)."""
        raise NotImplementedError(f"{self.kind} emitters do not start light paths")


class EnvironmentEmitter(Emitter):
    """A light at infinity seen by every escaped ray; subclasses give :meth:`eval`, :meth:`pdf`
    and ``sample(u) -> (wo, pdf, radiance)``, directions drawn by their own density."""

    environment = True

    def sample(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Directions ``wo`` (n, 3) towards the environment, their solid-angle pdf (n,) and the
        radiance (n, 3) arriving along ``-wo``."""
        raise NotImplementedError(f"{type(self).__name__} does not implement sample")

    def sample_direction(self, scene, ref_p: np.ndarray, u: np.ndarray) -> EmitterSample:
        """A direction drawn by the environment's own density, a shadow ray to infinity."""
        wo, pdf, radiance = self.sample(u)
        ok = pdf > 0
        weight = np.where(ok[:, None], radiance / np.where(ok, pdf, 1.0)[:, None], 0.0)
        return EmitterSample(wo, np.full(len(u), np.inf), np.where(ok, pdf, 0.0), weight,
                             np.zeros(len(u), dtype=bool))


def rotation_only(props) -> np.ndarray:
    """``to_world`` of a light at infinity, refused when it scales (Mitsuba would not renormalise)."""
    m = props.transform("to_world")
    if transform.has_scale(m):
        raise props.plugin.error("to_world must not scale or shear a light at infinity (Mitsuba "
                                 "would use unnormalised directions); use rotate or lookat",
                                 props.line("to_world"))
    return m
