"""From the evidence of a comparison to the likely cause, in a student's words.

Each rule looks at numbers the statistics already produced (image-level
ratio and its CI, the first diverging bounce, the variance ratio, the
convergence slope and floor) and, when they match a known pattern, returns a
sentence that quotes those numbers. Rules never run a test of their own.

Each hint is a :class:`Hint`: its text, and the causes it names (short ids such as
``"double_emission"``; none when it only states the evidence). A rule names a cause only where
its evidence is specific to that cause; where the numbers fit several, it says so or states
the numbers alone (``autograder.hints.accuracy`` measures how often the named cause is right).
"""
from __future__ import annotations

import math

from ..report.wording import mean_region


class Hint(str):
    """A hint's text (it *is* the string) and ``causes``, the ids of the causes it names."""

    causes: tuple = ()

    def __new__(cls, text: str, causes=()):
        self = super().__new__(cls, text)
        self.causes = tuple(causes)
        return self

    def __reduce__(self):
        return (Hint, (str(self), self.causes))


#: Brightness factors of the whole image: (factor, what it says, the causes it names). Only a
#: factor of pi points at a cause (the 1/pi of rho/pi, or of a cosine pdf cos/pi); a factor of
#: 2 or 1/2 over the whole image fits too many mistakes to name one.
KNOWN_FACTORS = (
    (1 / math.pi, "darker by a factor near pi: an extra 1/pi (e.g. dividing the diffuse BRDF "
                  "rho/pi by pi again, or a pdf that already includes 1/pi used twice)",
     ("diffuse_pi", "bsdf_sampling_weight")),
    (math.pi, "brighter by a factor near pi: the 1/pi of the diffuse BRDF rho/pi is missing "
              "(or that of a cosine pdf cos/pi)", ("diffuse_pi", "bsdf_sampling_weight")),
    (2.0, "about twice as bright overall: a factor of 2 in every bounce alike", ()),
    (0.5, "about half as bright overall: a factor of 1/2 in every bounce alike", ()),
)

BOUNCE_CAUSES = {
    1: "directly visible light is wrong: emitted radiance, one-sided emitters, emission "
       "missed on the first hit, or the camera (orientation, field of view)",
    2: "direct lighting is wrong: the light-sampling pdf (distance squared, cosine at the "
       "light), the shadow ray, or the BSDF value at the first hit",
    3: "indirect light is wrong while direct light is right: the BSDF sampling weight "
       "(f cos / pdf) or the continuation of the path",
}
#: The causes each of BOUNCE_CAUSES names.
BOUNCE_CAUSE_IDS = {
    1: ("visible_emission", "one_sided_emitter", "camera_orientation", "camera_fov"),
    2: ("light_pdf_distance", "light_pdf_cosine", "self_intersection", "bsdf_eval"),
    3: ("bsdf_sampling_weight", "self_intersection"),
}


def factor_hint(ratio: float, ci: tuple) -> Hint | None:
    """A hint when the image-level brightness ratio (with CI) sits on a known factor."""
    low, high = ci
    for factor, text, causes in KNOWN_FACTORS:
        # Inside the CI, or within 5 % when the CI is very tight.
        if low <= factor <= high or abs(ratio / factor - 1) < 0.05:
            return Hint(f"image {ratio:.3f}x the reference [{low:.3f}, {high:.3f}]: {text}", causes)
    return None


def missing_noise(comparison, ratio: float) -> Hint | None:
    """Evidence only: an image too dark whose per-sample variance (same estimator) is less than
    half of what a uniformly darker image would have, ``ratio^2`` times the reference's. The
    noisy part of the light is missing, by chance (heavy-tailed radiance: rare bright paths
    the render did not draw; ``test_texturedprincipled1_path``: 0.948x, variance 0.26x at 64
    spp, agreeing at 512) or always (a class of paths dropped)."""
    arrays = getattr(comparison, "arrays", None) or {}     # recorded evidence may lack them
    test, reference = arrays.get("test_variance"), arrays.get("reference_variance")
    if test is None or reference is None or ratio >= 1 or not comparison.compares_variance:
        return None
    if getattr(getattr(comparison, "convergence", None), "faster", False):
        return None     # stratified samples: a low variance is what they buy, not lost light
    total = float(reference.sum())
    share = float(test.sum()) / total if total > 0 else math.inf
    if share >= ratio ** 2 / 2:
        return None
    return Hint(f"the image is {ratio:.3f}x as bright and its per-sample variance only "
                f"{share:.2f}x the reference's (same estimator): the noisy part of the light is "
                "missing, either by chance (rare bright paths this render did not draw: rerun "
                "with 8x the spp; if it then agrees, the radiance is heavy-tailed) or always "
                "(a class of paths dropped, such as caustics)")


def hints(comparison) -> list[Hint]:
    """Likely causes of a comparison's failures, each with its supporting numbers."""
    out = []
    mean = comparison.mean
    rounds = getattr(comparison, "rounds", None)
    # With a tolerance the mean failed only when it DISAGREES (a bias inside it is no fault).
    if (not mean.agree) if rounds is None or getattr(mean, "faults", None) \
            else rounds.outcome == "DISAGREES":
        ratio = 1.0 + mean.rel_bias
        ci = (1.0 + mean.rel_bias_ci[0], 1.0 + mean.rel_bias_ci[1])
        text = factor_hint(ratio, ci)
        if text:
            out.append(text)
        elif ci[0] > 1 or ci[1] < 1:      # no known factor: the evidence itself
            out.append(Hint(f"the image is {ratio:.3f}x as bright as the reference [{ci[0]:.3f}, "
                            f"{ci[1]:.3f}] ({'too bright' if ratio > 1 else 'too dark'} overall)"))
        if comparison.bounce is not None and comparison.bounce[0] is not None:
            depth = comparison.bounce[0]
            out.append(Hint(f"first wrong at max_depth={depth}: "
                            f"{BOUNCE_CAUSES.get(depth, BOUNCE_CAUSES[3])}",
                            BOUNCE_CAUSE_IDS.get(depth, BOUNCE_CAUSE_IDS[3])))
            at_depth = comparison.bounce_results[depth]
            if depth == 2 and at_depth.rel_bias_ci[0] > 0:
                # Evidence only: many mistakes brighten direct light (a light pdf, a BSDF
                # value, MIS weights, emission counted twice).
                out.append(Hint(f"direct light is {100 * at_depth.rel_bias:.0f}% too bright "
                                f"[{100 * at_depth.rel_bias_ci[0]:.0f}%, "
                                f"{100 * at_depth.rel_bias_ci[1]:.0f}%]"))
        missing = missing_noise(comparison, ratio)
        if missing:
            out.append(missing)
        region = mean_region(mean)
        if region and region != "whole image":
            out.append(Hint(f"the largest difference (|z| = {abs(mean.worst_z):.1f}) is in the "
                            f"{region} of the image: look at what is there (see the "
                            "z-map)"))
    variance = comparison.variance
    if variance is not None and not variance.agree and mean.agree:
        ratio = variance.ratio
        if ratio > 1:
            out.append(Hint(f"mean right but variance {ratio:.2f}x Mitsuba's same estimator: the "
                            "sampling pdf does not follow the integrand (e.g. uniform directions "
                            "where cosine-weighted ones are expected), or a sample is wasted",
                            ("importance_sampling",)))
        else:
            out.append(Hint(f"mean right but variance only {ratio:.2f}x Mitsuba's same estimator: a "
                            "different (better or correlated) estimator than the one named"))
    law = comparison.convergence
    if law is not None and not law.passed:
        if law.correlated:
            out.append(Hint(f"error does not fall with more samples (slope {law.slope:.2f}, "
                            "expected -1): the same random numbers are reused across samples",
                            ("random_reuse",)))
        elif law.floor_detected:
            # Evidence only: any bias makes a floor.
            out.append(Hint(f"error stops falling near {law.floor_spp:.0f} spp: a bias of about "
                            f"{100 * law.bias_rel:.1f}% of the image mean"))
        else:
            out.append(Hint(f"error falls with slope {law.slope:.2f} [{law.slope_ci[0]:.2f}, "
                            f"{law.slope_ci[1]:.2f}] instead of -1: samples are not independent",
                            ("random_reuse",)))
    return out
