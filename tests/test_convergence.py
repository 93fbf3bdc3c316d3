"""The convergence law for every integrator on every built-in scene: 4x samples, half the error.

For each (scene, integrator) pair: ``REPLICAS`` independent renders at each
spp of ``LADDER``; MSE against the committed Mitsuba reference, minus the
reference's own variance contribution; the fitted log-log slope of MSE must be
compatible with -1, RMSE(N)/RMSE(4N) with 2, and the MSE must show no bias
floor (mitsuba_refs.stats.convergence_law). Select these with
``pytest -k convergence``. A tracer that reuses its random numbers fails here
(test_convergence_catches_reused_random_numbers).
"""
import numpy as np
import pytest

from mitsuba_refs.compare import compare
from pathtracer.integrators.path import PathIntegrator
from tests.budget import ALPHA
from tests.scenes import AGREEMENT_CASES, integrator_options

LADDER = (1, 4, 16)
REPLICAS = 4


@pytest.mark.parametrize("scene,integrator", AGREEMENT_CASES)
def test_convergence_law(scene, integrator):
    comparison = compare(scene, integrator, spp=1, alpha=ALPHA, convergence=True, bounces=False,
                         processes=2, ladder=LADDER, replicas=REPLICAS,
                         options=integrator_options(integrator))
    law = comparison.convergence
    assert law.passed, comparison.report()


class ReusedRandomNumbers(PathIntegrator):
    """A broken tracer: every sample of every pixel draws the same path random numbers."""

    name = "path"

    def radiance(self, scene, rays, rng):
        rng.keys = np.zeros_like(rng.keys)
        return super().radiance(scene, rays, rng)


def test_convergence_catches_reused_random_numbers():
    comparison = compare("cornell-box", ReusedRandomNumbers(), spp=1, alpha=ALPHA, convergence=True,
                         bounces=False, processes=2, ladder=LADDER, replicas=REPLICAS)
    law = comparison.convergence
    assert not law.passed and law.correlated, comparison.report()
