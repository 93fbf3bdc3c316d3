r"""Heterogeneous media: extinction and albedo from volumes, sampled against a majorant.

Mitsuba 3.9.1's ``heterogeneous`` medium reads :math:`\sigma_t(x)` =
``scale`` :math:`\times` ``sigma_t.eval(x)`` and :math:`\alpha(x)` =
``albedo.eval(x)`` from two volumes (:mod:`pathtracer.volumes`), and bounds
the extinction by one number for all three channels, the *majorant*

.. math:: \bar\sigma = \text{scale} \times \max_{\text{voxels, channels}} \text{sigma\_t},

(``max_value`` of a ``gridvolume`` replaces the grid's maximum). The medium
has density only inside the box of its ``sigma_t`` volume (the unit cube
under the volume's ``to_world``; a ``<float>`` or ``<rgb>`` ``sigma_t`` is a
``constvolume`` there too): a ray crosses the box over :math:`[t_0, t_1]`,
:math:`t_0 = \max(0, t_\text{enter})`.

Free flight, as ``volpath`` does it (delta tracking with weights)
-----------------------------------------------------------------
A tentative collision is drawn at :math:`t = t_0 - \ln(1 - u) / \bar\sigma`
(the path's RGB channel plays no part: the majorant is grey). If it falls
inside the box and before the surface, with :math:`\sigma_n = \bar\sigma -
\sigma_t(x)` (per channel) and the null probability
:math:`P_n = \overline{\sigma_n / \bar\sigma}` (the mean over R, G, B):

.. math::

    u' < P_n:\ \text{null collision, go on straight:}\quad
        \beta \mathrel{*}= \frac{\sigma_n}{\bar\sigma\,P_n},
    \qquad
    \text{else real scattering:}\quad
        \beta \mathrel{*}= \frac{\sigma_s}{\bar\sigma\,(1 - P_n)}
        = \frac{\sigma_s}{\overline{\sigma_t}},

and otherwise the path reaches the surface with weight 1 (:math:`T/T_c` of
the grey majorant), or 0 if it escapes to infinity inside the medium (the
majorant's transmittance over an infinite distance; Mitsuba does the same).
For a grey medium the weights are 1 and the albedo: classic delta tracking.

Shadow rays: ratio tracking
---------------------------
Along a shadow ray the same tentative collisions are drawn, and each one
multiplies the transmittance estimate by :math:`\sigma_n(x) / \bar\sigma`
(per channel, never 0 unless the voxel reaches the majorant), until the ray
leaves the box or reaches the end of its segment:
:math:`E[\prod_i \sigma_n(x_i)/\bar\sigma] = \exp(-\int \sigma_t)`.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core.vec import put_rows
from ..scene.properties import COLOR_TAGS, Props, children
from ..scene.registry import register
from ..scene.xml import Plugin
from ..volumes import ConstVolume, Volume, build_volume
from ..volumes.base import box_interval
from .phase import IsotropicPhase, build_phase


@dataclass
class HeterogeneousMedium:
    """Mitsuba's ``heterogeneous`` medium.

    Attributes
    ----------
    sigma_t, albedo : Volume
        Extinction (before ``scale``) and single-scattering albedo.
    scale : float
    phase, sample_emitters, name : as :class:`~pathtracer.media.homogeneous.HomogeneousMedium`.
    """

    sigma_t: Volume
    albedo: Volume
    scale: float = 1.0
    phase: object = field(default_factory=IsotropicPhase)
    sample_emitters: bool = True
    name: str = "heterogeneous"
    is_homogeneous = False

    @property
    def majorant(self) -> float:
        r""":math:`\bar\sigma` = scale x the largest value of ``sigma_t``."""
        return self.scale * self.sigma_t.max()

    def coefficients(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(sigma_t, sigma_s), each (n, 3), at world points ``p`` (n, 3)."""
        sigma_t = self.scale * self.sigma_t.eval(p)
        return sigma_t, sigma_t * self.albedo.eval(p)

    def box(self, o: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Rays' part in the density's box -> (crosses (n,), t0 (n,) >= 0, t1 (n,))."""
        hit, mint, maxt = box_interval(self.sigma_t.bbox, o, d)
        active = hit & (np.isfinite(mint) | np.isfinite(maxt))
        return active, np.where(active, np.maximum(mint, 0.0), 0.0), maxt


def heterogeneous_table(scene) -> np.ndarray:
    """True (M,) for the scene's heterogeneous media."""
    return np.array([_heterogeneous(m) for m in scene.media], dtype=bool)


def has_heterogeneous(scene) -> bool:
    """The scene has a heterogeneous medium (asked per segment and per shadow ray: no array)."""
    return any(_heterogeneous(m) for m in getattr(scene, "media", None) or ())


def _heterogeneous(medium) -> bool:
    return not getattr(medium, "is_homogeneous", True)


def track_heterogeneous(scene, flight, medium: np.ndarray, o: np.ndarray, d: np.ndarray,
                        t_surface: np.ndarray, u: np.ndarray, u_null: np.ndarray | None) -> None:
    """Fill in ``flight`` (a :class:`~pathtracer.media.homogeneous.FreeFlight`) for the rows
    in heterogeneous media: one tentative collision each (module docstring).

    ``u_null`` None: a shadow ray (ratio tracking): every collision is a null one with
    weight sigma_n / majorant, and a ray that does not collide keeps weight 1.
    Otherwise collisions are null or real by ``u_null``, and a path escaping to infinity
    gets weight 0. ``flight.null`` marks the null collisions; ``flight.t`` is the
    collision's distance where there is one.
    """
    hetero = heterogeneous_table(scene)
    inside = np.flatnonzero(medium >= 0)
    rows_all = inside[hetero[medium[inside]]]
    if not len(rows_all):
        return
    if flight.null is None:
        flight.null = np.zeros(len(medium), dtype=bool)
    for k in np.unique(medium[rows_all]):
        rows = rows_all[medium[rows_all] == k]
        med = scene.media[k]
        majorant = med.majorant
        # The rays' (n, 3) rows gathered once, by np.take (fancy indexing is slower)
        o_k, d_k = np.take(o, rows, axis=0), np.take(d, rows, axis=0)
        active, t0, t1 = med.box(o_k, d_k)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = t0 - np.log1p(-u[rows]) / majorant
        collided = active & (t <= t1) & (t <= t_surface[rows]) & (majorant > 0)
        weight = np.ones((len(rows), 3))
        if u_null is not None:
            weight[~collided & ~np.isfinite(t_surface[rows])] = 0.0
        c = np.flatnonzero(collided)
        real = np.zeros(len(rows), dtype=bool)
        if len(c):
            x = np.take(o_k, c, axis=0) + t[c, None] * np.take(d_k, c, axis=0)
            sigma_t, sigma_s = med.coefficients(x)
            sigma_n = majorant - sigma_t
            if u_null is None:
                put_rows(weight, c, sigma_n / majorant)
            else:
                p_null = np.mean(sigma_n / majorant, axis=1)
                is_null = u_null[rows[c]] < p_null
                with np.errstate(divide="ignore", invalid="ignore"):
                    w_null = sigma_n / (majorant * p_null[:, None])
                    w_real = sigma_s / (majorant * np.mean(sigma_t / majorant, axis=1))[:, None]
                put_rows(weight, c, np.where(is_null[:, None], w_null, w_real))
                real[c] = ~is_null
        flight.scattered[rows] = real
        flight.null[rows] = collided & ~real
        flight.t[rows] = np.where(collided, t, t_surface[rows])
        put_rows(flight.weight, rows, weight)


def _volume_parameter(plugin: Plugin, props: Props, volumes: dict, name: str,
                      default: float) -> Volume:
    """A volume parameter: a nested or referenced ``<volume name=..>``, else a ``<float>``,
    ``<rgb>`` or ``<spectrum>`` made a ``constvolume`` (Mitsuba's ``get_volume``)."""
    if name in volumes:
        if props.has(name):
            raise volumes[name].error(f"parameter \"{name}\" given twice")
        return build_volume(volumes[name], props.folders)
    if props.has(name) and plugin.props[name].tag not in COLOR_TAGS:
        raise plugin.error(f"property \"{name}\" must be a <volume>, <float>, <rgb> or "
                           f"<spectrum>, not <{plugin.props[name].tag}>", props.line(name))
    value = props.color(name, default)
    if props.has(name) and plugin.props[name].tag == "rgb" and not np.all(
            (value >= 0) & (value <= 1)):
        raise plugin.error(f"an <rgb> {name} must lie in [0, 1] (Mitsuba reads it as a "
                           "reflectance); give larger values in a <volume type=\"constvolume\"> "
                           "or with scale", props.line(name))
    return ConstVolume(value)


@register("medium", "heterogeneous")
def create(props: Props) -> HeterogeneousMedium:
    """The :class:`HeterogeneousMedium` of a ``<medium type="heterogeneous">`` element.

    ``sigma_t`` (1) and ``albedo`` (0.75): each a nested or referenced ``<volume>``
    (``gridvolume``, ``constvolume``) or a ``<float>`` / ``<rgb>`` / ``<spectrum>`` (a
    ``constvolume`` filling the unit cube); ``scale`` (1) multiplies ``sigma_t``;
    ``sample_emitters`` (true); ``has_spectral_extinction`` (true; false only with a grey
    ``sigma_t``); one nested ``<phase>`` (isotropic).
    """
    plugin = props.plugin
    kids = children(plugin, {"phase": 1, "volume": 2})
    volumes = {}
    for name, child in plugin.named_children():
        if child.kind != "volume":
            continue
        if name not in ("sigma_t", "albedo"):
            raise child.error(f"a <volume> inside {plugin.label} needs name=\"sigma_t\" or "
                              f"name=\"albedo\" (got {name!r})")
        if name in volumes:
            raise child.error(f"parameter \"{name}\" given twice")
        volumes[name] = child
    sigma_t = _volume_parameter(plugin, props, volumes, "sigma_t", 1.0)
    albedo = _volume_parameter(plugin, props, volumes, "albedo", 0.75)
    scale = props.float("scale", 1.0)
    if not (np.isfinite(scale) and scale >= 0):
        raise plugin.error(f"scale must be a finite number >= 0, got {scale}", props.line("scale"))
    sample_emitters = props.bool("sample_emitters", True)
    if not props.bool("has_spectral_extinction", True) and not sigma_t.is_grey():
        raise plugin.error("has_spectral_extinction=false with a coloured sigma_t is not "
                           "supported (Mitsuba then weights collisions wrongly); leave it true",
                           props.line("has_spectral_extinction"))
    props.finish()
    if sigma_t.max() < 0 or (isinstance(sigma_t, ConstVolume) and np.any(sigma_t.value < 0)):
        raise plugin.error("sigma_t must be >= 0")
    phase = build_phase(kids["phase"][0]) if kids["phase"] else IsotropicPhase()
    return HeterogeneousMedium(sigma_t, albedo, scale, phase, sample_emitters,
                               name=f"heterogeneous ({plugin.file}:{plugin.line})")
