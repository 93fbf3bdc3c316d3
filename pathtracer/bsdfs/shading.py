"""Evaluate and sample the BSDFs at a batch of hits, in world space.

Each hit's BSDF is ``scene.bsdfs[scene.shape_bsdf[hit.shape]]``. Hits are
grouped by BSDF (BSDFs that differ only in constant colours share a group) so
that every BSDF object works on one contiguous batch in its local shading
frame (z = shading normal); directions go in and out of that
frame here, so integrators never see local coordinates. A BSDF with a
texture is bound to its hits' texture coordinates first (:meth:`BSDF.at
<pathtracer.bsdfs.base.BSDF.at>`); constant BSDFs are used as they are.

The grouping of the last hit batch is kept (per thread, keyed by the scene and a weak
reference to the batch, :func:`_groups`), because an integrator asks several questions of
the same hits (``has_smooth`` and ``eval_bsdf`` for a shadow ray, then ``sample_bsdf``)
and grouping costs as much as a simple BSDF's evaluation. It stays a cache rather than
state an integrator passes or the batch carries, because these functions' signature
``(scene, hit, ...)`` is the students' contract (submissions and the bug zoo call and
replace them with exactly these arguments), and a hit batch is a dataclass of arrays that
:func:`~pathtracer.integrators.wavefront.subset_hit` and the submissions copy field by
field, so an attribute on it would travel into every copy. It is exact because a batch is
never changed in place once traced (subsets and replacements make new batches), and a
batch that cannot be weakly referenced is simply not cached.
"""
from __future__ import annotations

import copy
import threading
import weakref
from dataclasses import dataclass

import numpy as np

from ..core.vec import frame, put_rows, scale, select, take_rows, to_local, to_world
from ..scene.types import Scene
from ..shapes.intersect import texture_uv
from ..shapes.tangents import local_geometry
from .diffuse import hemisphere_sampling
from .tangent_frame import InTangentFrame


@dataclass
class ScatterSample:
    """A sampled continuation, world space.

    Attributes
    ----------
    wo : (n, 3) unit direction of the new ray.
    weight : (n, 3) f cos / pdf (the Dirac weight for specular lobes).
    pdf : (n,) solid-angle pdf (the lobe-choice probability for Dirac lobes).
    delta : (n,) bool, True where a Dirac lobe was sampled.
    eta : (n,) relative index of refraction crossed (1 for reflection).
    """

    wo: np.ndarray
    weight: np.ndarray
    pdf: np.ndarray
    delta: np.ndarray
    eta: np.ndarray


def bsdf_index(scene: Scene, hit) -> np.ndarray:
    """Index into ``scene.bsdfs`` of every hit (hits must be valid)."""
    return scene.shape_bsdf[hit.shape]


def _groups(scene: Scene, hit) -> list:
    """(BSDF, rows) per group of hits that one BSDF object can evaluate (see :func:`_grouping`).

    The last grouping is kept: next-event estimation and BSDF sampling at the same
    hits (one batch object) group them once.
    """
    last = getattr(_last_grouping, "key", None)
    if last is not None and last[0] is scene and last[1]() is hit:
        return _last_grouping.groups
    groups = list(_grouping(scene, hit))
    try:
        _last_grouping.key = (scene, weakref.ref(hit))
    except TypeError:   # a batch type without weak references (a plain namespace): not kept
        _last_grouping.key = None
    _last_grouping.groups = groups
    return groups


_last_grouping = threading.local()


def _grouping(scene: Scene, hit):
    """(BSDF, rows) per group of hits that one BSDF object can evaluate.

    BSDFs of one class whose parameters differ only in constant colours (the
    walls of a room: diffuse white, red, green) form one group, evaluated by a
    copy whose colours are per-row (n, 3) arrays: one pass over the hits
    instead of one per BSDF, and the same numbers (a (3,) colour and its rows
    broadcast alike). A textured BSDF comes bound to its rows' uv. ``rows`` is
    ``slice(None)`` when the group holds every hit (no gathers, no scatters).
    """
    ids = bsdf_index(scene, hit)
    present = np.flatnonzero(np.bincount(ids, minlength=len(scene.bsdfs)))
    groups: dict = {}
    for b in present.tolist():
        groups.setdefault(_merge_key(scene.bsdfs[b], b), []).append(b)
    for members in groups.values():
        if len(members) == len(present):
            rows = slice(None)
        elif len(members) == 1:
            rows = np.flatnonzero(ids == members[0])
        else:
            member = np.zeros(len(scene.bsdfs), bool)
            member[members] = True
            rows = np.flatnonzero(member[ids])
        bsdf = scene.bsdfs[members[0]]
        if len(members) > 1:
            bsdf = _merged(scene, members, ids[rows])
        else:
            bsdf = _bound(scene, hit, bsdf, np.arange(len(ids))[rows])
        yield bsdf, rows


def _bound(scene: Scene, hit, bsdf, rows: np.ndarray):
    """``bsdf`` ready for the hits ``rows``: bound to their uv (and, for normal and bump
    maps, their differential geometry) if textured; turned into Mitsuba's tangent frame
    (dp/du) if anisotropic. Plain isotropic BSDFs are returned as they are."""
    anisotropic = bsdf.anisotropic
    if not (bsdf.textured or anisotropic):
        return bsdf
    geometry = local_geometry(scene, hit, rows) if bsdf.needs_geometry or anisotropic else None
    if bsdf.textured:
        bsdf = bsdf.at(texture_uv(scene, hit, rows), geometry)
    return InTangentFrame(bsdf, geometry.tangent) if anisotropic else bsdf


_PLAIN = (bool, int, float, complex, str, type(None))


def _merge_key(bsdf, index: int):
    """Hashable key equal for BSDFs that one merged copy can stand for (see :func:`_groups`).

    The class and every attribute except the colour parameters; a BSDF with a
    texture or an attribute that is not a plain value or array keeps its own group.
    """
    if bsdf.textured:
        return ("own", index)
    items = []
    for name, value in sorted(vars(bsdf).items()):
        if name in bsdf.texture_params:
            continue
        if isinstance(value, np.ndarray):
            items.append((name, value.dtype.str, value.shape, value.tobytes()))
        elif isinstance(value, _PLAIN):
            items.append((name, value))
        else:
            return ("own", index)
    return (type(bsdf), tuple(items))


def _merged(scene: Scene, members: list, ids: np.ndarray):
    """A copy of ``scene.bsdfs[members[0]]`` whose colours are the rows' own, (n, 3)."""
    first = scene.bsdfs[members[0]]
    bound = copy.copy(first)
    slot = np.zeros(len(scene.bsdfs), np.int64)
    slot[members] = np.arange(len(members))
    which = slot[ids]
    for name in first.texture_params:
        table = np.stack([np.broadcast_to(getattr(scene.bsdfs[b], name), (3,)) for b in members])
        setattr(bound, name, np.take(table, which, axis=0))
    return bound


def has_smooth(scene: Scene, hit) -> np.ndarray:
    """True where the hit's BSDF has a non-Dirac lobe (next-event estimation applies)."""
    table = np.array([bsdf.has_smooth for bsdf in scene.bsdfs], dtype=bool)
    return table[bsdf_index(scene, hit)]


def is_delta(scene: Scene, hit) -> np.ndarray:
    """True where every lobe of the hit's BSDF is a Dirac delta (mirror, glass)."""
    table = np.array([bsdf.is_delta for bsdf in scene.bsdfs], dtype=bool)
    return table[bsdf_index(scene, hit)]


def eval_bsdf(scene: Scene, hit, wi: np.ndarray, wo: np.ndarray,
              hemisphere: str = "cosine", adjoint: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """BSDF value f cos(theta_o) and sampling pdf for world directions.

    Parameters
    ----------
    wi : (n, 3) unit direction towards the previous vertex (the camera side).
    wo : (n, 3) unit direction towards the next vertex (e.g. the light).
    hemisphere : {'cosine', 'uniform'}
        Diffuse sampling strategy whose pdf is returned
        (:func:`~pathtracer.bsdfs.diffuse.hemisphere_sampling`).
    adjoint : bool
        Importance transport (paths from the lights: ``wi`` towards the light side,
        ``wo`` towards the camera side), Mitsuba's ``TransportMode::Importance``: a
        refraction carries no ``1/eta'^2`` radiance scaling (:func:`importance_scale`).
    """
    with hemisphere_sampling(hemisphere):
        return _eval_bsdf(scene, hit, wi, wo, adjoint)


def _eval_bsdf(scene: Scene, hit, wi: np.ndarray, wo: np.ndarray, adjoint: bool):
    """:func:`eval_bsdf` inside its ``hemisphere_sampling`` block."""
    groups = _groups(scene, hit)
    if len(groups) == 1 and isinstance(groups[0][1], slice):   # one group: no scatters
        bsdf, _ = groups[0]
        wi_local, wo_local = _local_pair(hit.sh_n, wi, wo)
        value = _own(bsdf.eval(wi_local, wo_local), np.float64)
        if adjoint and bsdf.refracts:
            value *= importance_scale(bsdf, wi_local, wo_local)[:, None]
        return value, _own(bsdf.pdf(wi_local, wo_local), np.float64)
    value = np.zeros((len(wi), 3))
    pdf = np.zeros(len(wi))
    for bsdf, rows in groups:
        wi_local, wo_local = _local_pair(take_rows(hit.sh_n, rows), take_rows(wi, rows), take_rows(wo, rows))
        f = np.asarray(bsdf.eval(wi_local, wo_local), np.float64)
        if adjoint and bsdf.refracts:
            f = f * importance_scale(bsdf, wi_local, wo_local)[:, None]
        put_rows(value, rows, f)
        pdf[rows] = bsdf.pdf(wi_local, wo_local)
    return value, pdf


def _local_pair(n, a, b):
    """Two sets of world vectors in the shading frames around ``n`` (the frame built once)."""
    columns = frame(n)
    return to_local(a, n, columns), to_local(b, n, columns)


def _own(values, dtype) -> np.ndarray:
    """``values`` as a writeable array of ``dtype`` (what the scattering path returns)."""
    out = np.asarray(values, dtype=dtype)
    return out if out.flags.writeable and out.base is None else out.copy()


def importance_scale(bsdf, wi_local: np.ndarray, wo_local: np.ndarray) -> np.ndarray:
    """``eta'^2`` on refraction (``wi``, ``wo`` on opposite sides), 1 on reflection (n,).

    The radiance a BSDF returns is scaled by ``1/eta'^2`` when it refracts (``eta' =
    eta`` entering, ``1/eta`` leaving, seen from ``wi``): radiance is compressed into the
    smaller solid angle of the denser side. Importance is not, so the adjoint BSDF
    undoes the factor.
    """
    crossing = wi_local[:, 2] * wo_local[:, 2] < 0
    eta_seen = np.where(wi_local[:, 2] > 0, bsdf.eta, 1.0 / bsdf.eta)
    return np.where(crossing, eta_seen * eta_seen, 1.0)


def sample_bsdf(scene: Scene, hit, wi: np.ndarray, u1: np.ndarray, u2: np.ndarray,
                hemisphere: str = "cosine", adjoint: bool = False) -> ScatterSample:
    """Sample a continuation direction at every hit (see :class:`ScatterSample`).

    ``hemisphere``: how diffuse lobes are sampled (see :func:`eval_bsdf`). ``adjoint``:
    importance transport (see :func:`eval_bsdf`); the weight of a refraction is multiplied
    by ``bs.eta^2`` = ``eta'^2``, which undoes the radiance scaling.
    """
    with hemisphere_sampling(hemisphere):
        return _sample_bsdf(scene, hit, wi, u1, u2, adjoint)


def _sample_bsdf(scene: Scene, hit, wi: np.ndarray, u1: np.ndarray, u2: np.ndarray,
                 adjoint: bool) -> ScatterSample:
    """:func:`sample_bsdf` inside its ``hemisphere_sampling`` block."""
    groups = _groups(scene, hit)
    if len(groups) == 1 and isinstance(groups[0][1], slice):   # one group: no scatters
        bsdf, _ = groups[0]
        n = hit.sh_n
        columns = frame(n)
        bs = bsdf.sample(to_local(wi, n, columns), u1, u2)
        out = ScatterSample(to_world(bs.wo, n, columns),
                            select(bs.valid, bs.weight),
                            np.where(bs.valid, bs.pdf, 0.0).astype(np.float64, copy=False),
                            _own(bs.delta, bool), np.where(bs.valid, bs.eta, 1.0))
    else:
        count = len(wi)
        out = ScatterSample(np.zeros((count, 3)), np.zeros((count, 3)), np.zeros(count),
                            np.zeros(count, dtype=bool), np.ones(count))
        for bsdf, rows in groups:
            n = take_rows(hit.sh_n, rows)
            columns = frame(n)
            bs = bsdf.sample(to_local(take_rows(wi, rows), n, columns), take_rows(u1, rows),
                             take_rows(u2, rows))
            put_rows(out.wo, rows, to_world(bs.wo, n, columns))
            put_rows(out.weight, rows, select(bs.valid, bs.weight))
            out.pdf[rows] = np.where(bs.valid, bs.pdf, 0.0)
            out.delta[rows] = bs.delta
            out.eta[rows] = np.where(bs.valid, bs.eta, 1.0)
    if adjoint:
        out.weight = scale(out.weight, out.eta * out.eta)
    return out


@dataclass
class DielectricLobes:
    """Both Dirac lobes of a smooth dielectric, world space.

    Attributes
    ----------
    F : (n,) Fresnel reflectance.
    wo_r, wo_t : (n, 3) reflected and refracted directions.
    weight_r : (n, 3) F times specular_reflectance.
    weight_t : (n, 3) (1 - F) times specular_transmittance times the 1/eta^2 radiance scaling.
    """

    F: np.ndarray
    wo_r: np.ndarray
    weight_r: np.ndarray
    wo_t: np.ndarray
    weight_t: np.ndarray


def dielectric_lobes(scene: Scene, hit, wi: np.ndarray) -> DielectricLobes:
    """Both lobes at hits whose BSDF is a smooth dielectric (for splitting estimators)."""
    count = len(wi)
    out = DielectricLobes(np.zeros(count), np.zeros((count, 3)), np.zeros((count, 3)),
                          np.zeros((count, 3)), np.zeros((count, 3)))
    for bsdf, rows in _groups(scene, hit):
        n = take_rows(hit.sh_n, rows)
        columns = frame(n)
        F, wo_r, weight_r, wo_t, weight_t = bsdf.lobes(to_local(take_rows(wi, rows), n, columns))
        out.F[rows] = F
        put_rows(out.wo_r, rows, to_world(wo_r, n, columns))
        put_rows(out.weight_r, rows, weight_r)
        put_rows(out.wo_t, rows, to_world(wo_t, n, columns))
        put_rows(out.weight_t, rows, weight_t)
    return out
