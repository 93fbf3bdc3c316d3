"""Plumbing of the hint mutants: the reference registry with one integrator replaced.

The grader lets a submission read only its own folder, so this folder cannot import the bug
zoo's ``_mutate``; these are the few pieces its mutants use, in the same sense: ``registry``
(the reference INTEGRATORS with some classes replaced), ``patched`` (module-level names
replaced for a block) and ``mutate`` (a subclass whose ``radiance`` sees one helper of a
module replaced by a buggy version of it), and two facts of the light sample's solid-angle
pdf p = d^2 / (A |cos theta_light|).
"""
from __future__ import annotations

from contextlib import contextmanager

import numpy as np

from pathtracer.camera import camera_rays  # noqa: F401  (re-exported: the reference camera)
from pathtracer.integrators import INTEGRATORS as REFERENCE


def registry(*mutants) -> dict:
    out = dict(REFERENCE)
    out.update({cls.name: cls for cls in mutants})
    return out


@contextmanager
def patched(module, **replacements):
    saved = {name: getattr(module, name) for name in replacements}
    try:
        for name, value in replacements.items():
            setattr(module, name, value)
        yield saved
    finally:
        for name, value in saved.items():
            setattr(module, name, value)


def mutate(base, module, **factories):
    """``base`` whose ``radiance`` runs with ``module.name = factory(original)``."""
    class Mutant(base):
        def radiance(self, scene, rays, rng):
            buggy = {name: make(getattr(module, name)) for name, make in factories.items()}
            with patched(module, **buggy):
                return super().radiance(scene, rays, rng)
    Mutant.__name__ = Mutant.__qualname__ = f"Mutant{base.__name__}"
    return Mutant


def chosen_light(scene, u_choice, emitter=None) -> np.ndarray:
    """Index of the emitter each sample chose (uniform choice, as sample_emitter does)."""
    n = scene.num_emitters
    if emitter is not None:
        return np.full(len(u_choice), emitter)
    return np.minimum((u_choice * n).astype(np.int64), n - 1)


def light_area(scene, which) -> np.ndarray:
    return np.array([scene.shape_area[e.shape] if e.kind == "area" else 1.0
                     for e in scene.emitters])[which]


def scale_pdf(sample, factor):
    """The light sample's pdf times ``factor`` (its weight divided by it), area lights only."""
    rows = ~sample.delta & np.isfinite(sample.dist) & (sample.pdf > 0)
    f = np.where(rows, factor, 1.0)
    sample.pdf = sample.pdf * f
    sample.weight = sample.weight / f[:, None]
    return sample
