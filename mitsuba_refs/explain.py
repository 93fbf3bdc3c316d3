"""From the evidence of a comparison to the likely cause, in a student's words.

Each rule looks at numbers the statistics already produced (image-level
ratio and its CI, the first diverging bounce, the variance ratio, the
convergence slope and floor) and, when they match a known pattern, returns a
sentence that quotes those numbers. Rules never run a test of their own.
"""
from __future__ import annotations

import math

#: Brightness factors with a classic cause: (factor, what it usually means).
KNOWN_FACTORS = (
    (1 / math.pi, "darker by a factor near pi: an extra 1/pi (e.g. dividing the diffuse BRDF "
                  "rho/pi by pi again, or a pdf that already includes 1/pi used twice)"),
    (math.pi, "brighter by a factor near pi: the 1/pi of the diffuse BRDF rho/pi is missing"),
    (2.0, "about twice too bright: emission is counted twice (once by the shadow ray, once "
          "when the BSDF-sampled ray hits the light)"),
    (0.5, "about half as bright: a pdf twice too large (e.g. the uniform hemisphere pdf "
          "1/(2 pi) mixed up with 1/pi), or one of two contributions missing"),
)

BOUNCE_CAUSES = {
    1: "directly visible light is wrong: emitted radiance, one-sided emitters, emission "
       "missed on the first hit, or the camera (orientation, field of view)",
    2: "direct lighting is wrong: the light-sampling pdf (distance squared, cosine at the "
       "light), the shadow ray, or the BSDF value at the first hit",
    3: "indirect light is wrong while direct light is right: the BSDF sampling weight "
       "(f cos / pdf) or the continuation of the path",
}


def factor_hint(ratio: float, ci: tuple) -> str | None:
    """A hint when the image-level brightness ratio (with CI) sits on a known factor."""
    low, high = ci
    for factor, text in KNOWN_FACTORS:
        # Inside the CI, or within 5 % when the CI is very tight.
        if low <= factor <= high or abs(ratio / factor - 1) < 0.05:
            return f"image {ratio:.3f}x the reference [{low:.3f}, {high:.3f}]: {text}"
    return None


def hints(comparison) -> list[str]:
    """Likely causes of a comparison's failures, each with its supporting numbers."""
    out = []
    mean = comparison.mean
    if not mean.agree:
        ratio = 1.0 + mean.rel_bias
        ci = (1.0 + mean.rel_bias_ci[0], 1.0 + mean.rel_bias_ci[1])
        text = factor_hint(ratio, ci)
        if text:
            out.append(text)
        elif ci[0] > 1 or ci[1] < 1:      # no known factor: the evidence itself
            out.append(f"the image is {ratio:.3f}x as bright as the reference [{ci[0]:.3f}, "
                       f"{ci[1]:.3f}] ({'too bright' if ratio > 1 else 'too dark'} overall)")
        if comparison.bounce is not None and comparison.bounce[0] is not None:
            depth = comparison.bounce[0]
            out.append(f"first wrong at max_depth={depth}: {BOUNCE_CAUSES.get(depth, BOUNCE_CAUSES[3])}")
            at_depth = comparison.bounce_results[depth]
            if depth == 2 and at_depth.rel_bias_ci[0] > 0:
                out.append(f"direct light is {100 * at_depth.rel_bias:.0f}% too bright "
                           f"[{100 * at_depth.rel_bias_ci[0]:.0f}%, {100 * at_depth.rel_bias_ci[1]:.0f}%]: "
                           "emission is probably counted twice, by the shadow ray and again when "
                           "the BSDF-sampled ray hits the light (count it only after specular "
                           "bounces, or weight both with MIS)")
        if mean.worst_region and mean.worst_region != "whole image":
            out.append(f"the largest difference (|z| = {abs(mean.worst_z):.1f}) is in the "
                       f"{mean.worst_region} of the image: look at what is there (see the z-map)")
    variance = comparison.variance
    if variance is not None and not variance.agree and mean.agree:
        ratio = variance.ratio
        if ratio > 1:
            out.append(f"mean right but variance {ratio:.2f}x Mitsuba's same estimator: the "
                       "sampling pdf does not follow the integrand (e.g. uniform directions where "
                       "cosine-weighted ones are expected), or a sample is wasted")
        else:
            out.append(f"mean right but variance only {ratio:.2f}x Mitsuba's same estimator: a "
                       "different (better or correlated) estimator than the one named")
    law = comparison.convergence
    if law is not None and not law.passed:
        if law.correlated:
            out.append(f"error does not fall with more samples (slope {law.slope:.2f}, expected -1): "
                       "the same random numbers are reused across samples")
        elif law.floor_detected:
            out.append(f"error stops falling near {law.floor_spp:.0f} spp (bias about "
                       f"{100 * law.bias_rel:.1f}% of the image mean): a bias such as Russian "
                       "roulette without dividing by its probability, or a depth cut")
        else:
            out.append(f"error falls with slope {law.slope:.2f} [{law.slope_ci[0]:.2f}, "
                       f"{law.slope_ci[1]:.2f}] instead of -1: samples are not independent")
    return out
