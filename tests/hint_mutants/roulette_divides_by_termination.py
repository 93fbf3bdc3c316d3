"""Russian roulette divided by the wrong probability: path_bsdf continues a path with
probability q (Mitsuba's rule) but divides the survivors by 1 - q, the probability of
stopping.

Paths longer than rr_depth carry the wrong weight; bounces 1-3 are right.
True cause: Russian roulette.
"""
import numpy as np
from _zoo import camera_rays, registry  # noqa: F401

from pathtracer.core.vec import max_component, unscale
from pathtracer.integrators import path_bsdf

BUG = "roulette survivors divided by 1 - q (the stop probability) instead of q"
CHECKS = ("path_bsdf-cornell-box",)
CAUSE = "roulette"


class MutantPathBSDF(path_bsdf.PathBSDFIntegrator):
    def roulette_survivors(self, beta, eta, depth, u):
        playing = np.asarray(depth) >= self.rr_depth
        if not playing.any():
            return np.ones(len(u), dtype=bool), beta
        q = np.minimum(max_component(beta) * eta ** 2, 0.95)
        survive = (u < q) | ~playing
        return survive, unscale(beta, np.where(playing, 1.0 - q, 1.0))


INTEGRATORS = registry(MutantPathBSDF)
