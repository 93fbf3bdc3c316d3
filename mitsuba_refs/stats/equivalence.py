r"""Within a tolerance or beyond it: the mean verdict's three outcomes at one look.

A tolerance :math:`T` (relative, e.g. 0.02) turns the mean test's question "is there any
difference?" into two, each with an error budget of its own at this look, ``alpha``:

*Beyond the tolerance* (DISAGREES). The null hypothesis is :math:`|r|\le T` for the image's
luminance relative bias :math:`r` *and* for every tile-channel's relative bias. Components,
each one-sided against the shifted nulls :math:`\mu_a = (1\pm T)\mu_b` and Bonferroni-combined:

* image: :math:`(\hat r - T)/\hat s_r` and :math:`(\hat r + T)/\hat s_r` with the delta-method
  standard error of :mod:`mitsuba_refs.stats.mean` (heavy-tail guard included);
* tiles: :func:`mitsuba_refs.stats.mean.tile_z` of the test against the reference scaled by
  :math:`1\pm T` (its variance by :math:`(1\pm T)^2`), per tile-channel, Bonferroni over
  tile-channels and the two directions;
* with ``max_var_ratio``: the bounded-variance components of the mean test, shifted alike
  (a heavy-tailed wrong estimator cannot hide behind its own variance).

Reject (DISAGREES) when the smallest Bonferroni-adjusted p-value is at most ``alpha``.
Under the null each one-sided test rejects with probability at most its share, so the
false-DISAGREES rate of a look is at most ``alpha`` whatever the bias inside :math:`\pm T`.

*Within the tolerance* (AGREES). Two one-sided tests (TOST) on the image's relative bias:
reject :math:`r\le -T` and :math:`r \ge T` each at level ``alpha``, i.e. the
:math:`1-2\alpha` interval :math:`\hat r \pm z_{1-\alpha}\hat s_r` lies inside
:math:`(-T, T)`; and no tile is beyond the tolerance (the first part did not reject). A
renderer whose true bias is :math:`\pm T` or worse AGREES with probability at most ``alpha``.
The per-region condition is "no region shown beyond T", not "every region shown within T":
tiles hold 1/64 to 1/1000 of the image's samples, and proving each of them within T would
need hundreds of times the samples; a localised error large enough to matter is caught by
the tiles' beyond-T test (docs/statistics.md, section 9).

Neither: undecided at this look. Pure functions on arrays returning numbers; the words are in
:mod:`mitsuba_refs.report.wording`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import special

from pathtracer.core.color import LUMINANCE

from ._tiles import as_count
from .correlation import INDEPENDENT
from .mean import MeanTestOptions, _checked_inputs, _image_means, tile_z

__all__ = ["ToleranceDecision", "decide_tolerance", "samples_to_decide",
           "AGREES", "DISAGREES", "UNDECIDED"]

AGREES, DISAGREES, UNDECIDED = "agrees", "disagrees", "undecided"


@dataclass(frozen=True)
class ToleranceDecision:
    """One look's outcome against a tolerance (numbers only).

    Attributes
    ----------
    outcome : str
        :data:`AGREES`, :data:`DISAGREES` or :data:`UNDECIDED`.
    tolerance, alpha : float
        The relative tolerance and this look's level (each side's).
    rel_bias, rel_se, rel_se_reference : float
        Luminance relative bias, its standard error, and the part of it due to the
        reference's own noise.
    interval : (float, float)
        The ``1 - 2 alpha`` interval of the relative bias (the TOST's).
    p_beyond : dict
        Bonferroni-adjusted p-value of each beyond-the-tolerance component.
    beyond_tiles : int
        Tiles shown beyond the tolerance.
    """

    outcome: str
    tolerance: float
    alpha: float
    rel_bias: float
    rel_se: float
    rel_se_reference: float
    interval: tuple
    p_beyond: dict = field(default_factory=dict)
    beyond_tiles: int = 0

    @property
    def p_value(self) -> float:
        """The beyond-the-tolerance family p-value (Bonferroni over components)."""
        values = list(self.p_beyond.values()) or [1.0]
        return min(1.0, len(values) * min(values))


def _norm_sf(z):
    return special.ndtr(-np.asarray(z, dtype=np.float64))


def _luminance_ratio(A, B, sa, sb):
    """Relative bias of luminance, its standard error and the reference's share of it."""
    C = A.shape[0]
    wts = LUMINANCE if C == 3 else np.full(C, 1.0 / C)
    YA, YB, sYA, sYB = (float(wts @ x) for x in (A, B, sa, sb))
    if not (YA > 0 and YB > 0):
        rel = 0.0 if YA == YB else (math.inf if YB == 0 else -1.0)
        return rel, (0.0 if YA == YB else math.nan), 0.0
    ratio = YA / YB
    return ratio - 1.0, ratio * math.hypot(sYA / YA, sYB / YB), ratio * sYB / YB


def _one_sided_family(z_up, z_down, informative=None) -> tuple[float, int]:
    """Bonferroni p of the largest one-sided excess over both directions, and the number
    of one-sided tests it was adjusted for."""
    up, down = _norm_sf(z_up), _norm_sf(-np.asarray(z_down))
    p = np.minimum(up, down)
    if informative is not None:
        p = np.where(informative, p, 1.0)
    tests = 2 * (int(np.count_nonzero(informative)) if informative is not None else p.size)
    return float(min(1.0, tests * float(p.min()))) if p.size and tests else 1.0, tests


def _tile_components(ma, va, na, mb, vb, nb, tolerance, share, options, bound):
    """Per-tile beyond-the-tolerance p (own variance and, with ``bound``, bounded)."""
    out, tiles = {}, {}
    up, down = 1.0 + tolerance, 1.0 - tolerance
    variants = [("tiles", va)] + ([("tiles, bounded variance", bound * vb)] if bound else [])
    for name, test_var in variants:
        z_up, inf_up = tile_z(ma, test_var * share, na, mb * up, vb * share * up * up, nb,
                              options.tile, rel_floor=options.rel_floor)
        z_dn, inf_dn = tile_z(ma, test_var * share, na, mb * down, vb * share * down * down, nb,
                              options.tile, rel_floor=options.rel_floor)
        informative = inf_up | inf_dn
        out[name], tests = _one_sided_family(z_up, z_dn, informative)
        tiles[name] = (z_up, z_dn, informative, tests)
    return out, tiles


def _bounded_image(A, B, sb, vb, na, npx, bound, tolerance, rel_floor):
    """Per-channel beyond-the-tolerance p with the test's variance bounded by ``bound``."""
    sab2 = bound * (np.maximum(vb, 0) / na).sum(axis=(0, 1)) / npx ** 2
    zs = []
    for factor in (1.0 + tolerance, 1.0 - tolerance):
        se = np.sqrt(sab2 + (factor * sb) ** 2 + (rel_floor * np.maximum(abs(A), abs(B))) ** 2)
        with np.errstate(divide="ignore", invalid="ignore"):
            zs.append(np.where(se > 0, (A - factor * B) / se, 0.0))
    return _one_sided_family(zs[0], zs[1])[0]


def decide_tolerance(test, reference, *, tolerance: float, alpha: float,
                     max_var_ratio: float | None = None, image_components: bool = True,
                     options: MeanTestOptions = MeanTestOptions()) -> ToleranceDecision:
    """Within ``tolerance``, beyond it, or undecided, at level ``alpha`` for each side.

    Parameters
    ----------
    test, reference : (mean, variance, n)
        Per-pixel means, unbiased per-sample variances and sample counts, as
        :func:`mitsuba_refs.stats.mean.compare_means` takes them (a = test, b = reference).
    tolerance : float
        Relative, in (0, 1).
    alpha, max_var_ratio, image_components, options
        As for :func:`~mitsuba_refs.stats.mean.compare_means`; ``alpha`` is each side's level.
        See the module notes.
    """
    (mean_a, var_a, n_a), (mean_b, var_b, n_b) = test, reference
    if not 0.0 < tolerance < 1.0:
        raise ValueError(f"tolerance must be in (0, 1) (relative), got {tolerance}")
    ma, va, mb, vb = _checked_inputs(mean_a, var_a, mean_b, var_b, alpha, max_var_ratio,
                                     int(options.tile))
    h, w, _ = ma.shape
    na = as_count(n_a, (h, w), "n_a")[..., None]
    nb = as_count(n_b, (h, w), "n_b")[..., None]
    A, B, sa, sb, _ = _image_means(ma, va, na, mb, vb, nb, options)
    rel, se, se_ref = _luminance_ratio(A, B, sa, sb)
    share = (options.pixel_correlation or INDEPENDENT).within_tile_share(int(options.tile))
    tile_bound = max_var_ratio if not image_components else None
    p_beyond, tiles = _tile_components(ma, va, na[..., 0], mb, vb, nb[..., 0], tolerance, share,
                                       options, tile_bound)
    if image_components and math.isfinite(se) and se > 0:
        z_hi, z_lo = (rel - tolerance) / se, (rel + tolerance) / se
        p_beyond["image"] = float(min(1.0, 2.0 * min(_norm_sf(z_hi), _norm_sf(-z_lo))))
    if image_components and max_var_ratio is not None:
        p_beyond["image, bounded variance"] = _bounded_image(A, B, sb, vb, na, h * w,
                                                             max_var_ratio, tolerance,
                                                             options.rel_floor)
    components = len(p_beyond)
    beyond = min(p_beyond.values()) * components <= alpha
    z_up, z_dn, informative, tests = tiles["tiles"]
    crit = crit_tile(alpha, components, tests)
    per_tile = informative & ((z_up > crit) | (z_dn < -crit))
    zq = float(special.ndtri(1.0 - alpha)) if math.isfinite(se) else math.nan
    interval = (rel - zq * se, rel + zq * se)
    within = bool(interval[0] > -tolerance and interval[1] < tolerance)
    outcome = DISAGREES if beyond else (AGREES if within else UNDECIDED)
    return ToleranceDecision(outcome, float(tolerance), float(alpha), float(rel), float(se),
                             float(se_ref), (float(interval[0]), float(interval[1])), p_beyond,
                             int(per_tile.any(axis=2).sum()) if per_tile.ndim == 3 else 0)


def crit_tile(alpha: float, components: int, tests: int) -> float:
    """One-sided critical z of one tile-channel test in the beyond-the-tolerance family."""
    return float(special.ndtri(1.0 - alpha / max(components, 1) / max(tests, 1)))


def samples_to_decide(decision: ToleranceDecision, spp: int, alpha_final: float) -> tuple:
    """Samples per pixel at which the observed relative bias would be decided, and whether
    the reference's own noise alone keeps it undecided.

    Plans with the observed bias as the truth and the test side's share of the standard
    error falling as 1/sqrt(spp); ``alpha_final`` is the level of the look that would decide.

    Returns
    -------
    (spp_needed, reference_limited) : (float, bool)
        ``math.inf`` when even infinitely many test samples would not decide: with True when
        the reference's noise is the reason, False when the observed bias is within a quarter
        of the tolerance of the tolerance itself (at the boundary nothing decides).
    """
    rel, se, se_ref, tol = decision.rel_bias, decision.rel_se, decision.rel_se_reference, \
        decision.tolerance
    if not (math.isfinite(rel) and math.isfinite(se)) or se <= 0:
        return math.inf, False
    gap = abs(abs(rel) - tol)
    side = alpha_final if abs(rel) < tol else alpha_final / 4.0
    z = float(special.ndtri(1.0 - side))
    room = (gap / z) ** 2 - se_ref ** 2
    own = max(se * se - se_ref * se_ref, 0.0)
    if room <= 0:
        # Either the reference's noise alone hides the gap, or the bias sits at the tolerance
        # (gap ~ 0: no budget decides it); only the first is the reference's doing.
        return math.inf, gap >= tol / 4.0
    return float(spp * own / room), False
