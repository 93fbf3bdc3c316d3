"""Missing pdf: path_bsdf multiplies the throughput by f cos and forgets to divide by the
pdf of the sampled direction (beta *= f cos instead of f cos / p).

With cosine sampling p = cos/pi, so every bounce is about cos/pi too dark: direct light
(reached by BSDF sampling here, bounce 2) is already ~1/pi as bright.
Expected hint: darker by a factor near pi / a pdf used wrongly.
"""
import numpy as np
from _mutate import (
    camera_rays,  # noqa: F401  (the reference camera)
    mutate,
    registry,
)

from pathtracer.integrators import path_bsdf

BUG = "throughput times f cos, not divided by the sampling pdf"
CHECK = "path_bsdf-cornell-box"
EXPECTED = ("pdf",)


def _without_pdf(sample_bsdf):
    def buggy(scene, hit, wi, u1, u2, hemisphere="cosine"):
        bs = sample_bsdf(scene, hit, wi, u1, u2, hemisphere)
        smooth = ~bs.delta
        bs.weight = np.where(smooth[:, None], bs.weight * bs.pdf[:, None], bs.weight)
        return bs
    return buggy


INTEGRATORS = registry(mutate(path_bsdf.PathBSDFIntegrator, path_bsdf, sample_bsdf=_without_pdf))
