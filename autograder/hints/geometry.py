"""Geometric evidence for the direct-light hints: which quantity the error follows.

A mistake in one factor of the shadow ray's estimate ``Le f cos_s / p_light`` scales each
pixel's direct light by a function of that pixel's geometry: dropping the cosine at the light
by ``1 / cos_l``, dropping the distance squared by ``d^2``, the receiver's cosine in the
light pdf by ``cos_s / cos_l``, a BSDF evaluated with its arguments swapped by
``cos_v / cos_s`` (the cosine towards the camera where the light's belongs), a cosine counted
twice by ``cos_s``. A mistake in the choice of one of several lights scales each light's
share by its own constant. The rules of :mod:`autograder.hints.sweep` name such a cause only
when the 8x8 tiles' ratio of what max_depth = 2 adds follows its quantity (a rank correlation
of at least :data:`FOLLOWS`, clearly above every other candidate's) or, for the light choice,
when two constants, one per light, explain the tiles.

Geometry is measured at the first hit of each pixel centre's camera ray (no render): the
point, its normal, and a point on each light (the middle of its sample space).
"""
from __future__ import annotations

import numpy as np

from mitsuba_refs.verdicts.scenes import default_params
from pathtracer import load_scene
from pathtracer.core.color import LUMINANCE
from pathtracer.emitters.scene_emitters import sample_emitter
from pathtracer.sensors.perspective import camera_rays
from pathtracer.shapes.intersect import intersect

#: Rank correlation (Spearman) of the tiles' ratio with a candidate's quantity that counts as
#: following it, and the margin by which it must beat every other candidate.
FOLLOWS = 0.7
MARGIN = 0.15
#: Share of the tiles' spread (of the ratio) the per-light constants must explain (the shares
#: are those of the irradiance; a glossy surface and the sweep's noise leave the rest).
PER_LIGHT = 0.6
#: Light samples per pixel for the per-light shares.
SHARE_SAMPLES = 16

#: Candidate quantity -> (what it is, in words; the cause it names).
CANDIDATES = {
    "inv_cos_light": ("1 / cos theta at the light", "light_pdf_cosine"),
    "distance2": ("the squared distance to the light", "light_pdf_distance"),
    "cos_surface_over_cos_light": ("cos theta at the surface / cos theta at the light",
                                   "light_pdf_cosine"),
    "cos_view_over_cos_surface": ("cos theta towards the camera / cos theta towards the light",
                                  "bsdf_eval"),
    "cos_surface": ("cos theta towards the light at the surface", "bsdf_eval"),
}


def _first_hits(check):
    scene = load_scene(check.scene, **default_params(check.scene))
    camera = scene.camera
    w, h = camera.width, camera.height
    pixel = np.arange(w * h)
    rays = camera_rays(camera, pixel, np.full((w * h, 2), 0.5))
    return scene, rays, intersect(scene, rays.o, rays.d, rays.tmax), (h, w)


def pixel_geometry(check) -> dict:
    """Per-pixel (H, W) logs of each candidate quantity towards the scene's first light, and
    ``valid`` (a first hit that sees that light point); NaN where undefined."""
    scene, rays, hit, shape = _first_hits(check)
    n = len(rays.d)
    light = sample_emitter(scene, hit, np.zeros(n), np.full((n, 2), 0.5), test_visibility=False,
                           emitter=0)
    emitter = scene.emitters[0]
    area = scene.shape_area[emitter.shape] if emitter.kind == "area" else np.nan
    with np.errstate(divide="ignore", invalid="ignore"):
        cos_l = np.clip(light.dist ** 2 / (light.pdf * area), 1e-6, 1.0)
        cos_s = np.abs(np.sum(hit.sh_n * light.wo, axis=1))
        cos_v = np.abs(np.sum(hit.sh_n * -rays.d, axis=1))
        facing = np.sum(hit.n * light.wo, axis=1) * np.sum(hit.n * -rays.d, axis=1) > 0
        valid = hit.valid & facing & (light.pdf > 0) & np.isfinite(light.dist) & (cos_s > 1e-3)
        logs = dict(inv_cos_light=-np.log(cos_l), distance2=2 * np.log(light.dist),
                    cos_surface_over_cos_light=np.log(cos_s / cos_l),
                    cos_view_over_cos_surface=np.log(np.maximum(cos_v, 1e-6) / cos_s),
                    cos_surface=np.log(cos_s))
    out = {k: np.where(valid, v, np.nan).reshape(shape) for k, v in logs.items()}
    out["valid"] = valid.reshape(shape)
    return out


def light_shares(check) -> np.ndarray:
    """(K, H, W): each light's share of the direct irradiance at each pixel's first hit
    (visibility included; SHARE_SAMPLES points per light)."""
    scene, rays, hit, shape = _first_hits(check)
    n, k = len(rays.d), scene.num_emitters
    rng = np.random.default_rng(1)
    irradiance = np.zeros((k, n))
    for e in range(k):
        for _ in range(SHARE_SAMPLES):
            s = sample_emitter(scene, hit, np.zeros(n), rng.random((n, 2)), emitter=e)
            cos = np.abs(np.sum(hit.sh_n * s.wo, axis=1))
            irradiance[e] += (s.weight @ LUMINANCE) * cos * hit.valid
    total = irradiance.sum(axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        share = np.where(total > 0, irradiance / total, np.nan)
    return share.reshape(k, *shape)


def tiles(field, tile=8, weights=None) -> np.ndarray:
    """Mean of ``field`` (H, W) over each 8x8 tile (flattened), weighted, NaNs left out."""
    h, w = (field.shape[0] // tile) * tile, (field.shape[1] // tile) * tile
    f = field[:h, :w].reshape(h // tile, tile, w // tile, tile)
    wt = np.ones_like(f) if weights is None else weights[:h, :w].reshape(f.shape)
    wt = np.where(np.isfinite(f), wt, 0.0)
    total = wt.sum(axis=(1, 3))
    with np.errstate(invalid="ignore", divide="ignore"):
        return (np.where(np.isfinite(f), f, 0.0) * wt).sum(axis=(1, 3)).ravel() / total.ravel()


def _rank(x) -> np.ndarray:
    order = np.argsort(x)
    r = np.empty(len(x))
    r[order] = np.arange(len(x))
    return r


def spearman(a, b) -> float:
    """Rank correlation of a and b over their finite pairs (NaN for fewer than 6)."""
    ok = np.isfinite(a) & np.isfinite(b)
    if ok.sum() < 6 or np.ptp(a[ok]) == 0 or np.ptp(b[ok]) == 0:
        return float("nan")
    return float(np.corrcoef(_rank(a[ok]), _rank(b[ok]))[0, 1])


def followed(ratio, keep, geometry, weights) -> tuple:
    """(best candidate or None, {candidate: rank correlation}) of the tiles' ratio (over the
    tiles ``keep``) with each candidate quantity (tile means weighted by ``weights``)."""
    corr = {}
    log_ratio = np.log(np.maximum(ratio, 1e-6))
    for name in CANDIDATES:
        corr[name] = spearman(log_ratio, tiles(geometry[name], weights=weights)[keep])
    ranked = sorted((c, n) for n, c in corr.items() if np.isfinite(c))
    if not ranked:
        return None, corr
    best, name = ranked[-1]
    others = [c for c, n in ranked[:-1]
              if CANDIDATES[n][1] != CANDIDATES[name][1]]     # same cause: no competitor
    if best >= FOLLOWS and all(best - c >= MARGIN for c in others):
        return name, corr
    return None, corr


def per_light_fit(added_test, added_ref, keep, shares, weights) -> tuple:
    """Least-squares constants a_k with test ~ sum_k a_k ref share_k over the tiles ``keep``,
    and the share of the tiles' ratio spread they explain: (a, explained)."""
    columns = np.stack([added_ref[keep] * tiles(s, weights=weights)[keep] for s in shares], 1)
    ok = np.all(np.isfinite(columns), axis=1)
    if ok.sum() < 2 * len(shares):
        return None, 0.0
    a, *_ = np.linalg.lstsq(columns[ok], added_test[keep][ok], rcond=None)
    ratio = added_test[keep][ok] / added_ref[keep][ok]
    fitted = columns[ok] @ a / added_ref[keep][ok]
    spread = ratio.var()
    explained = 1 - (ratio - fitted).var() / spread if spread > 0 else 0.0
    return a, float(explained)
