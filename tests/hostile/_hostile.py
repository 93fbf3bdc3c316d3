"""Shared plumbing of the hostile zoo: a registry of integrators whose radiance is an attack.

Each hostile submission is written as a student who has read the grader's source would
write it: it uses only what a submission may import (the tracer's building blocks, NumPy,
the standard library) and returns a black image when its attack fails, so a submission
that gets any point has cheated.
"""
import numpy as np

from pathtracer.integrators.base import Integrator

NAMES = ("path", "path_bsdf", "path_nee", "direct")


def black(rays):
    return np.zeros((len(rays), 3))


def registry(radiance) -> dict:
    """Every graded integrator name -> a class whose radiance is ``radiance``."""
    return {name: type(f"Hostile_{name}", (Integrator,), {"name": name, "radiance": radiance})
            for name in NAMES}
