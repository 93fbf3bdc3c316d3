"""From the evidence of a failed check to the likely cause, in a student's words.

The rules of :mod:`mitsuba_refs.verdicts.explain` (image brightness factors, the first diverging
bounce, variance and convergence patterns) run first; the rules here add what only the
autograder sees, each quoting the numbers it rests on:

* the per-bounce sweep (:mod:`autograder.hints.sweep`): the first wrong depth, the *added
  term* ``(test_d - ref_{d-1}) / (ref_d - ref_{d-1})`` over the image and its 8x8 tiles, and
  what that term's error follows (one factor everywhere, a factor of each pixel's geometry,
  one constant per light: :mod:`autograder.hints.geometry`); a cause is named only where that
  evidence is specific to it, otherwise the hint states the numbers;
* sample independence: a second render with another seed differs from the first by
  ``R`` times what the per-pixel variances predict (R ~ 1 for independent samples, biased or
  not; R >> 1 when samples reuse random numbers);
* glass: the same integrator right on the Cornell box but wrong with a glass sphere;
* camera: the field of view measured from the student's own rays;
* light tracing (:func:`light_hints`, from the scored render itself): splats in the wrong
  pixel (the image matches Mitsuba's flipped or shifted), the 1/eta^2 of radiance applied to
  importance (only the light that leaves glass is off, by eta^2), the camera importance
  (a ratio that follows a power of cos theta, the angle to the optical axis, or a constant).

A rule never runs a test of its own; hints are explanations, never points. Each hint is a
:class:`mitsuba_refs.verdicts.explain.Hint` carrying the causes it names (``python -m
autograder.hints.accuracy`` measures them against the bug zoo's true causes).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from mitsuba_refs.report.wording import mean_region, variance_policy_verdict
from mitsuba_refs.verdicts import explain as base
from mitsuba_refs.verdicts.explain import Hint
from mitsuba_refs.verdicts.scenes import default_params
from pathtracer import load_scene
from pathtracer.core.color import LUMINANCE
from pathtracer.sensors.perspective import camera_rays

from .media import explain_media
from .sweep import sweep_hints

#: R above this or below its inverse: samples are not independent (R ~ 1 +- 0.1 for
#: independent samples at 64x64).
CORRELATED_R = 3.0
#: The causes the glass rule lists (the specular bounces' steps).
GLASS_CAUSES = ("glass_fresnel", "glass_eta", "backface_normals", "glass_radiance_scaling",
                "specular_emission")


@dataclass
class Evidence:
    """Everything the rules may look at (filled by :func:`autograder.grading.run_check`)."""

    # Duck-typed: a grading.Check and a Comparison when grading, their stored fields
    # (SimpleNamespace) when hints.evidence_io replays a recorded case.
    check: object
    comparison: object
    history: dict = field(default_factory=dict)
    sweep: dict = None            # depth -> (MeanAgreement, test mean, reference mean)
    independence: float = None    # R, see module docstring
    camera: dict = None           # measured field of view, see camera_evidence
    probe: tuple = None           # distinct results of 4096 copies of one ray: (student, reference)
    images: dict = None           # the scored render and its reference (light tracing)
    incomplete: str = ""


def independence(first, n_first, second, n_second) -> float:
    """R = mean (m1 - m2)^2 / mean(v1/n1 + v2/n2) over pixels and channels (bias cancels)."""
    m1, v1 = first
    m2, v2 = second
    predicted = float(np.mean(v1 / n_first + v2 / n_second))
    observed = float(np.mean((m1 - m2) ** 2))
    return observed / predicted if predicted > 0 else (math.inf if observed > 0 else 1.0)


#: A depth counts as wrong (for explanations) when it disagrees by at least this much: the
#: per-bounce references show a systematic ~1 % offset at max_depth = 2 (see the report).
DEPTH_TOLERANCE = 0.02
#: Brightness tolerance of the off-by-one rule: the student's render at max_depth = d is
#: "Mitsuba's at d +- 1" when within 3 % of it (consecutive depths differ by >= 10 % in the
#: graded scenes; 64-spp whole-image noise is < 1 %).
OFF_BY_ONE_TOLERANCE = 0.03


def _scene_facts(check) -> dict:
    """What the rules need to know about the check's scene: its number of emitters."""
    scene = load_scene(check.scene, **default_params(check.scene))
    return dict(emitters=scene.num_emitters)


def camera_evidence(check, student) -> dict:
    """Geometry of the student's camera measured from a few of its rays (no render).

    Returns a dict with

    ``film_ignored``  two film samples of one pixel, (0.05, 0.05) and (0.95, 0.95), give the
        same ray although the reference's differ by a pixel's width;
    ``x_fov, y_fov``  angles (degrees) between the rays through the left/right and the
        top/bottom edge midpoints of the film; when the film sample is ignored, between the
        rays of the edge pixels' centres (what such a camera can show), ``x_ref, y_ref`` the
        same for the scene's camera, so the comparison does not mistake the missing half
        pixel for a wrong field of view (``centres`` says which);
    ``mirrored, flipped``  left-right / top-bottom order reversed.
    """
    params = default_params(check.scene)
    camera = load_scene(check.scene, **params).camera
    w, h = camera.width, camera.height
    centre = (h // 2) * w + w // 2
    inside = np.array([[0.05, 0.05], [0.95, 0.95]])
    _, d_in = student.rays(check.scene, params, np.array([centre, centre]), inside)
    ref_in = camera_rays(camera, np.array([centre, centre]), inside).d
    film_ignored = bool(_angle(d_in[0], d_in[1]) < 0.01 * _angle(ref_in[0], ref_in[1]))
    # left/right edge midpoints, top/bottom edge midpoints (pixel + film offset)
    pixel = np.array([(h // 2) * w, (h // 2) * w + w - 1, w // 2, (h - 1) * w + w // 2])
    u = np.array([[0.0, 0.5], [1.0 - 1e-9, 0.5], [0.5, 0.0], [0.5, 1.0 - 1e-9]])
    if h % 2:
        u[:2, 1] = 0.5
    if film_ignored:
        u = np.full_like(u, 0.5)
    _, d = student.rays(check.scene, params, pixel, u)
    ref = camera_rays(camera, pixel, u)
    return dict(x_fov=_angle(d[0], d[1]), y_fov=_angle(d[2], d[3]),
                x_ref=_angle(ref.d[0], ref.d[1]), y_ref=_angle(ref.d[2], ref.d[3]),
                centres=film_ignored, film_ignored=film_ignored,
                mirrored=bool(np.dot(d[0] - d[1], ref.d[0] - ref.d[1]) < 0),
                flipped=bool(np.dot(d[2] - d[3], ref.d[2] - ref.d[3]) < 0))


def _angle(a, b) -> float:
    cos = np.dot(a, b) / (np.linalg.norm(a) * np.linalg.norm(b))
    return math.degrees(math.acos(float(np.clip(cos, -1, 1))))


def camera_findings(cam, image_passed: bool = True) -> list:
    """What the camera's geometry shows, for every submission: one line with the measured
    numbers, then, when the image check passed anyway (a scene that hides the mistake), one
    line per problem; when it failed, the problems are the check's hints instead."""
    span = "pixel centres of the film's edges" if cam["centres"] else "film's edges"
    line = (f"camera geometry (measured from your rays): {cam['x_fov']:.1f} x {cam['y_fov']:.1f} "
            f"deg between the {span}, the scene's camera {cam['x_ref']:.1f} x "
            f"{cam['y_ref']:.1f} deg")
    problems = _camera_hints(cam)
    if not problems:
        return [line + "; orientation and film sampling as expected"]
    if not image_passed:
        return [line]
    return [line] + [f"camera problem (the image check did not catch it): {p}" for p in problems]


def _camera_hints(cam) -> list:
    out = []
    if cam["mirrored"]:
        out.append(Hint("your image is mirrored left-right: in Mitsuba's camera +x points to "
                        "the image's left (right = -left)", ("camera_orientation",)))
    if cam["flipped"]:
        out.append(Hint("your image is upside down: row 0 is the top of the image",
                        ("camera_orientation",)))
    if cam.get("film_ignored"):
        out.append(Hint("the film sample is ignored: u_film (the sample's position inside its "
                        "pixel) does not move your rays, so every sample of a pixel goes through "
                        "its centre and edges are aliased instead of averaged over the pixel; use "
                        "s = (column + u_film[:, 0]) / width, (row + u_film[:, 1]) / height",
                        ("camera_film_sample",)))
    dx, dy = cam["x_fov"] - cam["x_ref"], cam["y_fov"] - cam["y_ref"]
    if abs(dx) > 0.5 or abs(dy) > 0.5:
        swapped = abs(cam["y_fov"] - cam["x_ref"]) < 0.5 or abs(cam["x_fov"] - cam["y_ref"]) < 0.5
        text = (f"field of view wrong: your rays span {cam['x_fov']:.1f} deg horizontally and "
                f"{cam['y_fov']:.1f} deg vertically, the scene's camera {cam['x_ref']:.1f} x "
                f"{cam['y_ref']:.1f} deg")
        if swapped:
            text += ": the fov is applied to the wrong axis (fov_axis; x_fov is horizontal, " \
                    "the vertical extent is tan(x_fov/2) * height/width)"
        else:
            text += ": check tan(fov/2) (degrees vs radians, half angle) and the aspect ratio"
        out.append(Hint(text, ("camera_fov",)))
    return out


def _sweep_hints(ev: Evidence) -> list:
    """Rules on the per-bounce sweep (:mod:`autograder.hints.sweep`)."""
    if not ev.sweep:
        return []
    return sweep_hints(ev, _scene_facts(ev.check)["emitters"], DEPTH_TOLERANCE,
                       OFF_BY_ONE_TOLERANCE)


def _glass_hints(ev: Evidence) -> list:
    check = ev.check
    if not check.glass or ev.comparison.mean.agree:
        return []
    diffuse = ev.history.get(f"{check.integrator}-cornell-box")
    if diffuse is not None and not diffuse.passed:
        return [Hint(f"fix {check.integrator} on the Cornell box first: it fails there too")]
    m = ev.comparison.mean
    where = f"largest |z| = {abs(m.worst_z):.1f} in the {mean_region(m)}"
    prefix = ("the Cornell box check of this integrator passed, so the diffuse part is right; "
              if diffuse is not None else "")
    return [Hint(f"{prefix}wrong with glass in the scene ({where}; image x{1 + m.rel_bias:.3f}): "
                 "look at the specular (delta) bounces: exact dielectric Fresnel (not Schlick), "
                 "eta = int_ior / ext_ior and its inverse when leaving the glass, normals flipped "
                 "for back faces (ray offsets on the side the ray leaves), the 1/eta^2 radiance "
                 "scaling, and emission after a specular bounce", GLASS_CAUSES)]


def _variance_policy(hint: str, comparison) -> str:
    """The variance rule of mitsuba_refs.verdicts.explain fires only when the variance part failed
    (with a right mean); say what that part allows before suggesting a cause, so that a
    correct estimator that is merely different is never told it is wrong."""
    v = comparison.variance
    policy = (f"the variance part failed ({variance_policy_verdict(v)}); it compares your image's "
              "per-sample variance with Mitsuba's run of the same estimator and allows a correct "
              f"estimator written differently (another MIS heuristic, roulette rule or light "
              f"choice) to be up to {v.max_ratio:g}x noisier, failing only beyond that bound")
    if v.ratio > 1:
        return Hint(f"{policy}: {v.ratio:.2f}x is more than a different but sound choice costs; "
                    "usually the sampling pdf does not follow the integrand (e.g. uniform "
                    "directions where cosine-weighted ones are expected), or a sample is wasted",
                    ("importance_sampling",))
    return Hint(f"{policy}: yours is lower ({v.ratio:.2f}x): a different estimator than the one "
                "named, or samples that are not independent", ("random_reuse",))


def explain(ev: Evidence) -> list:
    """Likely causes, most specific first, each with its numbers."""
    comparison = ev.comparison
    out = []
    if ev.images is not None:
        out += light_hints(ev.check, ev.images)
    if ev.camera is not None:
        out += _camera_hints(ev.camera)
    out += _glass_hints(ev)
    r = ev.independence
    correlated = r is not None and (r > CORRELATED_R or r < 1 / CORRELATED_R)
    if ev.probe is not None and ev.probe[1] >= 5 and ev.probe[0] <= max(1, ev.probe[1] // 50):
        correlated = True
        out.append(Hint(f"random numbers reused: 4096 copies of one camera ray, each given its "
                        f"own random stream, returned only {ev.probe[0]} distinct value(s) (the "
                        f"reference integrator: {ev.probe[1]}): the same random numbers are reused "
                        "across samples (draw from the rng you are given, per ray; never share or "
                        "reseed it)", ("random_reuse",)))
    elif correlated and r > 1:
        out.append(Hint(f"samples are not independent: two renders with different seeds differ "
                        f"{r:.2f}x as much as the per-pixel variances predict (1 expected; more): "
                        "the same random numbers are reused across samples (use the rng you are "
                        "given, one stream per ray; never reseed or share one stream)",
                        ("random_reuse",)))
    elif correlated:
        # Renders that differ *less* than their variances predict: reused random numbers do
        # the opposite, so this is evidence only (a variance the process misreports, or
        # samples of a pixel that cancel each other).
        out.append(Hint(f"two renders with different seeds differ {r:.2f}x as much as the "
                        "per-pixel variances your process reported predict (1 expected; less): "
                        "the reported variance is larger than the renders' own spread (the "
                        "grader scores with the spread)"))
    if getattr(ev.check, "assignment", "") == "media":
        if not correlated:
            out += explain_media(ev)
    elif not ev.check.glass and not correlated:
        out += _sweep_hints(ev)
    generic = base.hints(comparison)
    if ev.independence is not None and not correlated:
        # The convergence rules read a slope; with independent samples a flat slope is a bias.
        generic = [h for h in generic if "random numbers are reused" not in h
                   and "not independent" not in h]
    if out:
        # The specific rules already explain the mean (and a wrong mean is a bias, which the
        # convergence floor only restates); keep the variance hints.
        generic = [h for h in generic if not h.startswith("image ") and "first wrong" not in h
                   and "error stops falling" not in h]
    # A variance hint only where the variance part failed its policy (not the equality test).
    variance = comparison.variance
    policy_failed = variance is not None and not variance.policy_agree
    generic = [_variance_policy(h, comparison) if h.startswith("mean right but variance") else h
               for h in generic
               if policy_failed or not h.startswith("mean right but variance")]
    for hint in generic:
        if hint not in out:
            out.append(hint)
    if ev.incomplete:
        out.append(Hint(f"(explanation incomplete: {ev.incomplete})"))
    return out


# ----------------------------------------------------------------------------------------
# Light tracing: rules that read the scored image against the reference

#: Scenes of the light checks whose light leaves glass: the channel only that light gives,
#: what it is, and the glass's relative index of refraction (Mitsuba's BK7 in air).
GLASS_LIGHTS = {"glass-lamp": dict(channel=0, colour="red", others=(1, 2),
                                   light="the red lamp inside the glass sphere",
                                   eta=1.5046 / 1.000277)}
#: A rearrangement of the reference that explains the image this much better (chi^2 per pixel
#: at most this fraction of the image as it is) means the splats land in the wrong pixels.
REARRANGED = 0.5
#: Channels (or tiles) within this of Mitsuba's count as right in the light rules.
LIGHT_TOLERANCE = 0.05


def _rearrangements():
    """name -> (function of an (H, W, ...) image, its rows/columns kept) for wrong-pixel splats."""
    whole = (slice(None), slice(None))
    return {
        "as it is": (lambda x: x, whole),
        "flipped upside down (row r in row H - 1 - r)": (lambda x: x[::-1], whole),
        "mirrored left-right (column c in column W - 1 - c)": (lambda x: x[:, ::-1], whole),
        "rotated by 180 degrees": (lambda x: x[::-1, ::-1], whole),
        "shifted one row down": (lambda x: np.roll(x, 1, axis=0), (slice(1, None), slice(None))),
        "shifted one row up": (lambda x: np.roll(x, -1, axis=0), (slice(None, -1), slice(None))),
        "shifted one column right": (lambda x: np.roll(x, 1, axis=1), (slice(None), slice(1, None))),
        "shifted one column left": (lambda x: np.roll(x, -1, axis=1), (slice(None), slice(None, -1))),
        "transposed": (lambda x: np.swapaxes(x, 0, 1), whole),
    }


def pixel_mapping(images: dict) -> dict:
    """chi^2 per pixel of the render against each rearrangement of the reference (name -> value;
    shapes that do not fit, e.g. a transposed 4:3 film, are left out)."""
    mean, ref = images["mean"], images["ref_mean"]
    var = images["var"] / images["n"]
    ref_var = images["ref_var"] / images["ref_n"]
    floor = (1e-3 * float(np.mean(np.abs(ref)))) ** 2
    out = {}
    for name, (move, keep) in _rearrangements().items():
        moved, moved_var = move(ref), move(ref_var)
        if moved.shape != mean.shape:
            continue
        chi2 = (mean - moved) ** 2 / (var + moved_var + floor)
        out[name] = float(np.mean(chi2[keep]))
    return out


def _pixel_cosines(check, shape) -> np.ndarray:
    """cos theta (to the optical axis) of each pixel centre's ray, (H, W)."""
    camera = load_scene(check.scene, **default_params(check.scene)).camera
    height, width = shape[:2]
    tan_x = np.tan(np.radians(camera.x_fov) / 2)
    x = (1 - 2 * (np.arange(width) + 0.5) / width) * tan_x
    y = (1 - 2 * (np.arange(height) + 0.5) / height) * tan_x * height / width
    return 1.0 / np.sqrt(1.0 + x[None, :] ** 2 + y[:, None] ** 2)


def _tile_sums(image, tile=8):
    h, w = image.shape[:2]
    h, w = h - h % tile, w - w % tile
    return image[:h, :w].reshape(h // tile, tile, w // tile, tile, *image.shape[2:]).sum(axis=(1, 3))


def light_hints(check, images: dict) -> list:
    """Likely causes of a failed light-tracing check, each with the numbers it rests on."""
    mapping = pixel_mapping(images)
    best = min(mapping, key=mapping.get)
    if best != "as it is" and mapping[best] <= REARRANGED * mapping["as it is"]:
        return [Hint(f"splats land in the wrong pixel: your image matches Mitsuba's {best} (chi^2 per "
                f"pixel {mapping[best]:.2f}, 1 expected; as it is: {mapping['as it is']:.1f}): the "
                "pixel a point projects to is row * width + column with row 0 at the top of the "
                "image and column 0 on its left (camera space: +x to the left, +y up), "
                "row = floor(s_y H), column = floor(s_x W) with the film position s of "
                "camera_rays inverted", ("splat_pixel",))]
    out = []
    mean, ref = images["mean"], images["ref_mean"]
    channel_ratio = mean.sum(axis=(0, 1)) / np.maximum(ref.sum(axis=(0, 1)), 1e-300)
    glass = GLASS_LIGHTS.get(check.scene)
    if glass is not None:
        own = float(channel_ratio[glass["channel"]])
        others = float(np.mean(channel_ratio[list(glass["others"])]))
        eta2 = glass["eta"] ** 2
        if abs(others - 1) <= LIGHT_TOLERANCE and abs(own - 1) > LIGHT_TOLERANCE:
            factor = (f" = eta^2 ({eta2:.2f})" if abs(own / eta2 - 1) < 0.1 else
                      f" = 1/eta^2 ({1 / eta2:.2f})" if abs(own * eta2 - 1) < 0.1 else "")
            out.append(f"only the light that leaves glass is wrong: the {glass['colour']} channel "
                       f"(lit only by {glass['light']}) is x{own:.2f}{factor} while the others "
                       f"are x{others:.2f}: light paths carry importance, which refraction does "
                       "not scale: no 1/eta^2 on a light path's refractions (the adjoint BSDF: "
                       "sample_bsdf(..., adjoint=True) and eval_bsdf(..., adjoint=True)); the "
                       "1/eta^2 belongs to radiance, i.e. to camera paths")
            out[-1] = Hint(out[-1], ("adjoint_bsdf",))
            return out
    cosines = _pixel_cosines(check, mean.shape)
    lum_test, lum_ref = mean @ LUMINANCE, ref @ LUMINANCE
    sum_ref = _tile_sums(lum_ref)
    lit = sum_ref > 1e-3 * sum_ref.max()
    ratio = _tile_sums(lum_test)[lit] / sum_ref[lit]
    cos_tile = _tile_sums(cosines)[lit] / 64
    if len(ratio) >= 4 and np.all(ratio > 0):
        slope, intercept = np.polyfit(np.log(cos_tile), np.log(ratio), 1)
        fitted = intercept + slope * np.log(cos_tile)
        residual = np.log(ratio) - fitted
        explained = 1 - residual.var() / max(np.log(ratio).var(), 1e-300)
        centre, edge = np.exp(intercept), np.exp(intercept + slope * np.log(cosines.min()))
        if abs(slope) >= 0.5 and explained >= 0.6:
            out.append(f"the error follows the angle theta to the optical axis: yours / Mitsuba's "
                       f"is x{centre:.2f} at the centre and x{edge:.2f} in the corners, "
                       f"~cos^{slope:.1f} theta ({100 * explained:.0f} % of the tiles' spread): "
                       "the camera importance is wrong: We = 1 / (A cos^3 theta) (A: the film's "
                       "area on the plane at distance 1; the cos^3 converts the film's area "
                       "density to solid angle), and a splat is value * We / d^2 (the pinhole "
                       "has no pdf of its own)")
            out[-1] = Hint(out[-1], ("camera_importance",))
        elif np.all(np.abs(ratio / np.median(ratio) - 1) <= 2 * LIGHT_TOLERANCE) \
                and abs(np.median(ratio) - 1) > LIGHT_TOLERANCE:
            out.append(f"the whole image is x{np.median(ratio):.2f} (every tile within "
                       f"{100 * 2 * LIGHT_TOLERANCE:.0f} % of that): a constant factor in the "
                       "importance (We = 1 / (A cos^3 theta) with A = 4 tan(fov_x/2) "
                       "tan(fov_y/2)) or in the light paths' starting weight Le cos / (p_light "
                       "p_position p_direction)")
            out[-1] = Hint(out[-1], ("camera_importance", "light_start_weight"))
    return out
