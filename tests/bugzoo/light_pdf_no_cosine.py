"""Light pdf without the cosine at the light: the MIS path tracer converts the area pdf of a
light sample to solid angle as d^2 / A, forgetting the |cos theta_light| (in the shadow-ray
weight and in the MIS weight of BSDF samples alike).

Direct light (bounce 2) is too bright, most where the light is seen at a grazing angle.
Expected hint: light-sampling pdf (cosine at the light).
"""
from _lightpdf import hit_cosine, light_cosine, scale_sample
from _mutate import (
    camera_rays,  # noqa: F401  (the reference camera)
    mutate,
    registry,
)

from pathtracer.integrators import base, path

BUG = "light pdf = d^2 / A: the cosine at the light is missing"
CHECK = "path-cornell-box"
EXPECTED = ("cosine",)


def _sample(sample_emitter):
    def buggy(scene, hit, u_choice, u, test_visibility=True, emitter=None):
        sample = sample_emitter(scene, hit, u_choice, u, test_visibility, emitter)
        return scale_sample(sample, light_cosine(scene, sample, u_choice, emitter))
    return buggy


def _pdf(pdf_emitter_direction):
    def buggy(scene, ref_p, hit, d):
        return pdf_emitter_direction(scene, ref_p, hit, d) * hit_cosine(hit, d)
    return buggy


# Shadow rays are sampled in base.Integrator.sample_direct, the light pdf of BSDF-sampled
# hits is evaluated in path.py.
INTEGRATORS = registry(mutate(mutate(path.PathIntegrator, path, pdf_emitter_direction=_pdf),
                              base, sample_emitter=_sample))
