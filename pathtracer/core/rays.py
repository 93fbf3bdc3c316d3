"""A batch of rays: what cameras and lights start, integrators trace and spawn."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class Rays:
    """A batch of rays: origins ``o`` (n,3), unit directions ``d`` (n,3), ``tmax`` (n,)."""

    o: np.ndarray
    d: np.ndarray
    tmax: np.ndarray

    def __len__(self) -> int:
        return self.o.shape[0]

    def subset(self, index: np.ndarray) -> "Rays":
        return Rays(self.o[index], self.d[index], self.tmax[index])
