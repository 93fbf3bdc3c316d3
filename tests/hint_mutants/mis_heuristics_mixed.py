"""MIS weights that do not sum to one: path weights its shadow rays with the power heuristic
but the emission its BSDF samples find with the balance heuristic.

Direct light is slightly too bright where both strategies find the light.
True cause: the MIS weights.
"""
from _zoo import camera_rays, mutate, registry  # noqa: F401

from pathtracer.core.sampling import power_heuristic
from pathtracer.integrators import path

BUG = "power heuristic for the light sample, balance heuristic for the BSDF sample"
CHECKS = ("path-cornell-box",)
CAUSE = "mis_weights"


def _balance(_power):
    def balance(pdf_a, pdf_b):
        total = pdf_a + pdf_b
        return pdf_a / (total + (total == 0))
    return balance


class MutantPath(mutate(path.PathIntegrator, path, power_heuristic=_balance)):
    def sample_direct(self, scene, paths, beta=None, mis_weight=None, emitter=None):
        return super().sample_direct(scene, paths, beta, power_heuristic, emitter)


INTEGRATORS = registry(MutantPath)
