"""Rules on the per-bounce sweep: the first wrong max_depth, and what that bounce's error follows.

The sweep renders the student's integrator at max_depth = 1, 2, 3 against Mitsuba's per-bounce
references. A rule names a cause only where the sweep's evidence is specific to it:

* max_depth = 1 wrong: only emitters seen by the camera are in that image (the camera is the
  reference's in these checks): the emission seen directly;
* each max_depth = d rendering Mitsuba's d +- 1: the depth limit;
* max_depth = 2 (direct light) wrong: by a factor near pi, evenly (the 1/pi of rho/pi or of a
  cosine pdf); near 2, evenly, with shadow rays and no MIS (emission counted twice); near 1/N
  evenly with N lights (the light choice's 1/N); a tile pattern that two constants, one per
  light, explain (the light choice's pdf); a ratio that follows one factor of the shadow ray's
  estimate (:mod:`autograder.hints.geometry`); a loss that is never a gain, uneven, and
  follows none of them (shadow rays blocked); right where Mitsuba's direct light is, with
  extra light only where it has none (a two-sided emitter lights what is behind it);
* depths 1-3 right but the full image wrong beyond what depth 3 allows: the longer paths,
  naming only what the check's integrator has (roulette only where it plays, a depth cut only
  where max_depth is unlimited).

Elsewhere a hint states the evidence: the first wrong depth, what that bounce adds against
Mitsuba's, over the tiles and in the top and bottom thirds, and the image's ratio.
"""
from __future__ import annotations

import math

import numpy as np

from mitsuba_refs.verdicts.explain import Hint
from pathtracer.core.color import LUMINANCE

from . import geometry as geo

#: Integrators with shadow rays / with MIS / with Russian roulette / with paths beyond max_depth 2.
SHADOW_RAY_INTEGRATORS = ("path", "direct", "path_nee")
MIS_INTEGRATORS = ("path", "direct")
ROULETTE_INTEGRATORS = ("path", "path_nee", "path_bsdf")
#: Tiles this far from the image's added ratio are "uneven" (see :func:`tile_fields`).
UNEVEN = 0.15
#: A ratio within this of 1 counts as right (a band, a tile).
RIGHT = 0.1
#: Tiles follow one factor when their chi^2 per tile against it is at most this (measured on the
#: zoo: 0.2-2.2 for a constant factor (1/pi, 1/N, emission twice), 20-26000 for geometric errors;
#: 4 leaves room for the per-bounce references' ~1 % offset).
EVEN_CHI2 = 4.0


def lum(image) -> float:
    """Luminance summed over an image."""
    return float(np.asarray(image).reshape(-1, 3).sum(axis=0) @ LUMINANCE)


def tile_fields(sweep, depth, tile=8) -> dict:
    """What max_depth = ``depth`` adds to Mitsuba's depth - 1, per 8x8 tile (luminance): the
    student's (``test``), Mitsuba's (``ref``), the tiles that get a fair share (>= 1/4 of the
    median) of the added light (``keep``), and the per-pixel added light (``weights``)."""
    _, test, ref = sweep[depth]
    base = sweep[depth - 1][2] if depth - 1 in sweep else np.zeros_like(ref)
    h, w = (ref.shape[0] // tile) * tile, (ref.shape[1] // tile) * tile

    def tiles(img):
        lum_img = np.asarray(img)[:h, :w] @ LUMINANCE
        return lum_img.reshape(h // tile, tile, w // tile, tile).sum(axis=(1, 3)).ravel()
    added_ref, added_test = tiles(ref) - tiles(base), tiles(test) - tiles(base)
    positive = added_ref[added_ref > 0]
    keep = added_ref >= 0.25 * np.median(positive) if len(positive) else added_ref > 0
    weights = np.maximum((np.asarray(ref) - np.asarray(base)) @ LUMINANCE, 0.0)
    return dict(test=added_test, ref=added_ref, keep=keep, weights=weights)


def factor_chi2(sweep, depth, fields, factor) -> float:
    """Mean over the kept tiles of ((test - factor ref) / se)^2, the added light against one
    factor everywhere; ``se``, the noise of a tile's sum, comes from the sweep's own comparison
    (its per-tile z = (test - reference) / se, channels with |z| >= 1). NaN without it."""
    agreement, test, ref = sweep[depth]
    z = getattr(agreement, "z_tiles", None)
    if z is None:
        return math.nan
    z = np.asarray(z, dtype=float)
    t = 8
    h, w = (ref.shape[0] // t) * t, (ref.shape[1] // t) * t
    diff = (np.asarray(test) - np.asarray(ref))[:h, :w].reshape(h // t, t, w // t, t, 3)
    diff = diff.sum(axis=(1, 3))
    z = z[:h // t, :w // t]
    with np.errstate(divide="ignore", invalid="ignore"):
        se_c = np.where(np.abs(z) >= 1, np.abs(diff) / np.abs(z), np.nan)
    se = np.sqrt(np.nansum((se_c * LUMINANCE) ** 2, axis=2))
    se = np.where(np.isfinite(se_c[..., 1]) & (se > 0), se, np.nan).ravel()
    keep = fields["keep"] & np.isfinite(se)
    if keep.sum() < max(4, fields["keep"].sum() // 2):
        return math.nan
    return float(np.mean(((fields["test"][keep] - factor * fields["ref"][keep]) / se[keep]) ** 2))


def _near(value, factor, tolerance=0.2) -> bool:
    return math.isfinite(value) and abs(value / factor - 1) < tolerance


def _longer_paths(ev, ratios) -> list:
    """Depths 1..D right, the image wrong: name the long-path causes the check can have, when
    the image's error exceeds what depth D's agreement allows (else the numbers only)."""
    check, sweep = ev.check, ev.sweep
    last = max(sweep)
    r = 1 + ev.comparison.mean.rel_bias
    agreement = sweep[last][0]
    ci = getattr(agreement, "rel_bias_ci", (agreement.rel_bias, agreement.rel_bias))
    grows = (check.integrator != "direct"
             and abs(r - 1) > abs(agreement.rel_bias)
             and not (ci[0] <= r - 1 <= ci[1]))
    image = f"x{r:.3f}" if r < 1e3 else f"x{r:.2g}"
    evidence = (f"bounces 1-{last} agree with Mitsuba within the sweep's resolution ({ratios}) "
                f"but the full image is {image}")
    if not grows:
        why = ("direct has no longer paths: the error is smaller than the sweep resolves; see "
               "where it sits in the z-map" if check.integrator == "direct" else
               "an error this small is not resolved by the sweep; see where it sits in the "
               "z-map")
        return [Hint(f"{evidence}: {why}")]
    unlimited = check.max_depth is None or check.max_depth < 0
    roulette = (check.integrator in ROULETTE_INTEGRATORS
                and (check.rr_depth is None or unlimited or check.rr_depth < check.max_depth))
    causes, words = [], []
    if roulette:
        causes.append("roulette")
        words.append("Russian roulette without dividing the survivors by their probability")
    if unlimited:
        causes.append("depth_cut")
        words.append("a depth cut (a fixed maximum number of bounces although max_depth = -1)")
    causes.append("bsdf_sampling_weight")
    words.append("a per-bounce weight slightly off (f cos / pdf with the pdf the direction was "
                  "drawn from)")
    return [Hint(f"{evidence}, beyond depth {last}'s agreement: the error grows with path "
                 f"length: {', or '.join(words)}", causes)]


def off_by_one(sweep, tolerance) -> int:
    """+1 when the render at every max_depth = d matches Mitsuba's at d + 1, -1 when every
    d >= 2 matches Mitsuba's at d - 1 (max_depth = 1, the camera ray alone, cannot be cut),
    0 otherwise (whole-image brightness, within ``tolerance``)."""
    test = {d: lum(sweep[d][1]) for d in sweep}
    ref = {d: lum(sweep[d][2]) for d in sweep}
    ref[0] = 0.0
    scale = max(ref.values())

    def close(a, b):
        return abs(a - b) <= tolerance * max(b, 0.05 * scale)
    if all(close(test[d], ref[d]) for d in sweep):
        return 0
    for shift in (1, -1):
        pairs = [(d, d + shift) for d in sorted(sweep) if d + shift in ref and d + shift >= 1]
        if len(pairs) >= 2 and all(close(test[d], ref[e]) for d, e in pairs):
            return shift
    return 0


def direct_light(ev, added, fields, n_lights, numbers) -> list:
    """Rules for a first wrong max_depth = 2 (direct light)."""
    name = ev.check.integrator
    keep = fields["keep"]
    ratio = fields["test"][keep] / fields["ref"][keep]
    if not len(ratio):
        return [Hint(f"direct light (max_depth = 2) is the first wrong bounce {numbers}")]
    low, high = float(np.percentile(ratio, 10)), float(np.percentile(ratio, 90))
    q1, median, q3 = (float(q) for q in np.percentile(ratio, (25, 50, 75)))
    # One factor everywhere: the tiles' added light is the median ratio times Mitsuba's within
    # their noise. The factor rules read that median (the image's own ratio also counts the
    # tiles that get almost no direct light).
    chi2 = factor_chi2(ev.sweep, 2, fields, median)
    even = chi2 <= EVEN_CHI2 if math.isfinite(chi2) else q3 - q1 <= 2 * RIGHT * median
    shadow = name in SHADOW_RAY_INTEGRATORS
    lit = float(fields["ref"][keep].sum())
    excess_lit = float((fields["test"] - fields["ref"])[keep].sum()) / lit
    excess_dark = float((fields["test"] - fields["ref"])[~keep].sum()) / lit
    if abs(excess_lit) <= RIGHT / 5 and excess_dark >= 3 * RIGHT / 10:
        return [Hint("direct light right wherever Mitsuba's is, and extra light where Mitsuba "
                     f"has (almost) none (+{100 * excess_dark:.0f} % of the direct light, in the "
                     f"tiles it leaves dark; the lit tiles {100 * excess_lit:+.1f} %): light from "
                     "the back of an emitter; emitters are one-sided (emit only on the side their "
                     f"normal faces) {numbers}", ("one_sided_emitter",))]
    if even and _near(median, math.pi):
        return [Hint("direct light brighter by a factor near pi, evenly: the 1/pi of the diffuse "
                     f"BRDF rho/pi is missing (or that of a cosine pdf cos/pi) {numbers}",
                     ("diffuse_pi", "bsdf_sampling_weight"))]
    if even and _near(median, 1 / math.pi):
        return [Hint("direct light darker by a factor near pi, evenly: an extra 1/pi (the diffuse "
                     "BRDF is rho/pi, once), or a pdf that already includes 1/pi used twice "
                     f"{numbers}", ("diffuse_pi", "bsdf_sampling_weight"))]
    if even and name == "path_nee" and _near(median, 2.0, RIGHT):
        return [Hint("direct light twice too bright, evenly, with shadow rays: emission counted "
                     "twice (once by the shadow ray, once when the BSDF-sampled ray lands on the "
                     f"light); add Le after a bounce only if that bounce was specular {numbers}",
                     ("double_emission",))]
    if even and name in MIS_INTEGRATORS and _near(median, 2.0, RIGHT):
        return [Hint("direct light twice too bright, evenly, with MIS: both strategies count the "
                     "light in full, i.e. the MIS weights sum to two (each strategy weighted 1); "
                     "weight the shadow ray and the BSDF-sampled hit on the light with the power "
                     f"heuristic, w_light + w_bsdf = 1 {numbers}", ("mis_weights",))]
    if shadow and n_lights > 1:
        if even and _near(median, 1 / n_lights, 0.15):
            return [Hint(f"direct light x{median:.2f} everywhere in a scene with {n_lights} lights: "
                         f"the 1/N of choosing one of the N = {n_lights} lights is missing from the "
                         "light sample's pdf (p = 1/N x the pdf of the point on that light; the "
                         f"contribution is divided by it) {numbers}", ("light_choice_pdf",))]
        a, explained = geo.per_light_fit(fields["test"], fields["ref"], keep,
                                         geo.light_shares(ev.check), fields["weights"])
        # A choice probability p_k divided by another q_k scales light k by p_k / q_k: with
        # both summing to one, some lights gain and others lose.
        if a is not None and explained >= geo.PER_LIGHT and a.max() > 1 + UNEVEN / 2 \
                and 0 < a.min() < 1 - UNEVEN / 2:
            each = ", ".join(f"light {k + 1} x{v:.2f}" for k, v in enumerate(a))
            return [Hint(f"direct light too bright in some places and too dark in others, in a "
                         f"scene with {n_lights} lights, and one constant per light explains "
                         f"{100 * explained:.0f} % of the tiles' spread ({each}): the probability "
                         "of choosing each light must be the one its contribution is divided by "
                         "(uniform choice: 1/N for every light, in the shadow ray's pdf and in the "
                         f"MIS weights alike; choosing by power needs pdf = P_k / sum P) {numbers}",
                         ("light_choice_pdf",))]
        return [Hint(f"direct light (max_depth = 2) is the first wrong bounce, in a scene with "
                     f"{n_lights} lights, unevenly, and no constant per light explains it "
                     f"{numbers}")]
    if name == "path_bsdf":
        return [Hint(f"direct light x{added:.2f} with BSDF sampling alone (light found only by "
                     "the sampled directions): the weight of a sampled direction, f cos / pdf with "
                     "the pdf it was drawn from, or the next ray's origin (offset against "
                     f"self-intersection) {numbers}",
                     ("bsdf_sampling_weight",) + (("self_intersection",) if added < 1 else ()))]
    if not shadow:
        return [Hint(f"direct light (max_depth = 2) is the first wrong bounce {numbers}")]
    best, corr = geo.followed(ratio, keep, geo.pixel_geometry(ev.check), fields["weights"])
    follows = "; ".join(f"{geo.CANDIDATES[k][0]} {v:+.2f}" for k, v in corr.items()
                        if np.isfinite(v))
    if best is not None:
        what, cause = geo.CANDIDATES[best]
        advice = {
            "light_pdf_cosine": "the light-sampling pdf converts area to solid angle with the "
                                "cosine at the light: p = d^2 / (A |cos theta_light|)",
            "light_pdf_distance": "the light-sampling pdf misses the distance squared: "
                                  "p = d^2 / (A |cos theta_light|)",
            "bsdf_eval": "the BSDF value of the shadow ray: eval_bsdf(scene, hit, wi, wo) with wi "
                         "towards the camera side and wo towards the light, and its value "
                         "already includes cos theta_o (multiply by it once)",
        }[cause]
        return [Hint(f"direct light wrong by a factor that follows {what} (rank correlation over "
                     f"the tiles {corr[best]:+.2f}; {follows}): {advice} {numbers}", (cause,))]
    if even:
        return [Hint(f"direct light x{median:.2f} evenly over the image with shadow rays: a "
                     "constant factor in the shadow ray's estimate Le f cos / p_light: the light "
                     "pdf's constants (1 / area of the light, the 1/N of choosing one of N lights) "
                     "or a constant in the BSDF value; not a geometric problem such as "
                     f"self-intersection, which darkens some places more than others {numbers}",
                     ("light_pdf_area", "light_choice_pdf", "bsdf_eval", "diffuse_pi"))]
    if high <= 1 + RIGHT / 5 and low < 1 - UNEVEN:
        return [Hint("direct light too dark with shadow rays, unevenly, never brighter, and "
                     f"following no factor of the light pdf or the BSDF ({follows}): shadow rays "
                     "are blocked too often, a self-intersection (offset the origin along the "
                     f"normal, stop the ray just short of the light) {numbers}",
                     ("self_intersection",))]
    if name in MIS_INTEGRATORS and low >= 1 - RIGHT / 5 and high <= 2 + RIGHT and added > 1:
        return [Hint("direct light too bright with MIS, by between 1x and 2x in every tile, "
                     f"following no factor of the light pdf or the BSDF ({follows}): the MIS "
                     "weights of the two strategies do not sum to one (e.g. BSDF-sampled emission "
                     "added with weight 1 although the shadow ray also counts it; use one "
                     f"heuristic on both strategies) {numbers}", ("mis_weights",))]
    return [Hint(f"direct light (max_depth = 2) is the first wrong bounce, following no single "
                 f"factor of the shadow ray's estimate ({follows}) {numbers}")]


def sweep_hints(ev, n_lights, depth_tolerance, off_by_one_tolerance) -> list:
    """Hints from the per-bounce sweep of ``ev`` (an :class:`autograder.hints.explain.Evidence`)."""
    sweep, check = ev.sweep, ev.check
    if not sweep:
        return []
    bad = [d for d in sorted(sweep) if not sweep[d][0].agree
           and abs(sweep[d][0].rel_bias) >= depth_tolerance]
    depth = bad[0] if bad else None
    ratios = ", ".join(f"max_depth={d}: x{1 + sweep[d][0].rel_bias:.3f}" for d in sorted(sweep))
    # A check at a finite max_depth that the sweep reaches has no longer paths to blame.
    covered = check.max_depth is not None and max(sweep) >= check.max_depth
    if depth is None:
        if not ev.comparison.mean.agree and not covered:
            return _longer_paths(ev, ratios)
        return []
    shift = off_by_one(sweep, off_by_one_tolerance)
    if shift:
        pairs = ", ".join(f"yours at {d} is x{lum(sweep[d][1]) / lum(sweep[d + shift][2]):.3f} "
                          f"Mitsuba's at {d + shift}" for d in sorted(sweep)
                          if d + shift in sweep)
        more = "more" if shift > 0 else "fewer"
        return [Hint(f"max_depth off by one: your render at each max_depth = d looks like "
                     f"Mitsuba's at d {'+' if shift > 0 else '-'} 1 ({pairs}; {ratios}): your paths "
                     f"have one segment {more} than max_depth allows. max_depth counts segments: "
                     "1 = only emitters seen by the camera, 2 = direct light, 3 = one indirect "
                     "bounce; a path that has max_depth segments adds the Le of its last vertex "
                     "and stops (no shadow ray and no further bounce from there)",
                     ("depth_off_by_one",))]
    fields = tile_fields(sweep, depth)
    added_ref = float(fields["ref"].sum())
    added = float(fields["test"].sum()) / added_ref if added_ref > 0 else math.nan
    bands = band_ratios(sweep[depth][1], sweep[depth][2])
    keep = fields["keep"]
    tile_ratio = fields["test"][keep] / fields["ref"][keep] if keep.any() else np.array([math.nan])
    low, high = np.percentile(tile_ratio, 10), np.percentile(tile_ratio, 90)
    numbers = (f"(first wrong at max_depth={depth}; what that bounce adds is x{added:.2f} "
               f"Mitsuba's, x{low:.2f} to x{high:.2f} over most 8x8 tiles; top third "
               f"{_times(bands[0])}, bottom third {_times(bands[1])}; {ratios})")
    if depth == 1:
        if added < 0.5 and check.integrator in MIS_INTEGRATORS:
            # With MIS the camera ray's Le goes through the BSDF strategy's weight too.
            return [Hint("light sources seen directly are missing: the emitted radiance Le where "
                         "the camera ray's first hit is on a light is not added (emission missed "
                         "on the first hit), or added with MIS weight 0: a camera ray's hit has "
                         "weight 1 (no light sample competes with it), and the BSDF strategy's "
                         "weight is w(pdf_bsdf, pdf_light), in that order "
                         f"{numbers}", ("visible_emission", "mis_weights"))]
        if added < 0.5:
            return [Hint("light sources seen directly are missing: add the emitted radiance Le "
                         "when the camera ray's first hit is on a light (emission missed on the "
                         f"first hit) {numbers}", ("visible_emission",))]
        return [Hint(f"light sources seen directly are x{added:.2f}: the emission of the camera "
                     "ray's first hit (Le added once, where the camera ray lands on a light; the "
                     f"camera itself is the reference's in this check) {numbers}",
                     ("visible_emission",))]
    if depth == 2:
        return direct_light(ev, added, fields, n_lights, numbers)
    if check.integrator == "direct":
        return [Hint(f"max_depth={depth} is the first wrong {numbers}")]
    return [Hint("only bounce >= 3 is wrong, the indirect term (direct light is right): the "
                 "weight of a sampled direction is f cos / pdf with the pdf it was drawn from "
                 "(cosine and pdf both needed), and the next ray starts off the surface (offset "
                 f"against self-intersection) {numbers}",
                 ("bsdf_sampling_weight", "self_intersection"))]


def band_ratios(test, ref) -> tuple:
    """Brightness ratio test/ref of the top and bottom thirds of an image."""
    h = test.shape[0]
    ratio = []
    for band in (slice(0, h // 3), slice(h - h // 3, h)):
        r = lum(ref[band])
        ratio.append(lum(test[band]) / r if r > 0 else math.nan)
    return tuple(ratio)


def _times(ratio: float) -> str:
    """``x1.23``, or what a missing ratio means: the reference has no light there."""
    return f"x{ratio:.2f}" if math.isfinite(ratio) else "dark in Mitsuba's"
