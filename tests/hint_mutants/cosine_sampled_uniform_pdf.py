"""Cosine-weighted directions divided by the uniform pdf: path_bsdf samples the diffuse lobe
cosine-weighted but divides f cos by 1 / (2 pi), the pdf of uniform hemisphere sampling
(every bounce's weight 2 rho cos theta instead of rho).

Direct light (found by BSDF sampling) is already too bright, by 4/3 on average.
True cause: the BSDF sampling weight (its pdf).
"""
import numpy as np
from _zoo import camera_rays, mutate, registry  # noqa: F401

from pathtracer.integrators import path_bsdf

BUG = "cosine-sampled direction weighted f cos / (1 / 2 pi)"
CHECKS = ("path_bsdf-cornell-box",)
CAUSE = "bsdf_sampling_weight"


def _uniform_pdf(sample_bsdf):
    def buggy(scene, hit, wi, u1, u2, hemisphere="cosine"):
        bs = sample_bsdf(scene, hit, wi, u1, u2, hemisphere)
        smooth = ~np.asarray(bs.delta) & (bs.pdf > 0)
        factor = np.where(smooth, bs.pdf * 2 * np.pi, 1.0)       # (f cos / pdf) * pdf / p_uniform
        bs.weight = bs.weight * factor[:, None]
        bs.pdf = np.where(smooth, 1 / (2 * np.pi), bs.pdf)
        return bs
    return buggy


INTEGRATORS = registry(mutate(path_bsdf.PathBSDFIntegrator, path_bsdf, sample_bsdf=_uniform_pdf))
