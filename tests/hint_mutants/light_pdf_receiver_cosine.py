"""The light pdf with the wrong cosine: direct converts the light's area pdf to solid angle
with the cosine at the shaded point, d^2 / (A cos_surface), instead of the cosine at the
light, d^2 / (A cos_light).

Direct light is wrong by cos_surface / cos_light, unevenly over the room.
True cause: the cosine of the light-sampling pdf.
"""
import numpy as np
from _zoo import camera_rays, chosen_light, light_area, mutate, registry, scale_pdf  # noqa: F401

from pathtracer.integrators import base, direct
from pathtracer.vec import dot

BUG = "light pdf d^2 / (A cos) with the cosine at the receiver"
CHECKS = ("direct-cornell-box",)
CAUSE = "light_pdf_cosine"


def _receiver_cosine(sample_emitter):
    def buggy(scene, hit, u_choice, u, test_visibility=True, emitter=None):
        sample = sample_emitter(scene, hit, u_choice, u, test_visibility, emitter)
        n = 1 if emitter is not None else scene.num_emitters
        area = light_area(scene, chosen_light(scene, u_choice, emitter))
        with np.errstate(divide="ignore", invalid="ignore"):      # p = d^2 / (A cos_light N)
            cos_light = np.clip(sample.dist ** 2 / (sample.pdf * area * n), 1e-12, 1.0)
        cos_light = np.where(np.isfinite(cos_light), cos_light, 1.0)
        cos_here = np.clip(np.abs(dot(hit.n, sample.wo)), 1e-12, 1.0)
        return scale_pdf(sample, cos_light / cos_here)
    return buggy


INTEGRATORS = registry(mutate(direct.DirectIntegrator, base, sample_emitter=_receiver_cosine))
