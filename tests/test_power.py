"""Power of the graded mean parts (autograder.power, mitsuba_refs.stats.detectable).

The detectable bias is computed analytically from the committed references; the injection
check draws renders at the references' real per-pixel variances with fixed seeds.  Neither
depends on the tracer: the assertions are deterministic, their false-failure probabilities
(over the fixed seeds) are stated and below the suite's ALPHA (tests/budget.py).
"""
from __future__ import annotations

import dataclasses
import math

import pytest
from scipy import stats as sps

from autograder import grading, power
from mitsuba_refs.stats import detectable_bias
from tests.budget import ALPHA

INTEGRATOR_CHECKS = [c for c in grading.CHECKS if not c.camera]


def test_power_table_covers_every_check():
    rows = power.power_table(seeds=4)
    assert [r["check"] for r in rows] == [c.id for c in grading.CHECKS
                                          if any(n == "mean" for n, _ in c.parts)]
    for row, check in zip(rows, grading.CHECKS):
        assert row["spp"] == check.spp and row["alpha"] == grading.ALPHA
        assert 0 < row["reference_floor"] < row["detectable_bias"] < 0.1
    text = power.format_table(rows)
    assert text.count("\n") == len(rows) + 1 and "path-cornell-box" in text


@pytest.mark.parametrize("check", grading.CHECKS, ids=[c.id for c in grading.CHECKS])
def test_injected_power_confirms_the_analytic_bound(check):
    """At the analytic bound the simulated grader (its variance from 8 replicas, as the grader
    measures it) detects the bias (both signs) in at least
    the lower ALPHA-quantile of Binomial(100, 0.95) (82) of 100 injected renders: if the bound
    holds (power >= 0.95), this fails with probability <= ALPHA."""
    ref = power.reference_of(check)
    need = int(sps.binom.ppf(ALPHA, 100, 0.95))
    for sign in (1, -1):
        b = detectable_bias(ref.mean, ref.var, ref.n, check.spp, alpha=grading.ALPHA, sign=sign)
        rate = power.injected_power(sign * b, ref.mean, ref.var, ref.n, check.spp,
                                    power.Injection(alpha=grading.ALPHA, seeds=100, seed=7 + (sign > 0),
                                                    replicas=grading.scored_replicas(check)))
        print(check.id, sign, f"b={b:.4f}", rate)
        assert round(rate * 100) >= need, (check.id, sign, b, rate)


@pytest.mark.parametrize("check", INTEGRATOR_CHECKS, ids=[c.id for c in INTEGRATOR_CHECKS])
def test_every_integrator_check_detects_a_bias_of_one_and_a_half_percent(check):
    """1.5 % for every integrator check, the BSDF-only ones included (they grade on scenes
    with larger lights of the same power, mitsuba_refs.reference.config.GRADING_SCENES)."""
    ref = power.reference_of(check)
    worst = max(detectable_bias(ref.mean, ref.var, ref.n, check.spp, alpha=grading.ALPHA, sign=s)
                for s in (1, -1))
    assert worst <= power.TARGET_BIAS, f"{check.id}: {100 * worst:.2f} % at {check.spp} spp"


def test_power_is_measured_against_the_reference_the_check_compares_with():
    """A max_depth = 3 check is compared with the max_depth = 3 reference; its power too
    (the unbounded one has another variance: path_nee-lights detects 1.63 % at 448 spp
    against the max_depth = 3 reference, 1.41 % against the unbounded one)."""
    check = grading.CHECKS_BY_ID["path_nee-lights"]
    assert check.max_depth == 3
    assert power.reference_of(check).metadata["params"]["max_depth"] == "3"


def test_bsdf_sampling_is_graded_where_it_finds_the_light():
    """The path_bsdf checks use the GRADING_SCENES variants: every light of the scene they vary
    with the same emitted power (radiance x area) on a larger area, every other shape the
    same; the variant's per-sample variance is at least 4x smaller than the original's, which
    is what lets the same samples detect 1.5 %."""
    import numpy as np

    from mitsuba_refs.reference.config import GRADING_SCENES
    from pathtracer import load_scene
    bsdf_checks = [c for c in INTEGRATOR_CHECKS if c.integrator == "path_bsdf"]
    assert {c.scene for c in bsdf_checks} == set(GRADING_SCENES)
    for check in bsdf_checks:
        variant, original = (load_scene(name) for name in (check.scene, GRADING_SCENES[check.scene]))
        lights = [e.shape for e in original.emitters]
        assert [e.shape for e in variant.emitters] == lights
        for mine, theirs in zip(variant.emitters, original.emitters):
            np.testing.assert_allclose(mine.radiance * variant.shape_area[mine.shape],
                                       theirs.radiance * original.shape_area[theirs.shape], rtol=1e-6)
            assert variant.shape_area[mine.shape] >= 4 * original.shape_area[theirs.shape]
        others = [i for i in range(len(original.shape_area)) if i not in lights]
        np.testing.assert_allclose(np.asarray(variant.shape_area)[others],
                                   np.asarray(original.shape_area)[others], rtol=1e-9)
        original_check = dataclasses.replace(check, scene=GRADING_SCENES[check.scene])
        ours, theirs = power.reference_of(check), power.reference_of(original_check)
        relative = [r.var.mean() / r.mean.mean() ** 2 for r in (ours, theirs)]
        assert relative[0] * 4 <= relative[1], (check.id, relative)


def test_every_check_has_its_committed_references():
    """Each check's reference and the per-bounce references its hints compare with (``path``,
    ``volpath`` for the media checks; none for the camera and the splatting light tracer) are
    committed (a missing one would make the grader call Mitsuba on Gradescope)."""
    from mitsuba_refs.reference.cache import get_reference
    from mitsuba_refs.verdicts.estimators import BOUNCE_REFERENCE, SPLATTING
    from mitsuba_refs.verdicts.scenes import default_params
    for check in grading.ALL_CHECKS:
        assert power.reference_of(check).n == 4096, check.id
        estimator = BOUNCE_REFERENCE.get(check.integrator, "path")
        depths = [d for d in grading.BOUNCE_DEPTHS if not check.max_depth or d <= check.max_depth]
        swept = not check.camera and check.integrator not in SPLATTING   # as run_check
        for depth in depths if swept else []:
            params = {**default_params(check.scene), "max_depth": depth}
            assert get_reference(check.scene, params, estimator, render=False).n == 4096, check.id


def test_a_bias_significant_at_1e_minus_4_does_not_pass():
    """The issue's case: +1.6 % measured by the grader with p = 1.5e-4 passed at the part
    level 4.8e-5.  At each check's spp a +1.6 % bias has a detection probability of at least
    0.95 (analytic bound) on every integrator check."""
    for check in INTEGRATOR_CHECKS:
        ref = power.reference_of(check)
        assert detectable_bias(ref.mean, ref.var, ref.n, check.spp, alpha=grading.ALPHA) < 0.016


def test_check_spp_defaults_to_the_old_constant():
    check = grading.Check("x", "path", "quad-light", (("mean", 1),), 10)
    assert check.spp == grading.SPP == 64
    assert all(c.spp >= grading.SPP and c.spp % 64 == 0 for c in grading.CHECKS)
    assert not math.isnan(grading.ALPHA)


@pytest.mark.parametrize("check", grading.LIGHT_CHECKS, ids=[c.id for c in grading.LIGHT_CHECKS])
def test_light_check_detects_a_bias_of_one_and_a_half_percent(check):
    """The light tracer's mean test has tiles only (its pixels are correlated across the image):
    its analytic bound (tile_detectable_bias, a lower bound on the power) meets the 1.5 %
    target, and at that bound at least the lower ALPHA-quantile of Binomial(50, 0.95) of 50
    injected renders per sign fail, as they do with probability >= 1 - ALPHA if it holds."""
    ref = power.reference_of(check)
    level = grading.alpha_of(check)
    need = int(sps.binom.ppf(ALPHA, 50, 0.95))
    for sign in (1, -1):
        b = power.tile_detectable_bias(ref.mean, ref.var, ref.n, check.spp, alpha=level, sign=sign)
        assert b <= power.TARGET_BIAS, f"{check.id}: {100 * b:.2f} % at {check.spp} spp"
        rate = power.injected_power(sign * b, ref.mean, ref.var, ref.n, check.spp,
                                    power.Injection(alpha=level, seeds=50, seed=11 + (sign > 0),
                                                    image_components=False,
                                                    replicas=grading.scored_replicas(check)))
        assert round(rate * 50) >= need, (check.id, sign, b, rate)
