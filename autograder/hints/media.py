"""Hints of the ``media`` assignment: what a volumetric path tracer's evidence says.

The checks render ``media-box``: a fog cube behind an index-matched (null) boundary floats
above the floor of a box lit from the ceiling. The image splits into *fog pixels* (the camera
ray enters the fog) and *clear pixels* (it never does: walls, floor, ceiling, the light; the
floor under the fog lies in its shadow). Each of the lecture's four classic mistakes leaves its
own pattern in the per-bounce sweep (the student's renders at max_depth = 1, 2, 3 against
Mitsuba's ``volpath`` at the same depths) and across the two regions:

* shadow rays without transmittance (``volpath``): direct light (max_depth = 2) too bright,
  in the clear pixels too (the fog's shadow on the floor is too light), while
  ``volpath_phase``, which has no shadow rays, is right;
* the phase function's pdf not cancelled (``beta *= p`` instead of ``p / pdf = 1``): the
  fog's light far too dark (by about the phase function's value), the clear pixels' direct
  light right;
* the free-flight pdf wrong (the density instead of the probability of reaching the
  surface): what is seen *through* the fog scaled by ``1 / sigma_t``;
* the medium ignored at index-matched boundaries: paths never enter the fog, so the fog pixels
  see the wall behind it unattenuated and the floor in its shadow is lit (both too bright at
  max_depth = 2); a fog too bright while its shadow is right still attenuates: its scattering
  events weigh too much (the free-flight pdf or the phase function's weight).

Each rule quotes the numbers it rests on; hints are explanations, never points.
"""
from __future__ import annotations

import math

import numpy as np

from mitsuba_refs.verdicts.explain import Hint
from mitsuba_refs.verdicts.scenes import default_params
from pathtracer import load_scene
from pathtracer.core.color import LUMINANCE
from pathtracer.sensors.perspective import camera_rays
from pathtracer.shapes.intersect import intersect

#: A region counts as wrong (for explanations) beyond this relative brightness error.
REGION_TOLERANCE = 0.05
#: Fog light at most this fraction of Mitsuba's: the fog has (almost) vanished.
VANISHED = 0.35
#: The causes of a scattering event's wrong weight.
SCATTER_CAUSES = ("free_flight_pdf", "phase_pdf")
SHADOW_TEXT = ("the transmittance of the shadow rays from the fog to the light, T = "
               "exp(-sigma_t d) over the distance d inside the fog")
#: The causes the surface rule lists (the surface steps of a path tracer).
SURFACE_CAUSES = ("mis_weights", "light_pdf_cosine", "light_pdf_distance", "bsdf_sampling_weight")


def fog_pixels(scene_name: str, params: dict) -> tuple:
    """(fog, clear): boolean (h, w) masks of the pixels whose camera rays, at the 4 corners of
    a 2 x 2 grid inside the pixel, all enter a medium (first hit on a medium boundary) or all
    do not; pixels on the fog's outline are in neither."""
    scene = load_scene(scene_name, **params)
    camera = scene.camera
    w, h = camera.width, camera.height
    pixel = np.repeat(np.arange(w * h), 4)
    u = np.tile([[0.25, 0.25], [0.75, 0.25], [0.25, 0.75], [0.75, 0.75]], (w * h, 1))
    rays = camera_rays(camera, pixel, u)
    hit = intersect(scene, rays.o, rays.d, rays.tmax)
    enters = np.zeros(len(pixel), dtype=bool)
    interior = getattr(scene, "shape_interior", None)
    if interior is not None:
        shape = hit.shape[hit.valid]
        enters[hit.valid] = (interior[shape] >= 0) | (scene.shape_exterior[shape] >= 0)
    count = enters.reshape(h, w, 4).sum(axis=2)
    return count == 4, count == 0


def added_region_ratio(sweep, depth, mask) -> float:
    """Ratio, over ``mask``, of what max_depth = ``depth`` adds to max_depth - 1 (student /
    Mitsuba, both on top of Mitsuba's render at depth - 1)."""
    _, test, ref = sweep[depth]
    base = sweep[depth - 1][2] if depth - 1 in sweep else np.zeros_like(ref)
    added_ref = float(((ref - base)[mask] @ LUMINANCE).sum())
    added_test = float(((test - base)[mask] @ LUMINANCE).sum())
    return added_test / added_ref if added_ref > 0 else math.nan


def media_evidence(check, sweep) -> dict:
    """The numbers the media rules read: per region (fog / clear) the ratio of the light each
    depth of the sweep adds, and the regions' sizes."""
    fog, clear = fog_pixels(check.scene, default_params(check.scene))
    out = {"fog_pixels": int(fog.sum()), "clear_pixels": int(clear.sum())}
    for depth in sorted(sweep or {}):
        out[f"fog_{depth}"] = added_region_ratio(sweep, depth, fog)
        out[f"clear_{depth}"] = added_region_ratio(sweep, depth, clear)
    return out


def _numbers(facts: dict, sweep) -> str:
    per_depth = "; ".join(
        f"max_depth={d}: fog x{facts[f'fog_{d}']:.2f}, clear x{facts[f'clear_{d}']:.2f}"
        for d in sorted(sweep) if d > 1 and math.isfinite(facts.get(f"fog_{d}", math.nan)))
    return (f"(what each max_depth adds, yours / Mitsuba's, in the {facts['fog_pixels']} pixels "
            f"that look into the fog and the {facts['clear_pixels']} that do not: {per_depth})")


def _added(ratio: float) -> str:
    """``x0.43``, or in words when (almost) nothing of Mitsuba's is left."""
    return f"x{ratio:.2f}" if ratio >= 0.05 else f"almost nothing of Mitsuba's (x{ratio:.2f})"


def explain_media(ev) -> list:
    """Likely causes of a failed media check, most specific first, each with its numbers."""
    sweep, check = ev.sweep, ev.check
    if ev.comparison.mean.agree or not sweep or 2 not in sweep:
        return []
    facts = media_evidence(check, sweep)
    numbers = _numbers(facts, sweep)
    fog2, clear2 = facts["fog_2"], facts["clear_2"]
    fog3 = facts.get("fog_3", math.nan)
    image = f"image x{1 + ev.comparison.mean.rel_bias:.3f}"
    out = []
    phase = ev.history.get("volpath_phase-media")
    if check.integrator == "volpath" and phase is not None and not phase.passed:
        out.append(Hint("fix volpath_phase first: it fails too, and volpath shares its segment "
                        "loop and surface step"))
    if check.integrator == "volpath" and clear2 > 1 + REGION_TOLERANCE:
        phase_ok = (" volpath_phase, which has no shadow rays, passed;"
                    if phase is not None and phase.passed else "")
        out.append(f"direct light too bright, also on surfaces outside the fog (the floor in its "
                   f"shadow), {image}:{phase_ok} the transmittance along shadow rays is missing: "
                   "a shadow ray through a medium carries T = exp(-sigma_t d) (estimated with "
                   "the free-flight sampling: shadow_transmittance), not just the visibility of "
                   f"the null boundaries it crosses {numbers}")
        out[-1] = Hint(out[-1], ("shadow_transmittance",))
    elif fog2 > 1 + REGION_TOLERANCE and clear2 <= 1 + REGION_TOLERANCE:
        # The fog's own light too bright while what lies in its shadow is not: the fog still
        # attenuates, so it is entered; its scattering events weigh too much.
        shared = ("the free-flight pdf (a distance t < s is sampled with density sigma_t "
                  "exp(-sigma_t t): weight T sigma_s / pdf = albedo) or the phase function's "
                  "weight (p / pdf = 1)")
        if check.integrator != "volpath":
            what, causes = f"a scattering event weighs too much: {shared}", SCATTER_CAUSES
        elif phase is not None and phase.passed:
            what = f"volpath_phase, which shares the scattering step, passed: {SHADOW_TEXT}"
            causes = ("shadow_transmittance",)
        else:
            what = f"{SHADOW_TEXT}, or a scattering event weighs too much: {shared}"
            causes = ("shadow_transmittance",) + SCATTER_CAUSES
        out.append(Hint(f"light from the fog too bright (x{fog2:.2f} at max_depth = 2 in its "
                        f"pixels, x{fog3:.2f} at 3) while the floor in its shadow is not (x"
                        f"{clear2:.2f}), {image}: the fog is entered and attenuates; {what} "
                        f"{numbers}", causes))
    elif fog2 > 1 + REGION_TOLERANCE:
        out.append(f"the fog's pixels too bright at max_depth = 2 (x{fog2:.2f}), and the floor in "
                   f"its shadow too (x{clear2:.2f}), {image}: your "
                   "camera paths do not enter the fog, and see the wall behind it unattenuated: "
                   "the medium must be tracked at null boundaries (index-matched, eta = 1) too: "
                   "crossing a null BSDF is not a scattering event, but the ray is then in the "
                   "shape's interior (or exterior) medium (next_medium on every crossing)")
        out[-1] = Hint(f"{out[-1]} {numbers}", ("null_boundary",))
    elif fog2 < 1 - REGION_TOLERANCE:
        compounding = math.isfinite(fog3) and fog3 < VANISHED
        phase_text = ("the phase function's pdf not cancelled: a direction sampled from the "
                      "phase function has weight p / pdf = 1 (the pdf cancels), never beta *= p")
        flight_text = ("the free-flight pdf wrong: a distance t < s is sampled with density "
                       "sigma_t exp(-sigma_t t) (weight T sigma_s / pdf = albedo), the surface "
                       "at s is reached with probability exp(-sigma_t s) (weight T / P = 1), "
                       "not with the density")
        first, second = (phase_text, flight_text) if compounding else (flight_text, phase_text)
        depth3 = (f"what max_depth = 3 adds there is {_added(fog3)}: the error compounds with "
                  "every scattering event" if compounding else
                  f"what max_depth = 3 adds there is x{fog3:.2f}: about the same factor, once "
                  "per passage through the fog")
        volpath = check.integrator == "volpath"
        shadow = f"; or {SHADOW_TEXT} (too small)" if volpath else ""
        extra = ("shadow_transmittance",) if volpath else ()
        out.append(Hint(f"light from the fog too dark (x{fog2:.2f} at max_depth = 2 in its "
                        f"pixels, the rest x{clear2:.2f}), {image}; {depth3}; most likely first: "
                        f"{first}; or {second}{shadow} {numbers}", SCATTER_CAUSES + extra))
    elif abs(clear2 - 1) > REGION_TOLERANCE:
        out.append(f"direct light on the surfaces outside the fog x{clear2:.2f} (the fog's pixels "
                   f"x{fog2:.2f}), {image}: the surface steps, as in path tracing: emission "
                   "found (MIS weight against the last scattering event's light sample), the "
                   "shadow ray's light pdf and MIS weight, the BSDF sample's weight f cos / pdf "
                   f"{numbers}")
        out[-1] = Hint(out[-1], SURFACE_CAUSES + (("shadow_transmittance",)
                                                  if check.integrator == "volpath" else ()))
    elif not out and 1 in sweep and abs(sweep[1][0].rel_bias) > REGION_TOLERANCE:
        out.append(f"light sources seen directly are wrong (max_depth = 1: "
                   f"x{1 + sweep[1][0].rel_bias:.3f}): add Le where a camera ray hits an emitter, "
                   f"with the throughput of its way there {numbers}")
        out[-1] = Hint(out[-1], ("visible_emission",))
    elif not out:
        out.append(f"{image} with the fog and its surroundings right at max_depth 1-2: longer "
                   "paths: roulette after rr_depth scattering events (divide by q), or the "
                   f"throughput of multiple scattering {numbers}")
        out[-1] = Hint(out[-1], ("roulette", "free_flight_pdf", "phase_pdf"))
    return out
