"""Bidirectional path tracing: the strategies one by one, their MIS combination, Dirac vertices.

The full estimator's mean against Mitsuba's ``path`` runs in test_agreement.py
(tests/scenes.py: ``BDPT_SCENES``), its closed forms (quad light, point light, furnace)
in test_analytic.py. Here: each strategy (s, t), unweighted, against the per-bounce
references; the weighted strategy images summing to the render; the point-light caustic,
which only the light-tracing strategies can sample, against Mitsuba's ``ptracer``.
"""
from pathlib import Path

import numpy as np
import pytest

import pathtracer
from experiments.caustics import first_hits
from mitsuba_refs.reference.cache import get_reference
from mitsuba_refs.report.wording import verdict_line
from mitsuba_refs.stats import MeanTestOptions, compare_means
from pathtracer import load_scene, render
from pathtracer.cli import main
from pathtracer.core.rng import RandomStream, sample_keys
from pathtracer.integrators.bdpt import BDPTIntegrator
from pathtracer.render.strategies import render_strategies
from tests.budget import ALPHA
from tests.test_analytic import assert_matches, quad_light_case

#: Per-bounce references of the Cornell box (Mitsuba ``path`` at max_depth = 1, 2, 3).
BOX = {"width": 64, "height": 64}
#: Paths of up to this many segments are tested strategy by strategy.
LONGEST = 3
#: Tile edge of the per-strategy mean tests. An unweighted strategy is unbiased but can be
#: heavy-tailed: s, t >= 2 joins two independent vertices with G = cos cos / d^2, whose
#: second moment diverges where two walls meet (Veach 1997, sec. 10.3.5), and s = 0 finds the
#: small light by BSDF sampling alone. A few pixels then carry most of a strategy's variance
#: and their replica estimate is unreliable (an 8-pixel tile where no sample reached the light
#: has an estimated variance of 0), so the strategies are compared on 32 x 32 tiles.
STRATEGY_TILE = 32


def strategies_of_length(k: int) -> list[tuple[int, int]]:
    """Every strategy (s, t) of the paths of k segments: s + t = k + 1, t >= 1."""
    return [(s, k + 1 - s) for s in range(k + 1)]


@pytest.fixture(scope="module")
def unweighted_box():
    """The unweighted image of every strategy of the Cornell box up to LONGEST segments."""
    scene = load_scene("cornell-box", max_depth=LONGEST, **BOX)
    return render_strategies(scene, BDPTIntegrator(max_depth=LONGEST), spp=64, seed=5,
                             weighted=False)


@pytest.mark.statistical(assertions=1)
@pytest.mark.parametrize("k", range(1, LONGEST + 1))
def test_each_unweighted_strategy_estimates_the_paths_of_its_length(unweighted_box, k):
    """Veach's triangle of images: strategy (s, t) alone, without MIS weight, is an unbiased
    estimate of the light carried by the paths of k = s + t - 1 segments, which the
    per-bounce references give as ref(max_depth = k) - ref(max_depth = k - 1).

    One assertion of the suite's budget per k: each of its k + 1 strategies is tested at
    ALPHA / (k + 1) (Bonferroni), so that all of them together falsely fail with
    probability at most ALPHA."""
    upper = get_reference("cornell-box", {**BOX, "max_depth": k}, "path", render=False)
    expected, expected_var = upper.mean, upper.var
    if k > 1:
        lower = get_reference("cornell-box", {**BOX, "max_depth": k - 1}, "path", render=False)
        # the two references share random numbers (same seed): positively correlated, so
        # the sum of their variances bounds the variance of the difference from above
        expected, expected_var = expected - lower.mean, expected_var + lower.var
    strategies = strategies_of_length(k)
    for strategy in strategies:
        mean, variance = unweighted_box[strategy]
        verdict = compare_means(mean, variance, 64, expected, expected_var, upper.n, alpha=ALPHA / len(strategies),
                                image_components=False, options=MeanTestOptions(tile=STRATEGY_TILE))
        assert verdict.agree, f"strategy {strategy}: {verdict_line(verdict)}"


def test_weighted_strategy_images_sum_to_the_render():
    """Same samples, same random numbers: the MIS-weighted images of all strategies add up
    to the rendered image (glass and a mirror make Dirac vertices on both subpaths)."""
    scene = load_scene("cornell-caustics", width=8, height=8)
    integrator = BDPTIntegrator(replicas=2)
    result = render(scene, integrator, spp=4, seed=3, processes=1)
    images = render_strategies(scene, integrator, spp=4, seed=3)
    total = sum(mean for mean, _ in images.values())
    np.testing.assert_allclose(total, result.mean, rtol=1e-12, atol=1e-15)
    assert {(0, 2), (1, 1), (1, 2), (2, 1), (2, 2)} <= set(images)


def test_no_camera_subpath_ends_on_a_point_light():
    """A point light is a Dirac position: strategies s = 0 never contribute (and get weight 0
    in the others' MIS sums); the other strategies do, with finite, non-negative values."""
    scene = load_scene("caustics", width=16, height=16, light="point")
    pixels = np.arange(256).repeat(2)
    s, _, _, value = BDPTIntegrator().contributions(
        scene, RandomStream(sample_keys(1, np.arange(512))), pixels, weighted=False)
    assert len(s) > 0 and not np.any(s == 0)
    assert np.all(np.isfinite(value)) and np.all(value >= 0)


def pixels_seeing_glass(scene) -> np.ndarray:
    """(H, W) True where some camera ray of the pixel's footprint first hits a Dirac BSDF."""
    glass = np.zeros(scene.camera.width * scene.camera.height, dtype=bool)
    for _, seen, _ in first_hits(scene):
        glass |= seen
    return glass.reshape(scene.camera.height, scene.camera.width)


@pytest.mark.statistical(assertions=1)
def test_bdpt_finds_the_point_light_caustic():
    """The caustic of the point light through the glass sphere, L S S D E: only light tracing
    (t = 1) can sample it, and BDPT's MIS gives it the whole weight. Mitsuba's ptracer
    reference holds every path whose last vertex before the camera is diffuse, i.e. every
    path of the pixels that do not see the glass: there the images must agree (path
    tracing does not: test_light.py). Through the glass BDPT also renders the lit floor
    (L D S S E, by s = 1 and the camera subpath), which ptracer cannot (it has to join the
    camera at the glass), so those pixels are left out."""
    params = {"width": 32, "height": 32, "light": "point"}
    reference = get_reference("caustics", params, "light", render=False)
    scene = load_scene("caustics", **params)
    ours = render(scene, "bdpt", spp=16, seed=22, processes=1)
    floor = ~pixels_seeing_glass(scene)[:, :, None]
    assert floor.mean() > 0.8
    verdict = compare_means(ours.mean * floor, ours.variance * floor, ours.spp,
                            reference.mean * floor, reference.var * floor, reference.n,
                            alpha=ALPHA, image_components=False)
    assert verdict.agree, verdict_line(verdict)


@pytest.mark.statistical(assertions=1)
def test_balance_heuristic_on_the_quad_light():
    """``mis="balance"``: the same closed form as test_analytic's quad light."""
    scene, expected = quad_light_case(16, 12)
    result = render(scene, BDPTIntegrator(mis="balance"), spp=16, seed=15, processes=1)
    assert_matches(result, expected)


def test_refusals():
    with pytest.raises(ValueError, match="mis must be one of"):
        BDPTIntegrator(mis="maximum")
    with pytest.raises(ValueError, match="hide_emitters"):
        BDPTIntegrator(hide_emitters=True)
    with pytest.raises(ValueError, match="replicas"):
        BDPTIntegrator(replicas=0)
    # A splatting integrator has no radiance per camera ray at all (it is not inherited only
    # to raise): the renderer and the grader dispatch on its declared `splats`.
    assert BDPTIntegrator.splats and not hasattr(BDPTIntegrator(), "radiance")
    with pytest.raises(ValueError, match="hide_emitters"):
        render(load_scene("quad-light", width=4, height=4), "bdpt", spp=1, processes=1,
               hide_emitters=True)
    with pytest.raises(ValueError, match="light tracing does not support"):
        render(load_scene("envmap", width=4, height=4), "bdpt", spp=1, processes=1)


def test_cli_renders_bdpt(tmp_path, capsys):
    out = tmp_path / "bdpt.exr"
    code = main(["render", "quad-light", "-D", "width=8", "-D", "height=6", "--spp", "2",
                 "--integrator", "bdpt", "--mis", "balance", "--replicas", "2",
                 "--processes", "1", "-o", str(out)])
    assert code == 0 and out.exists()
    with pytest.raises(SystemExit) as error:
        main(["render", "quad-light", "--integrator", "bdpt", "--mis", "max", "-o",
              str(tmp_path / "x.exr")])
    assert error.value.code == 2


def test_scene_file_selects_bdpt(tmp_path):
    """``<integrator type="bdpt">`` with its own parameters (no Mitsuba counterpart)."""
    xml = tmp_path / "scene.xml"
    builtin = Path(pathtracer.__file__).parent / "data" / "scenes" / "quad-light.xml"
    xml.write_text(builtin.read_text().replace(
        '<integrator type="path">', '<integrator type="bdpt"><string name="mis" value="balance"/>'))
    result = render(load_scene(str(xml), width=4, height=4), spp=2, seed=1, processes=1)
    assert result.integrator == "bdpt" and result.options["mis"] == "balance"
