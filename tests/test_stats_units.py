"""Unit tests of mitsuba_refs.stats and mitsuba_refs.report.diagnostics (deterministic, fast).

Tests that draw random numbers use fixed seeds; where an assertion is statistical its
false-failure probability (over seeds) is stated and < 1e-4."""
from __future__ import annotations

import math

import numpy as np
import pytest

from mitsuba_refs.report.wording import (
    bounce_verdict,
    convergence_warnings,
    mean_region,
    region_name,
    variance_policy_verdict,
    variance_region,
    verdict_line,
)
from mitsuba_refs.stats import (
    ErrorBudget,
    MeanTestOptions,
    compare_means,
    compare_variances,
    convergence_law,
    first_diverging_bounce,
    image_mse,
    image_mse_parts,
    per_test_alpha,
    reference_mse_floor,
    suite_false_failure,
)
from mitsuba_refs.stats._mvn import p_max_abs
from mitsuba_refs.stats._tiles import tile_counts, tile_sums
from mitsuba_refs.stats.detectable import tile_gross_error_bound
from mitsuba_refs.stats.simulate import make_scene, render_stats


def _pair(h=40, w=56, n_a=64, n_b=4096, seed=0, p_range=(0.1, 0.6)):
    sc = make_scene(h, w, seed=seed, p_range=p_range)
    rng = np.random.default_rng(seed + 100)
    ma, va = render_stats(sc, n_a, 1, rng)
    mb, vb = render_stats(sc, n_b, 1, rng)
    return ma[0], va[0], mb[0], vb[0]


def test_tile_sums_partial_edges():
    x = np.arange(5 * 7, dtype=float).reshape(5, 7)
    s = tile_sums(x, 4)
    assert s.shape == (2, 2)
    assert s.sum() == x.sum()
    assert s[1, 1] == x[4:, 4:].sum()
    assert tile_counts(5, 7, 4).tolist() == [[16, 12], [4, 3]]


def test_region_names():
    assert region_name(1, 1, 90, 90) == "top-left"
    assert region_name(45, 45, 90, 90) == "center"
    assert region_name(80, 45, 90, 90) == "bottom"
    assert region_name(45, 85, 90, 90) == "right"


def test_p_max_abs_limits():
    from scipy import special
    one = special.erfc(3 / math.sqrt(2))
    assert p_max_abs(3.0, np.eye(1)) == pytest.approx(one)
    assert p_max_abs(3.0, np.eye(3)) == pytest.approx(1 - (1 - one) ** 3, rel=1e-6)
    full = p_max_abs(3.0, np.ones((3, 3)))
    assert one <= full <= 1.2 * one                      # nearly one test when channels are identical
    assert p_max_abs(np.inf, np.eye(3)) == 0.0


@pytest.mark.parametrize("channels", [1, 2, 3, 4])
def test_critical_value_solves_the_tail_equation(channels):
    """The per-tile critical |z| of compare_means: P(max |Z| >= crit) = level to 1e-9, for
    random correlations and levels from 1e-2 to 1e-10."""
    from mitsuba_refs.stats.mean import _solve_crit
    rng = np.random.default_rng(channels)
    for level in (1e-2, 1e-5, 3e-8, 1e-10):
        A = rng.normal(size=(channels, channels))
        R = A @ A.T / np.sqrt(np.outer(np.diag(A @ A.T), np.diag(A @ A.T)))
        crit = _solve_crit(level, R)
        assert p_max_abs(crit, R) == pytest.approx(level, rel=1e-9)


def test_mean_agree_non_multiple_size_and_fields():
    """Not multiples of the tile (40x56 with tile 16 -> partial edge tiles).  A correct pair
    agrees at alpha=1e-4 (fixed seed; false failure < 1e-4 by calibration)."""
    ma, va, mb, vb = _pair()
    r = compare_means(ma, va, 64, mb, vb, 4096, alpha=1e-4, options=MeanTestOptions(tile=16))
    assert r.agree and bool(r)
    assert r.z_tiles.shape == (3, 4, 3)
    assert verdict_line(r).startswith("agree (p=")
    assert "relative bias" in verdict_line(r)
    assert r.rel_bias_ci[0] <= r.rel_bias <= r.rel_bias_ci[1]
    with pytest.raises(ValueError):
        r.z_tiles[0, 0, 0] = 1.0                          # read-only result arrays


def test_mean_black_and_deterministic_tiles():
    h = w = 16
    m = np.zeros((h, w, 3))
    v = np.zeros((h, w, 3))
    m[:8, :8] = 0.5                                       # a deterministic grey tile, rest black
    r = compare_means(m, v, 16, m.copy(), v, 1024, alpha=1e-3)
    assert r.agree and r.p_value == 1.0
    assert r.n_tests == 1                                  # black tiles carry no evidence
    m2 = m.copy()
    m2[:8, :8] *= 1 + 1e-8                                 # float noise: still equal
    assert compare_means(m2, v, 16, m, v, 1024, alpha=1e-3).agree
    m3 = m.copy()
    m3[8:, 8:] = 0.01                                      # deterministic but different
    r3 = compare_means(m3, v, 16, m, v, 1024, alpha=1e-3)
    assert not r3.agree and r3.p_value == 0.0
    assert r3.worst_tile[:2] == (1, 1) and mean_region(r3) == "bottom-right"
    r4 = compare_means(m3, v, 16, m, v, 1024, alpha=1e-3, options=MeanTestOptions(rel_floor=0.0))
    assert np.isinf(r4.z_tiles[1, 1]).all()


def test_mean_verdict_names_region_and_bias():
    ma, va, mb, vb = _pair(64, 64, n_a=1024, n_b=16384, seed=3)
    s = np.ones_like(ma)
    s[:16, :16] = 0.85                                     # 15 % too dark in the top-left
    r = compare_means(ma * s, va * s ** 2, 1024, mb, vb, 16384, alpha=1e-3)
    assert not r.agree
    assert "top-left" in verdict_line(r) and "too dark" in verdict_line(r)
    assert r.worst_z < 0 and r.n_significant >= 2
    g = compare_means(ma * 0.9, va * 0.81, 1024, mb, vb, 16384, alpha=1e-3)
    assert "10." in verdict_line(g) or "9." in verdict_line(g)        # "image 10.0% too dark [...]"
    assert g.rel_bias_ci[0] < -0.09 < g.rel_bias_ci[1] or abs(g.rel_bias + 0.1) < 0.01


def test_mean_determinism_and_validation():
    ma, va, mb, vb = _pair(seed=4)
    r1 = compare_means(ma * 0.95, va, 64, mb, vb, 4096, alpha=0.01)
    r2 = compare_means(ma * 0.95, va, 64, mb, vb, 4096, alpha=0.01)
    assert verdict_line(r1) == verdict_line(r2) and r1.p_value == r2.p_value
    with pytest.raises(ValueError):
        compare_means(ma, va, 1, mb, vb, 4096, alpha=0.01)         # n < 2
    with pytest.raises(ValueError):
        compare_means(ma[:-1], va, 64, mb, vb, 4096, alpha=0.01)   # shapes
    bad = ma.copy()
    bad[0, 0, 0] = np.nan
    with pytest.raises(ValueError):
        compare_means(bad, va, 64, mb, vb, 4096, alpha=0.01)
    with pytest.raises(TypeError):
        compare_means(ma, va, 64, mb, vb, 4096)                    # alpha is required


def test_mean_one_side_missed_rare_light():
    """Test side saw no light hits in a tile the reference did hit rarely: the no-hit
    guard keeps this from being called a disagreement (Welch alone gives z ~ -5)."""
    h = w = 16
    ma = np.full((h, w, 3), 0.3)
    va = np.full((h, w, 3), 0.09)
    mb, vb = ma.copy(), va.copy()
    mb[:8, :8] += 0.01                                     # reference: 1e-4 hits of value 100
    vb[:8, :8] += 1.0
    r = compare_means(ma, va, 64, mb, vb, 4096, alpha=1e-3)
    assert r.agree


def test_variance_basic_and_verdict():
    ma, va, mb, vb = _pair(64, 64, seed=6)
    r = compare_variances(va, 64, vb, 4096, alpha=1e-3)
    assert r.agree and r.ratio_ci[0] <= r.ratio <= r.ratio_ci[1]
    assert verdict_line(r).startswith("variance agrees")
    r3 = compare_variances(va * 3, 64, vb, 4096, alpha=1e-3)
    assert not r3.agree and "3.0" in verdict_line(r3) and "the reference" in verdict_line(r3)
    loc = va.copy()
    loc[48:, 48:] *= 20                                    # a firefly corner
    r4 = compare_variances(loc, 64, vb, 4096, alpha=1e-3)
    assert not r4.agree and r4.n_outliers >= 1 and variance_region(r4) == "bottom-right"
    assert verdict_line(compare_variances(va, 64, vb, 4096, alpha=1e-3)) == verdict_line(r)   # deterministic
    with pytest.raises(ValueError):
        compare_variances(np.zeros((16, 16, 3)), 64, np.zeros((16, 16, 3)), 64, alpha=0.01)


def test_image_mse_and_floor():
    rng = np.random.default_rng(0)
    ref = rng.random((8, 8, 3))
    rv = np.full((8, 8, 3), 0.5)
    assert reference_mse_floor(rv, 100) == pytest.approx(0.005)
    assert image_mse(ref + 0.1, ref, rv, 100) == pytest.approx(0.01 - 0.005)
    assert image_mse(ref, ref, rv, np.full((8, 8), 100)) == pytest.approx(-0.005)


def test_image_mse_parts_are_image_mse_of_each_part_bit_for_bit():
    """The convergence test's precomputed form gives image_mse's own numbers."""
    rng = np.random.default_rng(5)
    test, ref, rv = rng.random((3, 12, 16, 3))
    n = rng.integers(1, 50, (12, 16)).astype(float)
    parts = [np.s_[a::4, b::4] for a in range(4) for b in range(4)] + [...]
    got = image_mse_parts(test, [ref[p] for p in parts],
                          [reference_mse_floor(rv[p], n[p]) for p in parts], parts)
    assert got == [image_mse(test[p], ref[p], rv[p], n[p]) for p in parts]


def test_mse_law_exact_and_failures():
    spp = np.array([1, 4, 16, 64, 256])
    rng = np.random.default_rng(1)
    good = (2.0 / spp) * (1 + 0.02 * rng.standard_normal((6, 5)))
    r = convergence_law(spp, good, alpha=1e-3)
    assert r.passed and r.slope_ci[0] <= -1 <= r.slope_ci[1]
    assert r.ratio_ci[0] <= 2 <= r.ratio_ci[1]
    assert verdict_line(r).startswith("converges as N^-1/2")
    flat = 2.0 * (1 + 0.02 * rng.standard_normal((6, 5)))
    rf = convergence_law(spp, flat, alpha=1e-3)
    assert not rf.passed and rf.correlated and "correlated" in verdict_line(rf)
    floor = (2.0 / spp + 0.01) * (1 + 0.02 * rng.standard_normal((6, 5)))
    rb = convergence_law(spp, floor, alpha=1e-3, image_mean=1.0)
    assert rb.floor_detected and "bias floor" in verdict_line(rb)
    # a per-pixel RMS error, not the image-level bias the mean verdict reports
    assert "per-pixel RMS bias \u2248 " in verdict_line(rb) and "of the image mean" in verdict_line(rb)
    assert 100 < rb.floor_spp < 400 and rb.bias_rel == pytest.approx(0.1, rel=0.3)
    with pytest.raises(ValueError):
        convergence_law(spp, good[:1], alpha=1e-3)
    w = convergence_law(spp, good, ref_mse_floor=0.005, alpha=1e-3)
    assert convergence_warnings(w) and "longer reference" in verdict_line(w)


def test_first_diverging_bounce():
    class R:
        def __init__(self, agree, p=0.5):
            self.agree, self.p_value, self.verdict = agree, p, "v"

    def bounce(results):
        depth, text = bounce_verdict(results, line=lambda r: r.verdict)
        assert depth == first_diverging_bounce(results)
        return depth, text
    d, t = bounce({1: R(True), 2: R(False, 1e-9), 3: R(False, 1e-12)})
    assert d == 2 and t.startswith("direct light (bounce 2) disagrees") and "directly visible" in t
    d, t = bounce({2: R(False, 1e-9), 3: R(False)})
    assert d == 2 and "already disagrees" in t
    d, t = bounce({1: R(True), -1: R(True), 3: R(True)})
    assert d is None and "all depths agree" in t
    d, t = bounce({1: R(True), 4: R(False), -1: R(False)})
    assert d == 4 and "2 indirect bounces (bounce 4)" in t


def test_budget():
    assert per_test_alpha(50) == pytest.approx(2e-5)
    a = per_test_alpha(50, method="sidak")
    assert suite_false_failure(a, 50) == pytest.approx(1e-3)
    assert suite_false_failure(0.01, 50) == pytest.approx(0.395, abs=1e-3)
    b = ErrorBudget(1e-3)
    b.register("x")
    b.register("y", weight=3)
    assert b.alpha("y") == pytest.approx(7.5e-4) and b.worst_case_suite_alpha() == pytest.approx(1e-3)
    with pytest.raises(ValueError):
        per_test_alpha(0)


def test_diagnostics_write_pngs(tmp_path):
    from mitsuba_refs.report import diagnostics as dg
    ma, va, mb, vb = _pair(32, 48, seed=8)
    r = compare_means(ma * 0.9, va, 64, mb, vb, 4096, alpha=1e-3)
    p1 = dg.plot_mean_comparison(tmp_path / "mean.png", ma * 0.9, mb, r, "synthetic 10% dark")
    rv = compare_variances(va, 64, vb, 4096, alpha=1e-3)
    p2 = dg.plot_variance_comparison(tmp_path / "var.png", va, vb, rv, "synthetic")
    spp = np.array([1, 4, 16, 64])
    mse = (1.0 / spp) * (1 + 0.05 * np.random.default_rng(0).standard_normal((5, 4)))
    rc = convergence_law(spp, mse, alpha=1e-3)
    p3 = dg.plot_convergence(tmp_path / "sub" / "conv.png", spp, mse, rc, "synthetic")
    for p in (p1, p2, p3):
        with open(p, "rb") as f:
            assert f.read(8) == b"\x89PNG\r\n\x1a\n"


# ------------------------------------------- the mean test when the test's variance explodes

def _heavy_tailed(ma, va, n, factor, pixels, seed):
    """A wrong estimator whose few enormous samples carry the image: ``pixels`` random pixels
    each get one extra sample of ``factor`` x the image mean (mean and variance updated as a
    renderer would compute them from its samples)."""
    rng = np.random.default_rng(seed)
    m, v = ma.copy(), va.copy()
    x = factor * ma.mean()
    for i, j in zip(rng.integers(0, m.shape[0], pixels), rng.integers(0, m.shape[1], pixels)):
        m[i, j] += x / n
        v[i, j] += x * x / n            # one sample of x among n: its share of the sample variance
    return m, v


def test_mean_bounded_variance_catches_an_exploding_bias():
    """A roulette bug whose image is 1e35x too bright through one enormous sample: with its
    own variance the Welch z stays ~1 (p = 0.55 in the issue) and the mean would 'agree';
    the bounded-variance component rejects, and the verdict says by how much."""
    ma, va, mb, vb = _pair(64, 64, seed=9)
    m, v = _heavy_tailed(ma, va, 64, 1e35 * 64 * 64 * 64, 1, seed=1)
    own = compare_means(m, v, 64, mb, vb, 4096, alpha=4.8e-5)
    assert own.agree                                       # the flaw this component fixes
    r = compare_means(m, v, 64, mb, vb, 4096, alpha=4.8e-5, max_var_ratio=4.0)
    assert not r.agree and r.p_value == 0.0
    assert "at most 4x the reference's variance" in verdict_line(r) and "too bright" in verdict_line(r)
    assert set(r.scale_p_values) == {"8px", "image", "image, bounded variance"}
    # a glass render 930x too bright with a variance to match: the same
    m2, v2 = ma * 930, va * 930 ** 2 * 1e4
    assert compare_means(m2, v2, 64, mb, vb, 4096, alpha=4.8e-5).agree
    r2 = compare_means(m2, v2, 64, mb, vb, 4096, alpha=4.8e-5, max_var_ratio=4.0)
    assert not r2.agree and "x too bright" in verdict_line(r2) and r2.rel_bias == pytest.approx(929, rel=0.01)


def test_tiles_only_mean_test_bounds_the_variance_tile_by_tile():
    """A splatting render (no whole-image components): a wrong light tracer whose image is
    carried by a few enormous samples agrees with its own tile variances, and is rejected by
    the bounded tiles, which name the tile and the bound; a correct render still agrees."""
    ma, va, mb, vb = _pair(48, 64, seed=12)
    m, v = _heavy_tailed(ma, va, 64, 1e6 * 48 * 64 * 64, 3, seed=2)
    own = compare_means(m, v, 64, mb, vb, 4096, alpha=1e-4, image_components=False)
    assert own.agree and set(own.scale_p_values) == {"8px"}      # the flaw this fixes
    r = compare_means(m, v, 64, mb, vb, 4096, alpha=1e-4, image_components=False,
                      max_var_ratio=4.0)
    assert set(r.scale_p_values) == {"8px", "8px, bounded variance"}
    assert not r.agree and r.scale_p_values["8px, bounded variance"] < 1e-12
    assert "at most 4x the reference's variance" in verdict_line(r) and r.n_significant >= 1
    assert compare_means(ma, va, 64, mb, vb, 4096, alpha=1e-4, image_components=False,
                         max_var_ratio=4.0).agree


def test_tile_gross_error_bound_is_a_guarantee():
    """An observed image off by the tiles' gross-error bound is rejected whatever its own
    variance (here 1e6x the reference's); one off by a tenth of it, with that variance, is not
    (nothing else can see it)."""
    _, _, mb, vb = _pair(48, 64, seed=13)
    bound = tile_gross_error_bound(mb, vb, 4096, 256, alpha=1e-3, max_var_ratio=4.0)
    assert 0 < bound < 0.2
    for r, rejected in ((1.001 * bound, True), (-1.001 * bound, True), (0.1 * bound, False)):
        verdict = compare_means(mb * (1 + r), vb * 1e6, 256, mb, vb, 4096, alpha=1e-3,
                                image_components=False, max_var_ratio=4.0)
        assert verdict.agree is not rejected, (r, verdict_line(verdict))


def test_mean_bounded_variance_is_exact_for_a_noiseless_reference_shift():
    """The bounded component's z is (A - B) / sqrt(K sb^2 n_b/n_a + sb^2): checked by hand on
    a uniform image (every pixel mean 1, per-sample variance 4)."""
    h = w = 16
    mb = np.ones((h, w, 3))
    vb = np.full((h, w, 3), 4.0)
    ma = mb * 1.01
    r = compare_means(ma, vb * 1e6, 64, mb, vb, 1024, alpha=1e-3, max_var_ratio=2.0)
    sb2 = 4.0 / 1024 / (h * w)
    z = 0.01 / math.sqrt(2.0 * 4.0 / 64 / (h * w) + sb2 + (1e-5 * 1.01) ** 2)
    assert r.scale_p_values["image, bounded variance"] == pytest.approx(
        p_max_abs(z, np.ones((3, 3))), rel=1e-6)      # differences all alike: R = 1
    with pytest.raises(ValueError):
        compare_means(ma, vb, 64, mb, vb, 1024, alpha=1e-3, max_var_ratio=0.0)


def test_values_that_overflow_give_a_failed_verdict_not_a_crash():
    """Images ~1e300 (their squares overflow float64) and a variance that overflowed to inf:
    every test returns a failed verdict with a reason."""
    ma, va, mb, vb = _pair(64, 64, seed=10)
    big = compare_means(ma * 1e300, np.full_like(va, np.inf), 64, mb, vb, 4096, alpha=1e-3,
                        max_var_ratio=4.0)
    assert not big.agree and "too bright" in verdict_line(big) and "e+299x" in verdict_line(big)
    huge = compare_means(ma * 1e300, va * 1e300, 64, mb, vb, 4096, alpha=1e-3)
    assert not huge.agree and math.isfinite(huge.worst_z)
    rv = compare_variances(va * 1e300, 64, vb, 4096, alpha=1e-3)
    assert not rv.agree and not rv.policy_agree and rv.ratio > 1e299
    spp = np.array([1, 4, 16, 64])
    table = np.full((4, 4), np.inf)
    rc = convergence_law(spp, table, alpha=1e-3)
    assert not rc.passed and "too large to compute" in verdict_line(rc)
    with np.errstate(over="ignore"):
        assert image_mse(ma * 1e300, mb, vb, 4096) == np.inf
    with pytest.raises(ValueError):
        convergence_law(spp, np.full((4, 4), np.nan), alpha=1e-3)


def test_convergence_law_is_scale_free_up_to_float64():
    """MSEs ~1e70 (images ~1e35) or ~1e250: the same verdict as at scale 1 (no
    OverflowError from their squares), and Kish's effective size of [1e200, 1e200] is 2."""
    from mitsuba_refs.stats import effective_rows
    spp = np.array([1, 4, 16, 64])
    rng = np.random.default_rng(2)
    good = (2.0 / spp) * (1 + 0.02 * rng.standard_normal((6, 4)))
    base = convergence_law(spp, good, alpha=1e-3)
    for s in (1e70, 1e250):
        r = convergence_law(spp, good * s, alpha=1e-3)
        assert r.slope == pytest.approx(base.slope) and r.p_value == pytest.approx(base.p_value)
    assert effective_rows([1e200, 1e200]) == pytest.approx(2.0)
    assert effective_rows([1.0, np.inf, 2.0]) == 1.0


# ---------------------------------------------------------------- the one-sided variance policy

def test_variance_policy_one_sided_fields():
    """Same variance: passes the policy (and equality); 1.3x: passes the policy although the
    equality test rejects; 1.9x: fails both; 0.5x passes the policy (it is one-sided); one
    noisy tile in an image within the bound passes the policy (it is about the image)."""
    ma, va, mb, vb = _pair(64, 64, n_a=1024, seed=6)
    same = compare_variances(va, 1024, vb, 4096, alpha=1e-3)
    assert same.policy_agree and same.agree and same.max_ratio == 1.5
    assert variance_policy_verdict(same).startswith("variance within 1.5x the reference")
    r13 = compare_variances(va * 1.3, 1024, vb, 4096, alpha=1e-3)
    assert r13.policy_agree and not r13.agree
    r19 = compare_variances(va * 1.9, 1024, vb, 4096, alpha=1e-3)
    assert not r19.policy_agree and variance_policy_verdict(r19).startswith("variance above 1.5x")
    low = compare_variances(va * 0.5, 1024, vb, 4096, alpha=1e-3)
    assert low.policy_agree and not low.agree
    loc = va.copy()
    loc[56:, 56:] *= 5                      # one tile 5x, the image 1.06x: a local trade-off
    corner = compare_variances(loc, 1024, vb, 4096, alpha=1e-3)
    assert corner.policy_agree and corner.ratio < 1.1     # the policy grades the image
    loc[16:] *= 4                           # three quarters of the image 4x: ~3x
    half = compare_variances(loc, 1024, vb, 4096, alpha=1e-3)
    assert not half.policy_agree and half.ratio > 2
    with pytest.raises(ValueError):
        compare_variances(va, 64, vb, 4096, alpha=1e-3, max_ratio=0)


# --------------------------------------------------------------------------- detectable bias

def test_detectable_bias_closed_form_on_a_uniform_image():
    """Uniform image (mean 1, per-sample variance v): the bound solves
    b / sqrt(v (1+b)^2 / (P n_a) + v / (P n_b)) = z* + z_0.95 (approximately: the far tail
    adds nothing), grows with alpha's strictness, and shrinks with the test's spp down to the
    reference's own floor."""
    from scipy import special

    from mitsuba_refs.stats import detectable_bias, spp_for_bias
    from mitsuba_refs.stats.detectable import bias_power, image_critical_z
    P, v, nb = 64 * 64, 50.0, 4096
    mean, var = np.ones((64, 64, 3)), np.full((64, 64, 3), v)
    alpha = 4.8e-5
    crit = image_critical_z(alpha)
    assert crit == pytest.approx(-special.ndtri((1 - (1 - (1 - (1 - alpha) ** (1 / 3))) ** (1 / 3)) / 2))
    b = detectable_bias(mean, var, nb, 256, alpha=alpha)
    delta = b / math.sqrt(v * (1 + b) ** 2 / (P * 256) + v / (P * nb))
    assert delta == pytest.approx(crit + 1.6448536, abs=1e-4)
    assert bias_power(b, mean, var, nb, 256, alpha=alpha) == pytest.approx(0.95, abs=1e-6)
    assert detectable_bias(mean, var, nb, 256, alpha=alpha, sign=-1) < b       # darker: less noise
    assert detectable_bias(mean, var, nb, 1024, alpha=alpha) < b
    assert detectable_bias(mean, var, nb, 256, alpha=alpha / 10) > b
    floor = detectable_bias(mean, var, nb, 1e15, alpha=alpha)
    assert floor == pytest.approx((crit + 1.6448536) * math.sqrt(v / (P * nb)), rel=1e-3)
    n = spp_for_bias(0.015, mean, var, nb, alpha=alpha)
    assert n % 64 == 0 and detectable_bias(mean, var, nb, n, alpha=alpha) <= 0.015
    assert detectable_bias(mean, var, nb, n - 64, alpha=alpha) > 0.015
    assert spp_for_bias(floor / 2, mean, var, nb, alpha=alpha) is None
    assert math.isinf(detectable_bias(np.zeros_like(mean), var, nb, 256, alpha=alpha))


def test_a_nearly_noiseless_image_skips_the_variance_test_with_its_reason():
    """Fewer than 8 tiles with variance (mitsuba-data's integrator_depth_1: max_depth 1 under
    a gaussian film, noisy only at 2 tiles' edges): compare_variances raises TooFewTiles,
    and a comparison says the variance was not tested, and why, instead of failing."""
    from mitsuba_refs.stats.variance import TooFewTiles, compare_variances
    from mitsuba_refs.verdicts.compare import Comparison
    var = np.zeros((32, 32, 3))
    var[:8, :8] = var[-8:, -8:] = 0.1
    with pytest.raises(TooFewTiles, match="got 2"):
        compare_variances(var, 64, var, 4096, alpha=1e-3)
    result = Comparison("scene", "path", {}, 64, mean=None,
                        variance_skipped="not tested: need >= 8 tiles with non-zero variance")
    assert result.variance_not_applicable().startswith("not tested: need >= 8 tiles")


def test_float32_rounding_variance_of_noiseless_pixels_does_not_decide_the_verdict():
    """bsdf_twosided_cbox under a gaussian film: the environment is exactly noiseless in the
    tracer, while the LLVM reference's float32 moments give it 1.5e-8..4.5e-8 of the squared
    mean. Without the means such tiles (ratio 0) pull an agreeing image to a disagreement;
    with them (the noise floor) the verdict is that of the noisy tiles. A tracer that is
    noiseless where the reference has a real variance (1e-4 of the mean squared) still fails."""
    ma, va, mb, vb = _pair(64, 64, seed=6)
    ma, mb = ma.copy(), mb.copy()
    va, vb = va.copy(), vb.copy()
    env = np.zeros((64, 64), bool)
    env[:, :24] = True                                     # 3 of 8 tile columns: environment
    ma[env] = mb[env] = 2.0                                # channel-summed squared mean 12
    va[env] = 0.0
    quanta = np.random.default_rng(3).integers(1, 4, size=(int(env.sum()), 1))
    vb[env] = quanta * 2.0 ** -26 * 12.0 / 3.0             # channel sum: 1..3 quanta of 2^-26 x 12
    blind = compare_variances(va, 64, vb, 4096, alpha=1e-3)
    assert not blind.agree and blind.ratio < 0.75
    floored = compare_variances(va, 64, vb, 4096, alpha=1e-3, mean_a=ma, mean_b=mb)
    clean = compare_variances(va[:, 24:], 64, vb[:, 24:], 4096, alpha=1e-3)
    assert floored.agree and floored.n_tiles == clean.n_tiles
    assert floored.ratio == pytest.approx(clean.ratio, rel=1e-12)
    vb[env] = 1e-4 * 12.0                                  # a real variance the tracer lacks
    assert not compare_variances(va, 64, vb, 4096, alpha=1e-3, mean_a=ma, mean_b=mb).agree
    with pytest.raises(ValueError, match="means of shape"):
        compare_variances(va, 64, vb, 4096, alpha=1e-3, mean_a=ma[:8], mean_b=mb)
