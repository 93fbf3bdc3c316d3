"""What a comparison could see: the detectable global bias of its mean test, weak agreements,
and ``--detect`` (mitsuba_refs.stats.detectable, mitsuba_refs.verdicts.detect).

The bound is checked against the closed forms it extends (stats.detectable's closed forms, the tile
bound) and, by injection, against the mean test itself: renders drawn around committed
references at their per-pixel variances (fixed seeds), scaled by ``1+b`` at the printed bound,
are rejected as often as a detection probability of 0.95 says, and at half the bound far less
often. Those simulations do not depend on the tracer; their assertions are Binomial quantiles
at the suite's ALPHA (tests/budget.py), as in tests/test_power.py.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats as sps

from mitsuba_refs.cli.main import main
from mitsuba_refs.errors import RefsInputError
from mitsuba_refs.reference.cache import get_reference
from mitsuba_refs.report.html import page
from mitsuba_refs.report.junit import junit_tree
from mitsuba_refs.report.results import comparison_record
from mitsuba_refs.report.wording import mean_line, verdict_line
from mitsuba_refs.stats import VARIANCE_BOUND, MeanTestOptions, compare_means, detectable_bias
from mitsuba_refs.stats._tiles import noiseless_pixels
from mitsuba_refs.stats.correlation import PixelCorrelation
from mitsuba_refs.stats.detectable import MeanTestPower, detectable_global_bias, tile_detectable_bias
from mitsuba_refs.verdicts.compare import compare
from mitsuba_refs.verdicts.detect import WEAK_BIAS, Detect, is_weak, mean_test_power, parse_bias, plan
from mitsuba_refs.verdicts.scenes import default_params
from tests.budget import ALPHA

LEVEL = 1e-3          # the comparison's alpha (compare's default)


def reference(scene, integrator="path"):
    return get_reference(scene, default_params(scene), integrator, render=False)


# ---- the bound against the closed forms ---------------------------------------------------

def test_image_component_is_the_closed_form_of_stats_power():
    """Without tiles that see more (a uniform image: every tile as noisy as the image), the
    bound is stats.detectable.detectable_bias with the test's variance as a ratio."""
    mean = np.full((32, 32, 3), 0.5)
    var = np.full((32, 32, 3), 4.0)
    for ratio in (1.0, 3.0):
        bound = detectable_global_bias(mean, var, 4096, ratio * var, 64, alpha=LEVEL)
        for sign, ours in ((1, bound.brighter), (-1, bound.darker)):
            closed = detectable_bias(mean, var, 4096, 64, alpha=LEVEL, variance_ratio=ratio,
                                     components=2, sign=sign)
            assert ours == pytest.approx(closed, rel=1e-4), (ratio, sign)
    assert bound.component == "image" and bound.floor < bound.bias


def test_the_heavy_tail_guard_moves_only_the_darker_bound_by_its_closed_form():
    """With the same estimator the image component divides by the larger of the test's own
    variance and the pooled one: brighter images keep their own (larger) variance, so that
    bound is unchanged; darker ones are divided by the pooled variance, and the bound solves
    Phi_c((z s - |b| mu) / sigma) + Phi_c((z s + |b| mu) / sigma) = 0.95 with sigma^2 =
    ((1+b)^2 V / n_a + V / n_b) / P and s^2 = (max((1+b)^2, pooled) V / n_a + V / n_b) / P."""
    from scipy import optimize
    mean, var, n_a, n_b = np.full((32, 32, 3), 0.5), np.full((32, 32, 3), 4.0), 64, 4096
    plain = detectable_global_bias(mean, var, n_b, var, n_a, alpha=LEVEL)
    guarded = detectable_global_bias(mean, var, n_b, var, n_a, alpha=LEVEL,
                                     options=MeanTestOptions(same_estimator=True))
    assert guarded.brighter == pytest.approx(plain.brighter, rel=1e-9)
    crit = MeanTestPower(mean, var, var, alpha=LEVEL).image_crit
    pixels = 32 * 32

    def power(size):
        scaled = (1.0 - size) ** 2
        pooled = (n_a * scaled + n_b) / (n_a + n_b)
        sigma = math.sqrt((scaled * 4.0 / n_a + 4.0 / n_b) / pixels)
        s = math.sqrt((max(scaled, pooled) * 4.0 / n_a + 4.0 / n_b) / pixels)
        return (sps.norm.sf((crit * s - size * 0.5) / sigma)
                + sps.norm.sf((crit * s + size * 0.5) / sigma)) - 0.95

    expected = optimize.brentq(power, 1e-6, 0.5, xtol=1e-12)
    assert guarded.darker == pytest.approx(expected, rel=1e-4)
    assert guarded.darker > plain.darker * 1.01


def test_the_heavy_tail_guard_keeps_a_short_render_that_missed_its_rare_samples():
    """The case of mitsuba-data's test_texturedprincipled1_path at 64 spp, in numbers: an
    image 5 % darker whose own per-sample variance is 0.3x the reference's (the rare bright
    samples missed) fails the own-variance image component, not the guarded one; a render
    that is noisier than the reference keeps its own variance, guarded or not."""
    rng = np.random.default_rng(5)
    truth = 0.2 + 0.1 * rng.random((48, 64, 3))
    ref_var = np.full_like(truth, 5.0)      # the image mean's se 2 % of it at 64 spp
    ref = truth + np.sqrt(ref_var / 4096) * rng.standard_normal(truth.shape)
    dark = 0.95 * truth
    plain = compare_means(dark, 0.3 * ref_var, 64, ref, ref_var, 4096, alpha=LEVEL)
    guarded = compare_means(dark, 0.3 * ref_var, 64, ref, ref_var, 4096, alpha=LEVEL,
                            options=MeanTestOptions(same_estimator=True))
    assert not plain.agree and guarded.agree
    assert abs(guarded.image_z).max() < abs(plain.image_z).max() / 1.5
    noisy = [compare_means(dark, 3.0 * ref_var, 64, ref, ref_var, 4096, alpha=LEVEL,
                           options=MeanTestOptions(same_estimator=guard)).image_z
             for guard in (False, True)]
    np.testing.assert_array_equal(noisy[0], noisy[1])


def test_tiles_only_bound_is_the_graders_on_the_light_reference():
    """A splatting render's bound is the tiles' (stats.detectable.tile_detectable_bias, an
    independent implementation: Bonferroni where this one uses Šidák, so nearly equal)."""
    ref = reference("cornell-box", "light")
    bound = detectable_global_bias(ref.mean, ref.var, ref.n, ref.var, 64, alpha=LEVEL,
                                   max_var_ratio=VARIANCE_BOUND, image_components=False)
    grader = tile_detectable_bias(ref.mean, ref.var, ref.n, 64, alpha=LEVEL)
    assert bound.component == "tiles"
    assert bound.brighter == pytest.approx(grader, rel=2e-3)


def test_a_filtered_film_changes_the_tiles_not_the_image_sums():
    """With a tent film a tile keeps the share s_8 of its pixels' variance row sums; the
    image mean's variance is the sum of the row sums whatever the filter."""
    ref = reference("cornell-box", "light")
    tent = PixelCorrelation((0.25, 1.0, 0.25))
    share = tent.within_tile_share(8)
    box, filtered = (detectable_global_bias(ref.mean, ref.var, ref.n, ref.var, 64, alpha=LEVEL,
                                            image_components=False, options=MeanTestOptions(pixel_correlation=c))
                     for c in (None, tent))
    assert filtered.brighter < box.brighter
    assert filtered.brighter / box.brighter == pytest.approx(math.sqrt(share), rel=0.02)
    model_box = MeanTestPower(ref.mean, ref.var, ref.var, alpha=LEVEL)
    model_tent = MeanTestPower(ref.mean, ref.var, ref.var, alpha=LEVEL, options=MeanTestOptions(pixel_correlation=tent))
    assert model_box._image_power(0.01, 64, 4096) == model_tent._image_power(0.01, 64, 4096)


def test_power_grows_with_the_bias_and_the_samples():
    ref = reference("cornell-box")
    model = MeanTestPower(ref.mean, ref.var, ref.var, alpha=LEVEL, max_var_ratio=VARIANCE_BOUND)
    powers = [model.power(b, 64, 4096) for b in (0.0, 0.005, 0.01, 0.02, 0.05)]
    assert powers == sorted(powers) and powers[0] < 0.01 and powers[-1] > 0.999
    biases = [model.worst(n, 4096) for n in (16, 64, 256, 1 << 20)]
    assert biases == sorted(biases, reverse=True)
    assert biases[-1] == pytest.approx(model.floor(4096), rel=5e-3)     # 2^20 = 256x the reference
    # se ~ 1/sqrt(n) while the test's noise dominates: 4x the samples, about half the bias
    assert biases[1] / biases[2] == pytest.approx(2.0, rel=0.1)


def test_a_black_reference_sees_no_global_bias():
    black = np.zeros((16, 16, 3))
    bound = detectable_global_bias(black, black, 4096, black, 64, alpha=LEVEL)
    assert math.isinf(bound.bias)


# ---- injection: the printed bound is right --------------------------------------------------

def injected(b, ref, test_var, n, *, same, splats, seeds, seed):
    """Rejections of ``seeds`` simulated renders whose noisy pixels are ``(1+b)`` times the
    reference image's (the module notes of stats.detectable), drawn at
    ``test_var`` (test, ``n`` spp) and the reference's variance (``ref.n``), by the mean test
    as compare() runs it. One normal per pixel for all channels (one path carries all three)."""
    rng = np.random.default_rng(seed)
    truth = np.asarray(ref.mean, dtype=np.float64)
    v = np.maximum(np.asarray(ref.var, dtype=np.float64), 0.0)
    sd_ref, sd_test = np.sqrt(v / ref.n), np.sqrt(test_var / n)
    shape = truth.shape[:2] + (1,)
    # the bias moves the sampled light: the noiseless pixels (the light itself) stay
    noiseless = noiseless_pixels(v.sum(axis=2), test_var.sum(axis=2), truth, truth)
    scaled = np.where(noiseless[..., None], 1.0, 1.0 + b)
    rejected = 0
    for _ in range(seeds):
        simulated_ref = truth + sd_ref * rng.standard_normal(shape)
        test = scaled * (truth + sd_test * rng.standard_normal(shape))
        result = compare_means(test, test_var * (1.0 + b) ** 2, n, simulated_ref, v, ref.n,
                               alpha=LEVEL, max_var_ratio=VARIANCE_BOUND if same else None,
                               image_components=not splats, options=MeanTestOptions(same_estimator=same))
        rejected += not result.agree
    return rejected


CASES = {
    # the same estimator at the default 64 spp: the whole-image components decide
    "cornell-box-path": ("cornell-box", "path", 1.0, True, False),
    # a light tracer: tiles only, own and bounded variance
    "cornell-box-light": ("cornell-box", "light", 1.0, True, True),
    # another estimator, 3x noisier, on the scene whose image mean is dominated by a few
    # pixels (glossy highlights of small lights): the tiles see far more than the image mean
    "veach-mis-noisier": ("veach-mis", "path", 3.0, False, False),
}


@pytest.mark.parametrize("case", CASES)
def test_an_image_scaled_at_the_printed_bound_fails_with_probability_095(case):
    """At the bound (each sign) at least the lower ALPHA-quantile of Binomial(100, 0.95) of 100
    injected renders fail (if the bound holds this fails with probability <= ALPHA); at half
    the bound at most the upper ALPHA-quantile of Binomial(50, 0.5) of 50 do (the power there
    is 4-20 % in these cases: the bound is not loose by a factor 2)."""
    scene, integrator, ratio, same, splats = CASES[case]
    ref = reference(scene, integrator)
    test_var = ratio * np.maximum(np.asarray(ref.var, dtype=np.float64), 0.0)
    bound = detectable_global_bias(ref.mean, ref.var, ref.n, test_var, 64, alpha=LEVEL,
                                   max_var_ratio=VARIANCE_BOUND if same else None,
                                   image_components=not splats, options=MeanTestOptions(same_estimator=same))
    need = int(sps.binom.ppf(ALPHA, 100, 0.95))
    most = int(sps.binom.isf(ALPHA, 50, 0.5))
    for k, (sign, b) in enumerate(((1, bound.brighter), (-1, bound.darker))):
        at = injected(sign * b, ref, test_var, 64, same=same, splats=splats, seeds=100, seed=10 + k)
        half = injected(sign * b / 2, ref, test_var, 64, same=same, splats=splats, seeds=50,
                        seed=20 + k)
        print(case, sign, f"b={b:.4f}", at, half)
        assert at >= need, (case, sign, b, at)
        assert half <= most, (case, sign, b, half)


# ---- verdicts: the bound printed, weak agreements -------------------------------------------

def reference_images(scene, integrator):
    """A render hook answering with the reference's own images (the mean agrees exactly:
    what is left to see is what the test could have seen)."""
    ref = reference(scene, integrator)

    def render(*args, **kwargs):
        return np.array(ref.mean), np.array(ref.var)
    return render


def test_every_mean_verdict_says_what_it_could_see():
    result = compare("cornell-box", "path", convergence=False,
                     render=reference_images("cornell-box", "path"))
    bound = result.detectable
    assert result.agree and not is_weak(result) and bound.bias < WEAK_BIAS
    line = mean_line(result)
    assert line.startswith(verdict_line(result.mean))
    assert f"+{100 * bound.brighter:.1f}% / \u2212{100 * bound.darker:.1f}%" in line
    assert "with probability 0.95 (alpha 0.001)" in line
    report = result.report()
    assert report.splitlines()[0].endswith("AGREES with Mitsuba")
    assert "mean:        " + line in report


def test_an_agreement_that_could_not_see_five_percent_is_weak(tmp_path):
    """smallpt's path_bsdf at the default 64 spp misses global biases up to ~5.2 %."""
    result = compare("smallpt", "path_bsdf", convergence=False,
                     render=reference_images("smallpt", "path_bsdf"))
    assert result.agree and is_weak(result)
    assert WEAK_BIAS < result.detectable.bias < 0.1
    shown = f"{100 * result.detectable.bias:.1f}%"
    head = result.report().splitlines()[0]
    assert head.endswith(f"AGREES with Mitsuba, weakly (could not see less than {shown})")
    line = mean_line(result)
    assert line.startswith(f"agrees, but could not see less than {shown} (p=")
    assert "--detect 2% picks the spp that would see 2%" in line
    record = comparison_record(result, tmp_path)
    assert record["weak"] is True and record["verdicts"]["mean"]["line"] == line
    entry = record["verdicts"]["mean"]["detectable_bias"]
    assert entry["bias"] == result.detectable.bias and entry["weak"] and entry["power"] == 0.95
    assert f"AGREES with Mitsuba, weakly (could not see less than {shown})" in page([record])
    properties = {p.get("name"): p.get("value") for p in junit_tree([record]).iter("property")}
    assert properties["weak"] == "true"
    assert float(properties["mean.detectable_bias"]) == pytest.approx(result.detectable.bias)


# ---- --detect: the pure choice --------------------------------------------------------------

def model_of(scene, integrator="path"):
    ref = reference(scene, integrator)
    return mean_test_power(ref, ref.var, alpha=LEVEL, same=True, splats=False)


def test_detect_picks_the_smallest_step_that_meets_the_target_with_its_margin():
    model = model_of("cornell-box")
    choice = plan(model, 0.02, 4096, seconds_per_spp=0.1, max_time=300)
    exact = next(n for n in range(2, 10_000) if model.worst(n, 4096) <= 0.02)
    assert model.worst(exact - 1, 4096) > 0.02
    assert choice.spp % 16 == 0 and choice.spp >= 1.1 * exact and choice.spp < 1.1 * exact + 16
    assert choice.met and choice.predicted <= 0.02 and choice.needed == choice.spp
    assert f"{choice.spp} spp" in choice.reason and f"asks for {exact} spp" in choice.reason


def test_detect_keeps_the_default_when_it_already_sees_the_target():
    choice = plan(model_of("cornell-box"), 0.05, 4096, seconds_per_spp=0.1, max_time=300)
    assert choice.spp == 64 and "(the default) already sees" in choice.reason


def test_detect_within_max_time_says_what_it_could_not_reach():
    model = model_of("cornell-box")
    choice = plan(model, 0.01, 4096, seconds_per_spp=0.5, max_time=100)
    assert choice.spp == 192 and choice.allowed == 192 and not choice.met
    assert choice.needed > 192
    assert "is not met within --max-time 100 s" in choice.reason
    assert f"{choice.needed} spp" in choice.reason


def test_detect_below_the_references_floor_names_the_floor_and_the_samples_it_needs():
    model = model_of("cornell-box")
    floor = model.floor(4096)
    choice = plan(model, 0.001, 4096, seconds_per_spp=0.01, max_time=300)
    assert choice.needed is None and not choice.met and choice.floor == floor > 0.001
    assert model.floor(choice.reference_needed) <= 0.001 < model.floor(choice.reference_needed - 1)
    # the floor falls as 1/sqrt(reference samples)
    assert choice.reference_needed == pytest.approx(4096 * (floor / 0.001) ** 2, rel=0.02)
    assert "cannot be met" in choice.reason and f"{choice.reference_needed:,} spp" in choice.reason
    assert model.worst(choice.spp, 4096) <= 1.1 * floor


@pytest.mark.parametrize("text, value", [("2%", 0.02), ("0.5 %", 0.005), ("0.03", 0.03)])
def test_detect_reads_percentages_and_fractions(text, value):
    assert parse_bias(text) == pytest.approx(value)


@pytest.mark.parametrize("args, words", [
    (["--detect", "0%"], "--detect takes a relative bias"),
    (["--detect", "two"], "--detect takes a relative bias"),
    (["--detect", "2%", "--spp", "128"], "--spp and --detect both set the sample count"),
    (["--max-time", "60"], "--max-time goes with --detect"),
    (["--detect", "2%", "--max-time", "0"], "--max-time must be a number of seconds > 0"),
])
def test_detect_options_are_checked_before_anything_renders(capsys, args, words):
    code = main(["compare", "cornell-box", "--no-convergence", "--out", "out/test-detect", *args])
    err = capsys.readouterr().err
    assert code == 2 and words in err and len(err.strip().splitlines()) == 1, err


def test_check_refuses_detect_with_images(capsys):
    code = main(["check", "cornell-box", "--images", "x.exr", "--detect", "2%"])
    err = capsys.readouterr().err
    assert code == 2 and "--detect goes with --command" in err, err
    with pytest.raises(RefsInputError, match="--detect goes with --command"):
        from mitsuba_refs.external.check import check
        check("cornell-box", images=["x.exr"], detect=Detect(0.02))


# ---- --detect on real renders ---------------------------------------------------------------

@pytest.mark.statistical(assertions=1)
def test_detect_picks_an_spp_that_meets_the_target_on_the_cornell_box():
    """--detect 2% on the Cornell box: the default 64 spp sees only 2.4 %; the pilot chooses
    more, and the render at that spp, judged from its own variance, sees 2 %. (The agreement
    itself is the suite's statistical assertion.)"""
    result = compare("cornell-box", "path", convergence=False,
                     detect=Detect(0.02, max_time=1e6))
    choice = result.detect
    assert choice.spp > 64 and result.spp == choice.spp and choice.met
    assert result.detectable.test_spp == choice.spp
    assert result.detectable.bias <= 0.02, (choice, result.detectable)
    assert [run["purpose"] for run in result.runs] == ["pilot", "mean"]
    assert result.runs[0]["spp"] == 16 and result.runs[1]["spp"] == choice.spp
    assert choice.reason in result.notes
    assert result.mean.agree, result.report()


def test_check_detect_runs_the_pilot_through_the_command(tmp_path):
    """The same with the tracer as an external command: the pilot is one more run (after the
    probe every check starts with: a replica-sized run telling whether images carry variance)."""
    import sys

    from mitsuba_refs.external.check import check
    command = (f"{sys.executable} -m pathtracer.cli render {{scene}} --resolution "
               "{width}x{height} --spp {spp} --seed {seed} -o {out}")
    result = check("cornell-box", command=command, same_estimator=True, convergence=False,
                   detect=Detect(0.02, max_time=1e6), jobs=1)
    assert [run["spp"] for run in result.runs] == [2, 16, result.spp] and result.spp > 64
    assert result.detect.met and result.detectable.bias <= 0.02, result.report()
    assert any(note.startswith("--detect 2.0%: ") for note in result.notes)
