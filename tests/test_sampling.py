"""Tests of the sampling warps: chi-square fits of every warp to its density, plus exact checks.

Chi-square tests run at the suite's per-test alpha (tests/budget.py).
"""
from __future__ import annotations

import numpy as np
import pytest

from pathtracer.core import sampling

pytestmark = pytest.mark.statistical(assertions=1)

try:
    from tests.chi2 import ALPHA, chi2_from_counts, chi2_plane, chi2_sphere
except ImportError:  # tests/ is not a package: pytest puts it on sys.path
    from chi2 import ALPHA, chi2_from_counts, chi2_plane, chi2_sphere


def _unit(n, seed=0):
    return np.random.default_rng(seed).random((n, 2))


# --------------------------------------------------------------------------
# Chi-square fits
# --------------------------------------------------------------------------

SPHERE_WARPS = {
    "uniform_sphere": (sampling.square_to_uniform_sphere, sampling.square_to_uniform_sphere_pdf),
    "uniform_hemisphere": (sampling.square_to_uniform_hemisphere, sampling.square_to_uniform_hemisphere_pdf),
    "cosine_hemisphere": (sampling.square_to_cosine_hemisphere, sampling.square_to_cosine_hemisphere_pdf),
}


@pytest.mark.parametrize("name", sorted(SPHERE_WARPS))
def test_chi2_sphere_warps(name):
    warp, pdf = SPHERE_WARPS[name]
    result = chi2_sphere(lambda u: warp(u[:, 1:]), pdf, seed=11)
    assert result.passed, result.message


@pytest.mark.parametrize("cos_cutoff, res_z", [(0.98, 100), (0.8, 10), (0.0, 10), (-0.6, 10)])
def test_chi2_uniform_cone(cos_cutoff, res_z):
    # The cone's rim lies on a cell edge, so the expected counts are exact.
    result = chi2_sphere(lambda u: sampling.square_to_uniform_cone(u[:, 1:], cos_cutoff),
                         lambda v: sampling.square_to_uniform_cone_pdf(v, cos_cutoff),
                         res=(res_z, 20), subdiv=(8, 8), seed=12)
    assert result.passed, result.message


def test_chi2_disk_concentric():
    result = chi2_plane(sampling.square_to_uniform_disk_concentric,
                        lambda p: np.where(np.sum(p ** 2, axis=1) <= 1.0, 1.0 / np.pi, 0.0), seed=13)
    assert result.passed, result.message


def test_chi2_triangle():
    result = chi2_plane(sampling.square_to_uniform_triangle, sampling.square_to_uniform_triangle_pdf,
                        bounds=((0.0, 1.0), (0.0, 1.0)), seed=14)
    assert result.passed, result.message


def test_chi2_discrete():
    weights = np.array([0.5, 0.0, 2.0, 1.0, 0.25, 3.0])
    u = np.random.default_rng(15).random(100_000)
    index, _ = sampling.sample_discrete(np.cumsum(weights), u)
    observed = np.bincount(index, minlength=weights.size)
    result = chi2_from_counts(observed, weights / weights.sum() * u.size)
    assert result.passed, result.message
    assert observed[1] == 0


# --------------------------------------------------------------------------
# Exact properties
# --------------------------------------------------------------------------

def test_warps_give_unit_vectors():
    u = _unit(10_000)
    for warp in (sampling.square_to_uniform_sphere, sampling.square_to_uniform_hemisphere,
                 sampling.square_to_cosine_hemisphere):
        v = warp(u)
        np.testing.assert_allclose(np.linalg.norm(v, axis=1), 1.0, atol=1e-12)
    v = sampling.square_to_uniform_cone(u, 0.3)
    np.testing.assert_allclose(np.linalg.norm(v, axis=1), 1.0, atol=1e-12)
    assert np.all(v[:, 2] >= 0.3 - 1e-12)
    assert np.all(sampling.square_to_uniform_hemisphere(u)[:, 2] >= 0)
    assert np.all(sampling.square_to_cosine_hemisphere(u)[:, 2] >= 0)


def test_disk_concentric_edge_cases():
    u = np.array([[0.5, 0.5], [0.0, 0.0], [1.0, 0.5], [0.5, 1.0], [0.0, 1.0]])
    p = sampling.square_to_uniform_disk_concentric(u)
    np.testing.assert_allclose(p[0], [0.0, 0.0])
    np.testing.assert_allclose(np.linalg.norm(p[1:], axis=1), 1.0)
    np.testing.assert_allclose(p[2], [1.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(p[3], [0.0, 1.0], atol=1e-15)


def test_pdfs_integrate_to_one():
    v = sampling.square_to_uniform_sphere(_unit(400_000, seed=3))
    for pdf in (sampling.square_to_uniform_hemisphere_pdf, sampling.square_to_cosine_hemisphere_pdf,
                lambda w: sampling.square_to_uniform_cone_pdf(w, 0.2)):
        estimate = np.mean(pdf(v)) * 4.0 * np.pi
        assert abs(estimate - 1.0) < 0.01


def test_triangle_barycentrics_inside():
    b = sampling.square_to_uniform_triangle(_unit(10_000))
    assert np.all(b >= 0) and np.all(b.sum(axis=1) <= 1.0 + 1e-12)


def test_sample_discrete_reuse():
    cdf = np.cumsum([1.0, 3.0, 0.0, 4.0])
    u = np.array([0.0, 0.124, 0.125, 0.49, 0.5, 0.999])
    index, u_reused = sampling.sample_discrete(cdf, u)
    np.testing.assert_array_equal(index, [0, 0, 1, 1, 3, 3])
    np.testing.assert_allclose(u_reused, [0.0, 0.992, 0.0, (0.49 * 8 - 1) / 3, 0.0, (0.999 * 8 - 4) / 4])
    # Reused samples are uniform within each choice.
    uu = np.random.default_rng(4).random(200_000)
    index, u_reused = sampling.sample_discrete(cdf, uu)
    for k in (0, 1, 3):
        counts = np.histogram(u_reused[index == k], bins=10, range=(0, 1))[0]
        result = chi2_from_counts(counts, np.full(10, counts.sum() / 10))
        assert result.passed, result.message


def test_power_heuristic():
    a = np.array([1.0, 0.0, 2.0, 0.0, np.inf])
    b = np.array([1.0, 1.0, 0.0, 0.0, 1.0])
    np.testing.assert_allclose(sampling.power_heuristic(a, b), [0.5, 0.0, 1.0, 0.0, 0.0])
    np.testing.assert_allclose(sampling.power_heuristic(np.array([3.0]), np.array([4.0])), [9.0 / 25.0])


def test_alpha_is_budgeted():
    from tests.budget import ALPHA as SUITE_ALPHA
    assert ALPHA == SUITE_ALPHA


def test_chi2_detects_wrong_pdf():
    """The test has power: cosine samples against the uniform density must fail."""
    result = chi2_sphere(lambda u: sampling.square_to_cosine_hemisphere(u[:, 1:]),
                         sampling.square_to_uniform_hemisphere_pdf, n_samples=20_000, seed=5)
    assert not result.passed


# --------------------------------------------------------------------------
# Comparison with Mitsuba 3's warps (same uniforms -> same points)
# --------------------------------------------------------------------------

@pytest.mark.mitsuba
def test_mitsuba_warps_identical(mi):
    u = np.random.default_rng(80).random((400, 2)).astype(np.float32).astype(np.float64)
    u[:4] = [[0.5, 0.5], [0.0, 0.0], [0.999, 0.25], [0.25, 0.999]]

    def theirs(fn, *args):
        return np.array([list(fn(mi.Point2f(*x), *args)) for x in u])

    cases = [
        (sampling.square_to_uniform_disk_concentric(u), theirs(mi.warp.square_to_uniform_disk_concentric)),
        (sampling.square_to_cosine_hemisphere(u), theirs(mi.warp.square_to_cosine_hemisphere)),
        (sampling.square_to_uniform_hemisphere(u), theirs(mi.warp.square_to_uniform_hemisphere)),
        (sampling.square_to_uniform_sphere(u), theirs(mi.warp.square_to_uniform_sphere)),
        (sampling.square_to_uniform_cone(u, 0.3), theirs(mi.warp.square_to_uniform_cone, 0.3)),
        (sampling.square_to_uniform_triangle(u), theirs(mi.warp.square_to_uniform_triangle)),
    ]
    for ours, ref in cases:
        np.testing.assert_allclose(ours, ref, atol=2e-6)
    v = sampling.square_to_cosine_hemisphere(u)
    ref_pdf = np.array([mi.warp.square_to_cosine_hemisphere_pdf(mi.Vector3f(*x)) for x in v])
    np.testing.assert_allclose(sampling.square_to_cosine_hemisphere_pdf(v), ref_pdf, rtol=1e-5, atol=1e-7)
    np.testing.assert_allclose(sampling.square_to_uniform_cone_pdf(v[:1], 0.3),
                               mi.warp.square_to_uniform_cone_pdf(mi.Vector3f(0, 0, 1), 0.3), rtol=1e-6)


@pytest.mark.mitsuba
def test_mitsuba_discrete_distribution(mi):
    weights = [0.5, 0.0, 2.0, 1.0, 0.25, 3.0]
    dist = mi.DiscreteDistribution(weights)
    u = np.random.default_rng(81).random(300).astype(np.float32).astype(np.float64)
    index, u_reused = sampling.sample_discrete(np.cumsum(weights), u)
    ref = [dist.sample_reuse(float(x)) for x in u]
    np.testing.assert_array_equal(index, [r[0] for r in ref])
    np.testing.assert_allclose(u_reused, [r[1] for r in ref], atol=1e-5)
