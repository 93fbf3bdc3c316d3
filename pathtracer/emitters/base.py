"""What the emitters share."""
from __future__ import annotations

import numpy as np

from ..scene import transform


def _rotation_only(plugin, props) -> np.ndarray:
    """``to_world`` of a light at infinity, refused when it scales (Mitsuba would not renormalise)."""
    m = props.transform("to_world")
    if transform.has_scale(m):
        raise plugin.error("to_world must not scale or shear a light at infinity (Mitsuba "
                           "would use unnormalised directions); use rotate or lookat",
                           props.line("to_world"))
    return m


def _sample_environment(emitter, u, sample, rows):
    """Constant or image environment: a direction drawn by the emitter's own density."""
    wo, pdf, radiance = emitter.sample(u)
    ok = pdf > 0
    sample.wo[rows] = wo
    sample.pdf[rows] = np.where(ok, pdf, 0.0)
    sample.weight[rows] = np.where(ok[:, None], radiance / np.where(ok, pdf, 1.0)[:, None], 0.0)
