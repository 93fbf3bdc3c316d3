"""MIS weight with its arguments swapped: path weights the emission its BSDF samples find by
power_heuristic(pdf_light, pdf_bsdf), the light sample's weight, instead of
power_heuristic(pdf_bsdf, pdf_light); its shadow rays keep the right weight. The two weights
of one light path then sum to 2 w_light, not 1, and a light seen by the camera (pdf_bsdf = 1
for the camera ray, pdf_light = 0) gets weight 0: directly visible lights vanish.

(Mixing the power and the balance heuristic, the first version of this mutant, changed the
Cornell box by too little to fail the check.)
True cause: the MIS weights.
"""
from _zoo import camera_rays, mutate, registry  # noqa: F401

from pathtracer.core.sampling import power_heuristic
from pathtracer.integrators import path

BUG = "BSDF-sampled emission weighted power_heuristic(pdf_light, pdf_bsdf)"
CHECKS = ("path-cornell-box",)
CAUSE = "mis_weights"


def _swapped(heuristic):
    def buggy(pdf_a, pdf_b):
        return heuristic(pdf_b, pdf_a)
    return buggy


class MutantPath(mutate(path.PathIntegrator, path, power_heuristic=_swapped)):
    def sample_direct(self, scene, paths, beta=None, mis_weight=None, emitter=None):
        return super().sample_direct(scene, paths, beta, power_heuristic, emitter)


INTEGRATORS = registry(MutantPath)
