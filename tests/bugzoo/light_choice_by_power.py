"""Lights chosen by power, weighted as if chosen uniformly: direct illumination picks light k
with probability P_k / sum(P) (P = radiance x area, in luminance) but still divides by the
uniform 1/N, in the shadow ray's weight and in the MIS weights alike.

With one light nothing changes; in cornell-lights the ceiling light (about 2/3 of the power)
is chosen twice as often as the wall light, so what it lights is too bright and what the
wall light lights is too dark.
Expected hint: the probability of choosing each light must be the one divided by.
"""
import numpy as np
from _mutate import (
    camera_rays,  # noqa: F401  (the reference camera)
    mutate,
    registry,
)

from pathtracer.integrators import base, direct

BUG = "lights chosen proportionally to power, divided by the uniform 1/N"
CHECK = "direct-lights"
EXPECTED = ("choosing each light",)

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


def _by_power(sample_emitter):
    def buggy(scene, hit, u_choice, u, test_visibility=True, emitter=None):
        if emitter is not None or scene.num_emitters < 2:
            return sample_emitter(scene, hit, u_choice, u, test_visibility, emitter)
        power = np.array([scene.shape_area[e.shape] * float(np.asarray(e.radiance) @ LUMINANCE)
                          for e in scene.emitters])
        cdf = np.cumsum(power) / power.sum()
        which = np.minimum(np.searchsorted(cdf, u_choice, side="right"), len(cdf) - 1)
        n = scene.num_emitters
        out = None
        for k in range(n):
            rows = np.flatnonzero(which == k)
            # One light's sample (no choice factor), then the uniform 1/N the student assumed.
            part = sample_emitter(scene, _rows(hit, rows), u_choice[rows], u[rows],
                                  test_visibility, emitter=k)
            part.pdf = np.where(part.delta, part.pdf, part.pdf / n)
            part.weight = part.weight * n
            if out is None:
                out = _empty(part, len(u_choice))
            for name in ("wo", "dist", "pdf", "weight", "delta"):
                getattr(out, name)[rows] = getattr(part, name)
        return out
    return buggy


def _rows(hit, rows):
    from pathtracer.integrators.base import subset_hit
    return subset_hit(hit, rows)


def _empty(like, n):
    from pathtracer.emitters import EmitterSample
    return EmitterSample(np.zeros((n, 3)), np.full(n, np.inf), np.zeros(n), np.zeros((n, 3)),
                         np.zeros(n, dtype=bool))


# Shadow rays are sampled in base.Integrator.sample_direct.
INTEGRATORS = registry(mutate(direct.DirectIntegrator, base, sample_emitter=_by_power))
