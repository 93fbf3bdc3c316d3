"""Reconstruction filters (pathtracer.sensors.film): weights, splatting, statistics, and Mitsuba's film.

The Mitsuba checks (marked ``mitsuba``) use a vectorised variant (``llvm_ad_rgb``): it
evaluates the filters exactly, as the references are rendered; the scalar variants
tabulate them (docs/scene-format.md).
"""
import numpy as np
import pytest

from mitsuba_refs.stats.correlation import pixel_correlation
from pathtracer import load_scene, render
from pathtracer.sensors.film import ReconstructionFilter, effective_counts, lag_correlations, splat
from tests.budget import ALPHA

TENT = ReconstructionFilter.make("tent")
GAUSSIAN = ReconstructionFilter.make("gaussian")
FILTERS = [("tent", 1.0), ("tent", 1.6), ("gaussian", 0.5), ("gaussian", 0.3)]


def _splat_one(rfilter, width, height, x, y, value=1.0):
    """Weights of a single sample at film position (x, y), as an (H, W) image."""
    col, row = int(np.floor(x)), int(np.floor(y))
    u = np.array([[[x - col, y - row]]])
    w, wf, _ = splat(rfilter, width, height, np.array([row * width + col]), u,
                     np.full((1, 1, 1), value))
    return w.reshape(height, width), wf.reshape(height, width)


def test_weights_are_separable_products_around_pixel_centres():
    w, wf = _splat_one(GAUSSIAN, 9, 7, 4.3, 2.8, value=2.0)
    centres_x, centres_y = np.arange(9) + 0.5, np.arange(7) + 0.5
    expected = np.outer(GAUSSIAN.eval(centres_y - 2.8), GAUSSIAN.eval(centres_x - 4.3))
    np.testing.assert_allclose(w, expected, rtol=1e-14, atol=1e-300)
    np.testing.assert_allclose(wf, 2.0 * expected, rtol=1e-14, atol=1e-300)
    assert np.count_nonzero(w) == 16        # |d| < 2 reaches 4 centres along each axis


def test_tent_weights_of_an_interior_sample_sum_to_one():
    """Tent functions on the pixel lattice are a partition of unity (bilinear splatting)."""
    for x, y in [(3.2, 4.7), (5.5, 5.5), (4.01, 3.99)]:
        w, _ = _splat_one(TENT, 10, 10, x, y)
        assert w.sum() == pytest.approx(1.0, abs=1e-14)


def test_samples_are_clipped_at_the_image_edge_and_edge_pixels_normalised():
    """A constant image stays constant to the last pixel, with zero variance."""
    rng = np.random.default_rng(1)
    h, w, n = 6, 8, 5
    sums = splat(GAUSSIAN, w, h, np.arange(h * w), rng.random((h * w, n, 2)),
                 np.full((h * w, n, 3), 0.7))
    from pathtracer.render.moments import filtered_mean_and_variance
    mean, var = filtered_mean_and_variance(sums, effective_counts(GAUSSIAN, w, h, n).reshape(-1, 1))
    np.testing.assert_allclose(mean, 0.7, rtol=1e-14)
    assert not var.any()
    corner, _ = _splat_one(GAUSSIAN, w, h, 0.2, 0.1)
    assert corner[0, 0] > 0 and corner.shape == (h, w)


def test_effective_counts():
    assert np.all(effective_counts(ReconstructionFilter(), 5, 4, 16) == 16)
    # tent: per axis (∫w)^2 / ∫w^2 = 1 / (2/3) in the interior, so 2.25 spp in 2-D
    n_eff = effective_counts(TENT, 12, 10, 16)
    assert n_eff[5, 6] == pytest.approx(16 * 2.25, rel=1e-5)
    assert n_eff[0, 0] < n_eff[5, 6]            # corners receive fewer samples
    # gaussian: Kish's count of the weights of ~5x5 pixels' samples
    assert effective_counts(GAUSSIAN, 12, 10, 1)[5, 6] == pytest.approx(
        float(_kish_1d(GAUSSIAN)) ** 2, rel=1e-4)


def _kish_1d(rfilter):
    x = np.linspace(-rfilter.radius, rfilter.radius, 200001)
    w = rfilter.eval(x)
    return w.sum() ** 2 / (w * w).sum() / (len(x) - 1) * 2 * rfilter.radius


def test_lag_correlations_of_the_tent():
    """∫ tent(x) tent(x + 1) dx / ∫ tent^2 = (1/6) / (2/3) = 1/4."""
    rho = lag_correlations(TENT)
    np.testing.assert_allclose(rho, [0.0, 0.25, 1.0, 0.25, 0.0], atol=1e-5)
    corr = pixel_correlation(TENT)
    assert corr.design_effect(8) == pytest.approx((1 + 2 * 0.25 * 7 / 8) ** 2, rel=1e-4)
    assert pixel_correlation(ReconstructionFilter()).independent


@pytest.fixture(scope="module")
def filtered_quad():
    return load_scene("quad-light-filtered", rfilter="gaussian", width=16, height=12)


def test_filtered_render_does_not_depend_on_processes_or_batching(filtered_quad):
    a = render(filtered_quad, spp=2, seed=2, processes=1)
    b = render(filtered_quad, spp=2, seed=2, processes=2, batch_size=40)
    c = render(filtered_quad, spp=2, seed=2, processes=1, batch_size=40)
    assert np.array_equal(b.mean, c.mean) and np.array_equal(b.variance, c.variance)
    np.testing.assert_allclose(a.mean, b.mean, rtol=1e-13, atol=1e-300)
    np.testing.assert_allclose(a.variance, b.variance, rtol=1e-12, atol=1e-300)


def test_loader_defaults_to_mitsubas_gaussian(tmp_path):
    xml = tmp_path / "s.xml"
    xml.write_text("""<scene version="3.0.0"><sensor type="perspective">
        <float name="fov" value="40"/>
        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="6"/>
        </film></sensor>
        <shape type="sphere"><emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>
        </scene>""")
    assert load_scene(str(xml)).camera.rfilter == ReconstructionFilter("gaussian", 2.0, 0.5)
    text = xml.read_text().replace("</film>", '<rfilter type="tent"><float name="radius" '
                                              'value="1.5"/></rfilter></film>')
    xml.write_text(text)
    assert load_scene(str(xml)).camera.rfilter == ReconstructionFilter("tent", 1.5)


# ------------------------------------------------------------------ against Mitsuba

@pytest.fixture(scope="module")
def mi_llvm(mi):
    """Mitsuba in ``llvm_ad_rgb`` (exact filter weights, as the references), then back to
    the conftest's ``scalar_rgb``."""
    from mitsuba_refs.reference.variant import probe_llvm
    ok, detail = probe_llvm()
    if not ok:
        pytest.skip(f"llvm_ad_rgb unusable ({detail}); scalar variants tabulate the filter")
    mi.set_variant("llvm_ad_rgb")
    yield mi
    mi.set_variant("scalar_rgb")


@pytest.mark.mitsuba
@pytest.mark.parametrize("kind,value", FILTERS)
def test_splat_matches_mitsubas_image_block(mi_llvm, kind, value):
    """Where each sample's weights go and how large they are, as Mitsuba's ImageBlock.put.

    Mitsuba evaluates the gaussian with a polynomial fit of exp (max deviation from the
    exact Gaussian 4e-4 of the peak weight); the tent is exact up to float32.
    """
    mi = mi_llvm
    name = "stddev" if kind == "gaussian" else "radius"
    mitsuba_filter = mi.load_dict({"type": kind, name: value})
    ours = ReconstructionFilter.make(kind, value)
    assert float(mitsuba_filter.radius()) == pytest.approx(ours.radius, rel=1e-6)
    width, height = 7, 6
    rng = np.random.default_rng(0)
    points = np.vstack([rng.uniform([0, 0], [width, height], (30, 2)), [[0.1, 0.05], [6.99, 5.5]]])
    block = mi.ImageBlock(size=[width, height], offset=[0, 0], channel_count=1,
                          rfilter=mitsuba_filter, border=True, coalesce=False)
    # one vectorised put of every sample (one kernel), against our weights summed
    block.put(mi.Point2f(mi.Float(points[:, 0]), mi.Float(points[:, 1])),
              [mi.Float(np.ones(len(points)))])
    ours_total = sum(_splat_one(ours, width, height, x, y)[0] for x, y in points)
    b = block.border_size()
    theirs = np.array(block.tensor())[b:b + height, b:b + width, 0]
    tolerance = 1e-3 if kind == "gaussian" else 1e-6
    np.testing.assert_allclose(ours_total, theirs, atol=tolerance * len(points))
    np.testing.assert_array_equal(ours_total > 0, theirs > 0)


EDGE_SCENE = """<scene version="3.0.0">
    <default name="rfilter" value="gaussian"/>
    <default name="width" value="24"/>
    <default name="height" value="16"/>
    <default name="spp" value="64"/>
    <default name="max_depth" value="1"/>
    <integrator type="path"><integer name="max_depth" value="$max_depth"/></integrator>
    <sensor type="perspective">
        <float name="fov" value="30"/>
        <transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
        <film type="hdrfilm">
            <integer name="width" value="$width"/><integer name="height" value="$height"/>
            <rfilter type="$rfilter"/>
        </film>
    </sensor>
    <shape type="rectangle">
        <transform name="to_world"><scale value="0.7"/><rotate z="1" angle="20"/></transform>
        <emitter type="area"><rgb name="radiance" value="1, 0.5, 0.25"/></emitter>
    </shape>
</scene>
"""


def _pixel_z(ours, ours_n_eff, ref, ref_n_eff):
    """Per-pixel z of two filtered images, each pixel's own variance being var / n_eff."""
    se = np.sqrt(ours.variance / ours_n_eff[..., None] + ref.var / ref_n_eff[..., None])
    diff = ours.mean - ref.mean
    # pixels without noise on either side (inside or outside the emitter): float32 agreement
    exact = se == 0
    assert np.all(np.abs(diff[exact]) <= 1e-6 * np.maximum(np.abs(ref.mean[exact]), 1e-6))
    return np.abs(diff[~exact] / se[~exact])


@pytest.mark.mitsuba
@pytest.mark.statistical(assertions=2)
@pytest.mark.parametrize("kind", ["tent", "gaussian"])
def test_sharp_emitter_edges_match_mitsubas_filtered_film(mi_llvm, tmp_path, kind):
    """A tilted emitter seen directly (max_depth 1): the only randomness is where samples
    land, so each pixel on its edges is the filter at work. Per pixel, Mitsuba's film and
    ours agree; a box film is told apart (tile means cannot see a filter, which keeps
    local averages: docs/statistics.md)."""
    from scipy import stats

    from mitsuba_refs.reference.render import render_reference
    path = tmp_path / "edge.xml"
    path.write_text(EDGE_SCENE)
    ref = render_reference(path, {"rfilter": kind}, "path", 1024, 5, variant="llvm_ad_rgb")
    assert ref.metadata["rfilter"]["type"] == kind
    rfilter = ReconstructionFilter.make(kind)
    ref_n_eff = effective_counts(rfilter, 24, 16, ref.n)
    z_crit = stats.norm.isf((1 - (1 - ALPHA) ** (1 / ref.mean.size)) / 2)     # Šidák, two-sided
    ours = render(load_scene(str(path), rfilter=kind), spp=256, seed=9, processes=1)
    z = _pixel_z(ours, effective_counts(rfilter, 24, 16, 256), ref, ref_n_eff)
    assert z.max() < z_crit, f"{kind}: max per-pixel |z| {z.max():.1f} >= {z_crit:.1f}"
    box = render(load_scene(str(path), rfilter="box"), spp=256, seed=9, processes=1)
    z_box = _pixel_z(box, np.full((16, 24), 256.0), ref, ref_n_eff)
    assert z_box.max() > 2 * z_crit, f"box film not told apart: max |z| {z_box.max():.1f}"
