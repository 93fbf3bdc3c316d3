"""The scored render's variance comes from replicas the grader asks for (autograder/replicas.py):
the arithmetic, the seeds, and the refusals, with a fake student render (no process)."""
import re

import numpy as np
import pytest

from autograder import grading
from autograder.isolation.process import StudentFailure
from autograder.replicas import (
    REPLICAS,
    ScoredRender,
    replica_seeds,
    reported_variance_finding,
    scored_render,
)
from mitsuba_refs.verdicts.compare import TEST_SEED
from mitsuba_refs.verdicts.convergence import CONVERGENCE_SEED

SHAPE = (16, 12, 3)


class FakeStudent:
    """A render hook whose images are ``truth + noise(seed)``; records what it was asked."""

    def __init__(self, reported_factor=1.0, shared=0.0, ignore_seed=False):
        self.asked, self.factor, self.shared, self.ignore_seed = [], reported_factor, shared, ignore_seed

    def noise(self, seed):
        return np.random.default_rng(0 if self.ignore_seed else seed).standard_normal(SHAPE)

    def __call__(self, scene, integrator, params, spp, seed):
        self.asked.append((spp, seed))
        # An odd seed shares a part of its noise with the seed before it.
        shared = self.shared if seed % 2 else 0.0
        noise = np.sqrt(shared) * self.noise(seed - 1) + np.sqrt(1 - shared) * self.noise(seed)
        sigma2 = 4.0                                   # per-sample variance
        mean = 10.0 + np.sqrt(sigma2 / spp) * noise
        return mean, np.full(SHAPE, sigma2 * self.factor)


def test_mean_and_per_sample_variance_come_from_the_spread():
    student = FakeStudent()
    scored = scored_render(student, "s", "path", {}, 256, TEST_SEED)
    assert [spp for spp, _ in student.asked] == [32] * REPLICAS
    stack = scored.images
    assert np.allclose(scored.mean, stack.mean(axis=0))
    assert np.allclose(scored.variance, stack.var(axis=0, ddof=1) * 32)
    # An unbiased estimate of the per-sample variance (4): over 576 pixel-channels, 7 dof each.
    assert abs(scored.variance.mean() / 4.0 - 1) < 5 * np.sqrt(2 / 7 / scored.variance.size)
    assert reported_variance_finding(scored) is None


def test_replica_seeds_are_their_own():
    seeds = replica_seeds(TEST_SEED)
    assert len(set(seeds)) == REPLICAS
    others = {TEST_SEED + d for d in range(8)} | {CONVERGENCE_SEED + 100_000 * j + k
                                                  for j in range(8) for k in range(4096)}
    assert not set(seeds) & others
    # Below the calibration's stride between repetitions (autograder.calibrate.SEED_STRIDE).
    from autograder.calibrate import SEED_STRIDE
    assert max(seeds) < SEED_STRIDE


@pytest.mark.parametrize("factor", [100.0, 0.1])
def test_a_misstated_variance_is_named_and_not_used(factor):
    honest = scored_render(FakeStudent(), "s", "path", {}, 64, TEST_SEED)
    lying = scored_render(FakeStudent(reported_factor=factor), "s", "path", {}, 64, TEST_SEED)
    assert np.array_equal(honest.variance, lying.variance)
    said = re.search(r"reported is ([0-9.]+)x the spread", reported_variance_finding(lying))
    assert 0.8 < float(said.group(1)) / factor < 1.25


def test_renders_that_ignore_the_seed_fail_the_check():
    with pytest.raises(StudentFailure, match="same image for 8 different seeds"):
        scored_render(FakeStudent(ignore_seed=True), "s", "path", {}, 64, TEST_SEED)
    # A constant image (black, say) is graded as it is: it has no noise to share.
    black = scored_render(lambda *args: (np.zeros(SHAPE), np.zeros(SHAPE)), "s", "path", {}, 64,
                          TEST_SEED)
    assert not np.any(black.mean) and not np.any(black.variance)
    # A scene without noise in the reference: identical images are right there.
    scored = scored_render(FakeStudent(ignore_seed=True), "s", "path", {}, 64, TEST_SEED,
                           reference_noisy=False)
    assert np.allclose(scored.variance, 0.0, atol=1e-20)       # up to rounding of the mean


def test_replicas_that_share_their_noise_fail_the_check():
    with pytest.raises(StudentFailure, match="share most of their noise"):
        scored_render(FakeStudent(shared=0.8), "s", "path", {}, 64, TEST_SEED)
    # A small shared part is left to the mean part (noise the spread does not see), and a part
    # every replica shares cancels from their deviations: the replicas cannot show it.
    scored_render(FakeStudent(shared=0.2), "s", "path", {}, 64, TEST_SEED)


def test_halves_are_two_independent_renders_with_their_reported_variance():
    scored = scored_render(FakeStudent(reported_factor=3.0), "s", "path", {}, 64, TEST_SEED)
    (mean_a, var_a), n_a, (mean_b, var_b), n_b = scored.halves()
    assert n_a == n_b == 32
    assert np.allclose(mean_a, scored.images[:4].mean(axis=0))
    assert np.allclose(var_b, 12.0)
    assert isinstance(scored, ScoredRender)


def test_every_scored_render_is_eight_replicas():
    for check in grading.ALL_CHECKS:
        assert grading.scored_replicas(check) == (None if check.camera else REPLICAS), check.id


def test_an_spp_without_a_divisor_is_refused_in_one_line():
    with pytest.raises(ValueError, match="cannot be 1 replicas"):
        scored_render(FakeStudent(), "s", "path", {}, 7, TEST_SEED, replicas=1)


def test_one_huge_sample_is_not_shared_noise():
    """A replica with a firefly moves the replicas' average in that pixel, so every other
    replica's deviation from the average carries it; from the median none does."""
    from mitsuba_refs.stats.replicas import shared_noise
    rng = np.random.default_rng(3)
    stack = 1.0 + 0.1 * rng.standard_normal((8, 32, 32, 3))
    stack[2, 5, 7] = 1e4                     # a grazing 1/cos sample, say
    deviations = (stack - stack.mean(axis=0)).reshape(8, -1)
    others = deviations[[0, 1]]
    from_mean = others[0] @ others[1] / np.linalg.norm(others[0]) / np.linalg.norm(others[1])
    assert from_mean > 0.9                   # what the average would have said
    assert shared_noise(stack)[2] < 0.1
