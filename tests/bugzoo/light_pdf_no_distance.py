"""Light pdf without the distance squared: direct lighting converts the area pdf 1/A of a
light sample to solid angle as 1/(|cos| A), forgetting the d^2 (in the shadow-ray weight and
in the MIS weight of BSDF samples alike).

Direct light (bounce 2) is wrong, brighter where the light is far.
Expected hint: light-sampling pdf (distance squared).
"""
from _lightpdf import hit_distance2, scale_sample
from _mutate import (
    camera_rays,  # noqa: F401  (the reference camera)
    mutate,
    registry,
)

from pathtracer.integrators import base, direct

BUG = "light pdf = 1/(|cos| A): the distance squared is missing"
CHECK = "direct-cornell-box"
EXPECTED = ("distance",)


def _sample(sample_emitter):
    def buggy(scene, hit, u_choice, u, test_visibility=True, emitter=None):
        sample = sample_emitter(scene, hit, u_choice, u, test_visibility, emitter)
        return scale_sample(sample, 1.0 / sample.dist ** 2)
    return buggy


def _pdf(pdf_emitter_direction):
    def buggy(scene, ref_p, hit, d):
        return pdf_emitter_direction(scene, ref_p, hit, d) / hit_distance2(ref_p, hit)
    return buggy


# Shadow rays are sampled in base.Integrator.sample_direct, the light pdf of BSDF-sampled
# hits is evaluated in direct.py.
INTEGRATORS = registry(mutate(mutate(direct.DirectIntegrator, direct, pdf_emitter_direction=_pdf),
                              base, sample_emitter=_sample))
