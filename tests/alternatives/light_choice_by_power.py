"""Lights chosen proportionally to their power, with the matching pdf: ``path_nee``, ``path``
and ``direct`` pick light k with probability P_k / sum(P) (P = luminance of the radiance x
area) instead of 1/N, and divide by that probability: in the shadow ray's pdf and, for the
MIS integrators, in the light pdf of BSDF-sampled directions that hit light k.

Any choice probabilities that are > 0 for every light give an unbiased estimator when the
same probabilities divide; the variance moves (brighter lights get more shadow rays).
"""
import numpy as np
from _common import (
    camera_rays,  # noqa: F401  (the reference camera)
    registry,
)

from pathtracer.emitters import EmitterSample, hit_emitter
from pathtracer.integrators import base, direct, path, path_nee
from pathtracer.integrators.base import subset_hit

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


def choice_probabilities(scene) -> np.ndarray:
    """P_k / sum(P) for area lights; uniform if any light is not an area light."""
    if any(e.kind != "area" for e in scene.emitters):
        return np.full(scene.num_emitters, 1.0 / scene.num_emitters)
    power = np.array([scene.shape_area[e.shape] * float(np.asarray(e.radiance) @ LUMINANCE)
                      for e in scene.emitters])
    return power / power.sum()


def _sample(sample_emitter):
    def by_power(scene, hit, u_choice, u, test_visibility=True, emitter=None):
        if emitter is not None or scene.num_emitters < 2:
            return sample_emitter(scene, hit, u_choice, u, test_visibility, emitter)
        prob = choice_probabilities(scene)
        which = np.minimum(np.searchsorted(np.cumsum(prob), u_choice, side="right"),
                           len(prob) - 1)
        count = len(u_choice)
        out = EmitterSample(np.zeros((count, 3)), np.full(count, np.inf), np.zeros(count),
                            np.zeros((count, 3)), np.zeros(count, dtype=bool))
        for k in np.unique(which):
            rows = np.flatnonzero(which == k)
            part = sample_emitter(scene, subset_hit(hit, rows), u_choice[rows], u[rows],
                                  test_visibility, emitter=int(k))
            # The sample of light k alone, then the probability of having chosen it.
            part.pdf = np.where(part.delta, part.pdf, part.pdf * prob[k])
            part.weight = part.weight / prob[k]
            for name in ("wo", "dist", "pdf", "weight", "delta"):
                getattr(out, name)[rows] = getattr(part, name)
        return out
    return by_power


def _pdf(pdf_emitter_direction):
    def by_power(scene, ref_p, hit, d):
        pdf = pdf_emitter_direction(scene, ref_p, hit, d)      # includes the uniform 1/N
        if scene.num_emitters < 2:
            return pdf
        k = hit_emitter(scene, hit)
        prob = choice_probabilities(scene)
        scale = np.where(k >= 0, prob[np.maximum(k, 0)] * scene.num_emitters, 1.0)
        return pdf * scale
    return by_power


def _by_power(reference, module):
    """``reference`` with lights chosen by power: in its shadow rays (sampled in
    base.Integrator.sample_direct) and in the light pdf its ``module`` evaluates, if any."""
    class ByPower(reference):
        def radiance(self, scene, rays, rng):
            saved_sample = base.sample_emitter
            saved_pdf = getattr(module, "pdf_emitter_direction", None)
            base.sample_emitter = _sample(saved_sample)
            if saved_pdf is not None:
                module.pdf_emitter_direction = _pdf(saved_pdf)
            try:
                return super().radiance(scene, rays, rng)
            finally:
                base.sample_emitter = saved_sample
                if saved_pdf is not None:
                    module.pdf_emitter_direction = saved_pdf
    ByPower.__name__ = f"ByPower{reference.__name__}"
    return ByPower


INTEGRATORS = registry(_by_power(path_nee.PathNEEIntegrator, path_nee),
                       _by_power(path.PathIntegrator, path),
                       _by_power(direct.DirectIntegrator, direct))

#: The integrators that differ from the reference solution (the grader's tests grade their checks).
CHANGES = ('path_nee', 'path', 'direct')
#: Scenes whose checks it is not graded on: with one light the choice has probability 1 either
#: way, so its images there are the reference's bit for bit (tests/test_autograder.py proves it).
SAME_AS_REFERENCE = ('cornell-box', 'cornell-caustics', 'glass-cube')
