r"""Homogeneous participating media: free-flight sampling, transmittance, medium tracking.

A medium fills the inside (``interior``) or outside (``exterior``) of shapes,
or surrounds the camera. Inside it light is absorbed and out-scattered at the
rate :math:`\sigma_t` (extinction, per unit length) and in-scattered at
:math:`\sigma_s = \alpha\,\sigma_t` (:math:`\alpha` the single-scattering
albedo), with the direction chosen by the medium's phase function
(:mod:`pathtracer.media.phase`). Transmittance over a distance :math:`t` is
:math:`T(t) = e^{-\sigma_t t}`, per RGB channel.

Free-flight sampling, as Mitsuba 3.9.1's ``volpath`` does it in RGB
----------------------------------------------------------------------
One channel :math:`c` is chosen uniformly per camera path (once, at its start)
and distances are drawn from that channel's exponential,
:math:`t = -\ln(1 - u) / \sigma_{t,c}`. If :math:`t` falls before the next
surface (at distance :math:`s`) the path scatters there, otherwise it reaches
the surface. The throughput is multiplied by the full RGB transmittance over
the *chosen channel's* pdf:

.. math::

    \text{scatter:}\quad \beta \mathrel{*}= \frac{T(t)\,\sigma_s}{T_c(t)\,\sigma_{t,c}},
    \qquad
    \text{surface:}\quad \beta \mathrel{*}= \frac{T(s)}{T_c(s)}.

This is *not* spectral MIS (the pdf is not averaged over the channels; that is
Mitsuba's ``volpathmis``): ``volpath`` divides by the one channel's pdf, and
its scattering factor :math:`\sigma_s / \overline{\sigma_t / \bar\sigma}`
reduces to :math:`\sigma_s` for a homogeneous medium, whose majorant
:math:`\bar\sigma` is :math:`\sigma_t` itself. For a grey medium both factors
are the albedo and 1. The estimator is unbiased in every channel; a strongly
coloured :math:`\sigma_t` gives large weights in the channels not chosen.

Spectral MIS (``volpathmis``)
-----------------------------
A path whose channel is :data:`MIXTURE` draws each free flight's channel afresh, uniformly,
from the flight's own uniform number (:math:`c = \lfloor 3u \rfloor`, then :math:`u' = 3u - c`
for the distance), so that distances follow the mixture of the three exponentials, and
divides by the mixture's density, the one-sample balance heuristic over the channels:

.. math::

    \text{scatter:}\quad \beta \mathrel{*}= \frac{T(t)\,\sigma_s}
        {\tfrac13 \sum_k T_k(t)\,\sigma_{t,k}},
    \qquad
    \text{surface:}\quad \beta \mathrel{*}= \frac{T(s)}{\tfrac13 \sum_k T_k(s)}.

Every factor is at most 3 in every channel (that channel's own term bounds the denominator),
where ``volpath``'s :math:`T / T_c` grows as :math:`e^{(\sigma_{t,c} - \sigma_{t,k}) t}` in a
channel :math:`k` of smaller extinction. Mitsuba's ``volpathmis`` averages the densities of
the whole path instead (one channel per path); both are unbiased and bounded, with
different noise. Shadow rays of such paths follow the same rule.

Shadow rays (transmittance along a segment) use the same sampling: a distance
is drawn in the current medium; if it falls before the end of the segment the
estimate is 0 (a homogeneous medium has no null collisions), else it is
:math:`T / T_c` (delta tracking with the same weights, Mitsuba's estimator, so
that the variance agrees too). Surfaces on the way let the shadow ray through
only through a null lobe: fully through a ``null`` BSDF, with
:math:`(1 - r)` times its transmittance through a ``thindielectric``
(:func:`null_transmission`, Mitsuba's ``eval_null_transmission``).

Medium tracking
---------------
A shape with an ``interior`` or ``exterior`` medium is a *medium transition*:
a ray leaving one of its points along ``d`` is in the exterior medium if
``dot(n_geometric, d) > 0`` and in the interior one otherwise (Mitsuba's
``target_medium``). Crossing any other shape does not change the medium.
Index -1 means vacuum.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from types import SimpleNamespace

import numpy as np

from ..core.vec import (
    any_row,
    dot,
    multiply_rows,
    put_rows,
    rows_by_value,
    scale,
    select,
    take_rows,
    unscale,
)
from ..scene.properties import Props, children
from ..scene.registry import register
from ..scene.types import Scene
from ..scene.xml import Plugin
from ..shapes import intersect
from ..volumes import build_volume
from .heterogeneous import has_heterogeneous, heterogeneous_table, track_heterogeneous
from .phase import IsotropicPhase, build_phase


@dataclass
class HomogeneousMedium:
    """Mitsuba's ``homogeneous`` medium.

    Attributes
    ----------
    sigma_t : (3,) extinction per unit length (``sigma_t * scale`` of the file).
    albedo : (3,) single-scattering albedo in [0, 1].
    phase : IsotropicPhase or HenyeyGreensteinPhase
    sample_emitters : bool
        Next-event estimation from points inside the medium (Mitsuba's
        ``sample_emitters``); when False, emission reached after scattering
        in it counts in full, as after a specular bounce.
    name : str
        Where it was defined, for messages.
    albedo_volume : Volume or None
        A spatially varying albedo (Mitsuba's homogeneous medium takes a ``<volume
        name="albedo">``); ``albedo`` is then 1 and the integrators multiply by the
        volume's value where the path scatters (:func:`scattering_albedo`).
    """

    sigma_t: np.ndarray
    albedo: np.ndarray
    phase: object = field(default_factory=IsotropicPhase)
    sample_emitters: bool = True
    name: str = "homogeneous"
    albedo_volume: object = None
    is_homogeneous = True

    @property
    def sigma_s(self) -> np.ndarray:
        """Scattering coefficient :math:`\\alpha\\,\\sigma_t` (3,)."""
        return self.albedo * self.sigma_t


def has_media(scene: Scene) -> bool:
    """The scene has a participating medium or a ``null`` boundary."""
    return bool(getattr(scene, "media", None)) or any(
        getattr(b, "is_null", False) for b in scene.bsdfs)


def camera_medium(scene: Scene, n: int) -> np.ndarray:
    """Medium index (n,) of camera rays: the sensor's medium, -1 for vacuum."""
    return np.full(n, getattr(scene, "camera_medium", -1), dtype=np.int64)


def _coefficients(scene: Scene) -> tuple[np.ndarray, np.ndarray]:
    """(M, 3) tables of sigma_t and sigma_s (zeros for heterogeneous media)."""
    homogeneous = [m if m.is_homogeneous else None for m in scene.media]
    return (np.array([np.zeros(3) if m is None else m.sigma_t for m in homogeneous]).reshape(-1, 3),
            np.array([np.zeros(3) if m is None else m.sigma_s for m in homogeneous]).reshape(-1, 3))


#: The channel of a path that draws every free flight from the mixture of the three channels'
#: exponentials (spectral MIS, ``volpathmis``; see the module docstring).
MIXTURE = -1


def choose_channel(u: np.ndarray) -> np.ndarray:
    """The RGB channel (n,) whose extinction drives free-flight sampling, uniformly."""
    return np.minimum((u * 3).astype(np.int64), 2)


@dataclass
class FreeFlight:
    """Outcome of :func:`sample_free_flight`.

    Attributes
    ----------
    scattered : (n,) bool, the path scatters in the medium before the surface.
    t : (n,) distance to the scattering point (the surface distance otherwise).
    weight : (n, 3) throughput factor (see the module docstring).
    null : (n,) bool or None, a null collision in a heterogeneous medium (the path goes on
        straight from ``t``; :mod:`pathtracer.media.heterogeneous`); None: there is none.
    """

    scattered: np.ndarray
    t: np.ndarray
    weight: np.ndarray
    null: np.ndarray | None = None


def sample_free_flight(scene: Scene, medium: np.ndarray, channel: np.ndarray,
                       t_surface: np.ndarray, u: np.ndarray) -> FreeFlight:
    """Sample where rays in ``medium`` (n,) next interact, before ``t_surface`` (n,) or there.

    Rows in vacuum (medium -1) reach the surface with weight 1, and so do, here, rows in a
    heterogeneous medium: :func:`~pathtracer.media.heterogeneous.track_heterogeneous`
    samples those. Rows whose ``channel`` is :data:`MIXTURE` draw their channel from ``u``
    and are weighted by the channels' average density ("Spectral MIS" above).
    """
    n = len(medium)
    rows = np.flatnonzero(medium >= 0)
    if len(rows) and has_heterogeneous(scene):
        rows = rows[~heterogeneous_table(scene)[medium[rows]]]
    if not len(rows):
        return FreeFlight(np.zeros(n, dtype=bool), t_surface.copy(), np.ones((n, 3)))
    sigma_t_table, sigma_s_table = _coefficients(scene)
    medium, t_reach = np.take(medium, rows), np.take(t_surface, rows)
    sigma_t, sigma_s = np.take(sigma_t_table, medium, axis=0), np.take(sigma_s_table, medium, axis=0)
    channel, u_flight = channel[rows], u[rows]
    mixture = np.flatnonzero(channel == MIXTURE)
    if len(mixture):     # one uniform number: the channel, then the distance (3u - c)
        channel[mixture] = choose_channel(u_flight[mixture])
        u_flight[mixture] = np.minimum(3.0 * u_flight[mixture] - channel[mixture], 1.0 - 2.0 ** -53)
    sigma_c = sigma_t_table[medium, channel]
    with np.errstate(divide="ignore", invalid="ignore"):
        t_sampled = -np.log1p(-u_flight) / sigma_c
        scattered = t_sampled < t_reach
        t = np.where(scattered, t_sampled, t_reach)
        tr = np.exp(scale(sigma_t, -t))
        tr_c = np.exp(-sigma_c * t)
        pdf = np.where(scattered, tr_c * sigma_c, tr_c)
        if len(mixture):     # the mixture's density: the channels' densities averaged
            tr_m = np.take(tr, mixture, axis=0)
            pdf[mixture] = np.where(scattered[mixture],
                                    np.mean(tr_m * np.take(sigma_t, mixture, axis=0), axis=1),
                                    np.mean(tr_m, axis=1))
        weight = select(pdf > 0, unscale(tr, pdf))
    weight *= select(scattered, sigma_s, 1.0)
    if len(rows) == n:   # every row in a homogeneous medium: nothing to put back in place
        return FreeFlight(scattered, t, weight)
    out = FreeFlight(np.zeros(n, dtype=bool), t_surface.copy(), np.ones((n, 3)))
    out.scattered[rows], out.t[rows] = scattered, t
    put_rows(out.weight, rows, weight)
    return out


def phase_eval(scene: Scene, medium: np.ndarray, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
    """Phase function value (= pdf) (n,) of each row's medium ``medium`` (n,), all >= 0."""
    value = np.zeros(len(medium))
    for k, rows in rows_by_value(medium):
        value[rows] = scene.media[k].phase.eval(take_rows(wi, rows), take_rows(wo, rows))
    return value


def phase_sample(scene: Scene, medium: np.ndarray, wi: np.ndarray,
                 u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Directions (n, 3) and pdfs (n,) sampled from each row's phase function."""
    wo, pdf = np.zeros((len(medium), 3)), np.zeros(len(medium))
    for k, rows in rows_by_value(medium):
        wo_k, pdf[rows] = scene.media[k].phase.sample(take_rows(wi, rows), take_rows(u, rows))
        put_rows(wo, rows, wo_k)
    return wo, pdf


def scattering_albedo(scene: Scene, medium: np.ndarray, x: np.ndarray) -> np.ndarray:
    """The factor (n, 3) of a spatially varying albedo at scattering points ``x`` (n, 3) in
    ``medium`` (n,), all >= 0: the albedo volume's value in homogeneous media that have one,
    1 elsewhere (the free flight's weight holds the constant albedos)."""
    factor = np.ones((len(medium), 3))
    if all(getattr(m, "albedo_volume", None) is None for m in scene.media):
        return factor
    for k, rows in rows_by_value(medium):
        volume = getattr(scene.media[k], "albedo_volume", None)
        if volume is not None:
            put_rows(factor, rows, volume.eval(take_rows(x, rows)))
    return factor


def samples_emitters(scene: Scene, medium: np.ndarray) -> np.ndarray:
    """True (n,) where next-event estimation is done from inside ``medium`` (n,), all >= 0."""
    table = np.array([m.sample_emitters for m in scene.media], dtype=bool)
    return table[medium]


def null_transmission(scene: Scene, hit, d: np.ndarray) -> np.ndarray:
    """What shadow rays along ``d`` keep crossing the (valid) hits -> (n, 3).

    1 through ``null`` BSDFs, ``(1 - r)`` times the transmittance through a
    ``thindielectric`` (Mitsuba's ``eval_null_transmission``), 0 through any other.
    """
    return _null_transmission(scene, hit, np.arange(len(d)), d)


def _null_transmission(scene: Scene, hit, rows: np.ndarray, d: np.ndarray) -> np.ndarray:
    """:func:`null_transmission` at the hits ``rows`` of ``hit`` (``d``: one per row), read
    from the batch in place."""
    out = np.zeros((len(rows), 3))
    ids = scene.shape_bsdf[hit.shape[rows]]
    for b, sel in rows_by_value(ids):
        bsdf = scene.bsdfs[b]
        if not getattr(bsdf, "null_lobe", False):
            continue
        if bsdf.textured:
            bsdf = bsdf.at(intersect.texture_uv(scene, hit, rows[sel]))
        sh_n = np.take(hit.sh_n, rows[sel], axis=0)
        put_rows(out, sel, bsdf.eval_null_transmission(dot(sh_n, take_rows(d, sel))))
    return out


def null_event(scene: Scene, hit, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
    """True (n,) where the sampled ``wo`` crossed the surface through a null lobe (a
    ``null`` BSDF, a ``thindielectric``'s straight transmission): not a scattering event."""
    table = np.array([getattr(b, "null_lobe", False) for b in scene.bsdfs], dtype=bool)
    crossed = dot(hit.sh_n, wi) * dot(hit.sh_n, wo) < 0
    return table[scene.shape_bsdf[hit.shape]] & crossed


def next_medium(scene: Scene, hit, medium: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Medium (n,) of rays leaving the (valid) hits along ``d``.

    On a medium transition: the exterior medium if ``d`` leaves along the
    geometric normal, else the interior one; elsewhere ``medium`` is kept.
    """
    interior = getattr(scene, "shape_interior", None)
    if interior is None or not len(hit.shape):
        return medium
    # Each side's medium gathered once (np.take: faster than fancy indexing)
    inside, outside = np.take(interior, hit.shape), np.take(scene.shape_exterior, hit.shape)
    transition = (inside >= 0) | (outside >= 0)
    target = np.where(dot(hit.n, d) > 0, outside, inside)
    return np.where(transition, target, medium)


def shadow_transmittance(scene: Scene, p: np.ndarray, n: np.ndarray, wo: np.ndarray,
                         dist: np.ndarray, medium: np.ndarray, channel: np.ndarray,
                         rng, counter: int) -> np.ndarray:
    """Estimate the transmittance (n, 3) from ``p`` to the light ``dist`` away along ``wo``.

    Parameters
    ----------
    p, n : (n, 3) start points and their geometric normals (zeros for points
        inside a medium, which are not offset).
    wo, dist : (n, 3) unit directions and (n,) distances (inf: the environment
        or a directional light).
    medium : (n,) medium the shadow ray starts in; channel : (n,) the path's channel
        (:data:`MIXTURE`: flights from the channels' mixture, ``T / mean_k T_k`` past a segment).
    rng : RandomStream of these rows; the k-th step draws at counter ``counter + k``
        (so that the numbers a path sees do not depend on the rest of its batch).

    Each step goes to the next surface or, in a heterogeneous medium, to the next
    tentative collision. Delta tracking in each homogeneous medium segment (0 on a
    collision, ``T / T_c`` otherwise), ratio tracking in heterogeneous media (each
    tentative collision multiplies by ``sigma_n / majorant``), times the null
    transmission of every surface crossed.
    """
    o, d, remaining = _shadow_rays(p, n, wo, dist)
    result = np.zeros((len(p), 3))
    # The live rays' own arrays, compacted as rays end; a ray's estimate goes to its row of
    # ``result`` once, when it ends. ``rows``: the live rays' rows of the arguments (and rng).
    rows, value = np.arange(len(p)), np.ones((len(p), 3))
    tracking = has_heterogeneous(scene)
    hit = None
    for k in range(MAX_STEPS):
        if hit is None:
            hit = intersect.intersect(scene, o, d, remaining)
        t_surface = np.where(hit.valid, hit.t, remaining)
        scattered = collided = None
        inside = np.flatnonzero(medium >= 0)
        if len(inside):      # rays in vacuum reach the surface with weight 1: no flight
            whole = len(inside) == len(rows)
            inside = slice(None) if whole else inside
            u = rng.numbers(counter + k, index=rows[inside])
            flight = sample_free_flight(scene, medium[inside], channel[inside], t_surface[inside], u)
            if tracking:
                track_heterogeneous(scene, flight, medium[inside], o[inside], d[inside],
                                    t_surface[inside], u, None)
            factor = np.where(flight.scattered[:, None], 0.0, flight.weight)
            if whole:
                value *= factor
            else:
                multiply_rows(value, inside, factor)
            scattered = _rows_of(flight.scattered, inside, np.zeros(len(rows), bool))
            if flight.null is not None:
                collided = _rows_of(flight.null, inside, np.zeros(len(rows), bool))
                t_surface = _rows_of(flight.t, inside, t_surface)
        through = hit.valid if scattered is None else hit.valid & ~scattered
        if collided is not None:
            through = through & ~collided
        live = np.flatnonzero(through)
        if len(live):
            multiply_rows(value, live, _null_transmission(scene, hit, live, np.take(d, live, axis=0)))
        goes_on = through if collided is None else through | collided
        goes_on = goes_on & any_row(value > 0)
        keep = np.flatnonzero(goes_on)
        if len(keep) < len(rows):
            ends = np.flatnonzero(~goes_on)
            put_rows(result, rows[ends], np.take(value, ends, axis=0))
        if not len(keep):
            return result
        rows, value, d, channel, medium = (np.take(a, keep, axis=0)
                                           for a in (rows, value, d, channel, medium))
        moved = None if collided is None else collided[keep]
        if moved is None or not moved.any():     # every ray crossed a surface: trace again from each
            p_k, n_k, t_k = (np.take(a, keep, axis=0) for a in (hit.p, hit.n, hit.t))
            medium = next_medium(scene, SimpleNamespace(shape=hit.shape[keep], n=n_k), medium, d)
            o = intersect.offset_p(p_k, n_k, d)
            remaining = remaining[keep] - t_k
            hit = None
            continue
        # Collisions in a heterogeneous medium move the origin along the ray; their next
        # surface stays the one found (closer by t), as Mitsuba keeps its intersection.
        hit_k = _take(hit, keep)
        crossed, t_collision, o = through[keep], t_surface[keep], np.take(o, keep, axis=0)
        remaining = remaining[keep] - np.where(crossed, hit_k.t, t_collision)
        c = np.flatnonzero(crossed)
        hc, d_c = _take(hit_k, c), np.take(d, c, axis=0)
        medium[c] = next_medium(scene, hc, medium[c], d_c)
        put_rows(o, c, intersect.offset_p(hc.p, hc.n, d_c))
        m = np.flatnonzero(moved)
        put_rows(o, m, np.take(o, m, axis=0) + t_collision[m, None] * np.take(d, m, axis=0))
        hit_k.t[m] -= t_collision[m]
        if len(c):
            _put(hit_k, c, intersect.intersect(scene, np.take(o, c, axis=0), d_c, remaining[c]))
        hit = hit_k
    return result        # more steps than any sensible scene has: give up, 0 (counted)


def _shadow_rays(p: np.ndarray, n: np.ndarray, wo: np.ndarray, dist: np.ndarray):
    """Origins, directions and lengths of shadow rays from ``p`` (normals ``n``) along ``wo``
    to points ``dist`` away (inf: unbounded), as :func:`~.intersect.spawn_ray_to` spawns them."""
    finite = np.isfinite(dist)
    if finite.all():     # area and point lights: no masks
        return intersect.spawn_ray_to(p, n, p + wo * dist[:, None])
    o, d, remaining = np.empty_like(p), wo.copy(), np.full(len(p), np.inf)
    if finite.any():
        target = p[finite] + wo[finite] * dist[finite, None]
        o[finite], d[finite], remaining[finite] = intersect.spawn_ray_to(p[finite], n[finite], target)
    o[~finite] = intersect.offset_p(p[~finite], n[~finite], wo[~finite])
    return o, d, remaining


def _rows_of(values: np.ndarray, rows, base: np.ndarray) -> np.ndarray:
    """``base`` with its ``rows`` (indices, or ``slice(None)``: all) replaced by ``values``;
    ``base`` itself is left as it was."""
    if isinstance(rows, slice):
        return values
    out = base.copy()
    out[rows] = values
    return out


#: Steps (surfaces crossed and tentative collisions in heterogeneous media) a shadow ray may
#: take before it is declared blocked: the counters a segment has left after SLOT_SHADOW.
MAX_STEPS = 496


def _take(hit, rows):
    return type(hit)(**{k: np.take(v, rows, axis=0) for k, v in vars(hit).items()})


def _put(hit, rows, new) -> None:
    """Rows ``rows`` of ``hit`` replaced by the hits ``new``."""
    for k, v in vars(hit).items():
        put_rows(v, rows, getattr(new, k))


@register("medium", "homogeneous")
def create(props: Props) -> HomogeneousMedium:
    """The :class:`HomogeneousMedium` of a ``<medium type="homogeneous">`` element.

    Mitsuba 3's ``homogeneous`` medium takes ``sigma_t`` (extinction) and
    ``albedo`` (single-scattering albedo), each a ``<float>``, an ``<rgb>`` or a
    ``<spectrum>``, and ``scale`` multiplying ``sigma_t``. An ``<rgb>`` sigma_t must
    lie in [0, 1] (Mitsuba reads it as a reflectance); larger extinctions are
    written with ``scale``. ``sigma_a`` / ``sigma_s`` are Mitsuba 0.6's parameters,
    which Mitsuba 3 refuses; the error says the equivalent ``sigma_t`` and ``albedo``.
    """
    plugin = props.plugin
    albedo_volume = None
    for name, child in plugin.named_children():
        if child.kind != "volume":
            continue
        if name != "albedo" or albedo_volume is not None or props.has("albedo"):
            raise child.error("a homogeneous medium reads one <volume>, its albedo: for a "
                              "varying sigma_t write <medium type=\"heterogeneous\">")
        albedo_volume = child
    kids = children(plugin, {"phase": 1, "volume": 1})
    if props.has("sigma_a") or props.has("sigma_s"):
        raise _mitsuba06_coefficients(plugin, props)
    sigma_t = props.color("sigma_t", 1.0)
    if props.has("sigma_t") and plugin.props["sigma_t"].tag == "rgb" and not np.all(
            (sigma_t >= 0) & (sigma_t <= 1)):
        raise plugin.error("an <rgb> sigma_t must lie in [0, 1] (Mitsuba reads it as a "
                           "reflectance); give the extinction's colour there and its "
                           "magnitude in <float name=\"scale\">", props.line("sigma_t"))
    if not np.all(sigma_t >= 0):
        raise plugin.error("sigma_t must be >= 0", props.line("sigma_t"))
    albedo = props.reflectance("albedo", 0.75) if albedo_volume is None else np.ones(3)
    scale = props.float("scale", 1.0)
    if not (np.isfinite(scale) and scale >= 0):
        raise plugin.error(f"scale must be a finite number >= 0, got {scale}", props.line("scale"))
    sample_emitters = props.bool("sample_emitters", True)
    if not props.bool("has_spectral_extinction", True) and np.ptp(sigma_t) > 0:
        raise plugin.error("has_spectral_extinction=false with a coloured sigma_t is not "
                           "supported (Mitsuba then samples distances with the wrong "
                           "weights); leave it true", props.line("has_spectral_extinction"))
    props.finish()
    phase = build_phase(kids["phase"][0]) if kids["phase"] else IsotropicPhase()
    if albedo_volume is not None:
        albedo_volume = build_volume(albedo_volume, props.folders)
    return HomogeneousMedium(sigma_t * scale, albedo, phase, sample_emitters,
                             name=f"homogeneous ({plugin.file}:{plugin.line})",
                             albedo_volume=albedo_volume)


def _mitsuba06_coefficients(plugin: Plugin, props: Props):
    """The error for Mitsuba 0.6's sigma_a / sigma_s, with the Mitsuba 3 equivalent."""
    name = "sigma_a" if props.has("sigma_a") else "sigma_s"
    text = ""
    if props.has("sigma_a") and props.has("sigma_s"):
        sigma_a, sigma_s = props.color("sigma_a", 0.0, "unbounded"), props.color("sigma_s", 0.0, "unbounded")
        total = sigma_a + sigma_s
        albedo = np.where(total > 0, sigma_s / np.where(total > 0, total, 1), 0)
        text = (f": sigma_t = sigma_a + sigma_s = {', '.join(f'{v:g}' for v in total)}, "
                f"albedo = sigma_s / sigma_t = {', '.join(f'{v:.6g}' for v in albedo)}")
    return plugin.error(f"\"{name}\" is Mitsuba 0.6's; Mitsuba 3's homogeneous medium takes "
                        f"sigma_t and albedo{text}", props.line(name))
