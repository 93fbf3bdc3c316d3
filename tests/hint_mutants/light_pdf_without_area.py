"""The light pdf without its area: path_nee's shadow ray divides by d^2 / cos_light, the
solid-angle pdf of a unit-area light, instead of d^2 / (A cos_light).

Direct light is scaled by the light's 1/A everywhere (a constant factor).
True cause: the light-sampling pdf (its area factor).
"""
from _zoo import camera_rays, chosen_light, light_area, mutate, registry, scale_pdf  # noqa: F401

from pathtracer.integrators import base, path_nee

BUG = "light sample's pdf d^2 / cos without the 1/A of the area"
CHECKS = ("path_nee-cornell-box",)
CAUSE = "light_pdf_area"


def _without_area(sample_emitter):
    def buggy(scene, hit, u_choice, u, test_visibility=True, emitter=None):
        sample = sample_emitter(scene, hit, u_choice, u, test_visibility, emitter)
        area = light_area(scene, chosen_light(scene, u_choice, emitter))
        return scale_pdf(sample, area)
    return buggy


INTEGRATORS = registry(mutate(path_nee.PathNEEIntegrator, base, sample_emitter=_without_area))
