"""The result of a render: per-pixel mean and variance, and how they were made."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class RenderResult:
    """Per-pixel statistics of a render.

    Attributes
    ----------
    mean : (H, W, 3) float64 pixel values (mean of the samples).
    variance : (H, W, 3) float64 unbiased per-sample variance of each pixel.
    spp, seed : int
    integrator : str
    options : dict of the integrator's options.
    seconds : float wall-clock time.
    scene : str the scene's source.
    """

    mean: np.ndarray
    variance: np.ndarray
    spp: int
    seed: int
    integrator: str
    options: dict = field(default_factory=dict)
    seconds: float = 0.0
    scene: str = ""
