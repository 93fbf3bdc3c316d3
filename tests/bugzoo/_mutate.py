"""Shared plumbing of the bug zoo: a registry with one integrator replaced, and patching.

Every mutant is an implementation in the student's contract (``INTEGRATORS``, optionally
``camera_rays``): the reference solution with exactly one integrator (or the camera) broken.
Many bugs live in a helper an integrator calls (its BSDF sampling, its light pdf, ...); such a
mutant subclasses the reference integrator and runs the reference ``radiance`` with that one
helper replaced by a buggy version *inside the module that calls it*: the integrator's own
module, or for the steps every integrator shares, ``integrators/base.py`` (emission, shadow
rays) and ``integrators/wavefront.py`` (the next ray of a path). The replacement lasts only
while that integrator's ``radiance`` runs, and the grader runs each submission in its own
process, so nothing else sees the change. Control-flow bugs override a
method or copy the loop with one line changed.

Module attributes every mutant defines:

``BUG``       the mistake, in a sentence
``CHECK``     the id of the check that must lose points (autograder.grading.CHECKS)
``EXPECTED``  keywords, one of which the hint must contain (case-insensitive)
``PARTIAL``   optional: True when the check keeps some of its points (mean right)
"""
from __future__ import annotations

from contextlib import contextmanager

from pathtracer.camera import camera_rays  # noqa: F401  (re-exported: the reference camera)
from pathtracer.integrators import INTEGRATORS as REFERENCE


def registry(*mutants) -> dict:
    """The reference INTEGRATORS with the given classes replacing those of the same name."""
    out = dict(REFERENCE)
    for cls in mutants:
        out[cls.name] = cls
    return out


@contextmanager
def patched(module, **replacements):
    """Replace module-level names for the duration of a block."""
    saved = {name: getattr(module, name) for name in replacements}
    try:
        for name, value in replacements.items():
            setattr(module, name, value)
        yield saved
    finally:
        for name, value in saved.items():
            setattr(module, name, value)


def mutate(base, module, **factories):
    """A subclass of ``base`` whose ``radiance`` sees ``module.name = factory(original)``."""

    class Mutant(base):
        def radiance(self, scene, rays, rng):
            buggy = {name: make(getattr(module, name)) for name, make in factories.items()}
            with patched(module, **buggy):
                return super().radiance(scene, rays, rng)

    Mutant.__name__ = f"Mutant{base.__name__}"
    Mutant.__qualname__ = Mutant.__name__
    return Mutant


def mutate_splat(base, module, **factories):
    """:func:`mutate` for a light tracer: its ``splat`` sees ``module.name = factory(original)``."""

    class Mutant(base):
        def splat(self, scene, rng, *args):
            buggy = {name: make(getattr(module, name)) for name, make in factories.items()}
            with patched(module, **buggy):
                return super().splat(scene, rng, *args)

    Mutant.__name__ = f"Mutant{base.__name__}"
    Mutant.__qualname__ = Mutant.__name__
    return Mutant
