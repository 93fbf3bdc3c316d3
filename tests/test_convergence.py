"""The convergence law for every integrator on every built-in scene: 4x samples, half the error.

For each (scene, integrator) pair (tests/scenes.py, CONVERGENCE_CASES): the same number of samples at every spp of
``LADDER`` (``REPLICAS`` renders at the top, 4x as many per 4x fewer spp, all
doubled while rare bright paths carry the error: mitsuba_refs.verdicts.convergence.convergence_test);
MSE against the committed Mitsuba reference, minus the reference's own variance
contribution; the fitted log-log slope of MSE must not lie significantly above -1
(one-sided: RMSE(N)/RMSE(4N) at least 2), and the MSE must show no bias floor
(mitsuba_refs.stats.convergence_law). Select these with
``pytest -k convergence``. A tracer that reuses its random numbers fails here
(test_convergence_catches_reused_random_numbers).
"""
import numpy as np
import pytest

from mitsuba_refs.report.wording import verdict_line
from mitsuba_refs.verdicts.convergence import CONVERGENCE_LADDER, check_convergence
from pathtracer.integrators.path import PathIntegrator
from tests.budget import ALPHA
from tests.scenes import CONVERGENCE_CASES, NOISELESS, integrator_options

pytestmark = pytest.mark.statistical(assertions=1)

LADDER = (1, 4, 16)
REPLICAS = 2


@pytest.mark.parametrize("scene,integrator", CONVERGENCE_CASES)
def test_convergence_law(scene, integrator):
    law, mse = check_convergence(scene, integrator, alpha=ALPHA, processes=2, ladder=LADDER,
                                 replicas=REPLICAS, options=integrator_options(integrator))
    assert law.passed, f"{verdict_line(law)}\nMSE per replica x spp {LADDER}:\n{mse}"


@pytest.mark.parametrize("scene,integrator", sorted(NOISELESS))
def test_convergence_noiseless_pairs_have_zero_error(scene, integrator):
    """Black on both sides (tests/scenes.py): no error to fall, and none at any spp."""
    from mitsuba_refs.reference.cache import get_reference
    from mitsuba_refs.verdicts.scenes import default_params, render_ours
    reference = get_reference(scene, default_params(scene), integrator, render=False)
    for spp in LADDER:
        mean, variance = render_ours(scene, integrator, default_params(scene), spp, 7, processes=2)
        assert not mean.any() and not variance.any() and not reference.mean.any()


class ReusedRandomNumbers(PathIntegrator):
    """A broken tracer: every sample of every pixel draws the same path random numbers."""

    name = "path"

    def radiance(self, scene, rays, rng):
        rng.keys = np.zeros_like(rng.keys)
        return super().radiance(scene, rays, rng)


def test_convergence_catches_reused_random_numbers():
    # The driver still jitters each camera sample, so the error first falls, then
    # plateaus: the full default ladder (up to 64 spp) is needed to see the floor.
    law, mse = check_convergence("cornell-box", ReusedRandomNumbers(), alpha=ALPHA, processes=2,
                                 ladder=CONVERGENCE_LADDER, replicas=REPLICAS)
    assert not law.passed, f"{verdict_line(law)}\n{mse}"
