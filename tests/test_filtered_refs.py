"""Tent- and gaussian-filtered references in ``scalar_rgb`` (mitsuba_refs.reference.positions,
mitsuba_refs.reference.filtered): Mitsuba's sample positions recomputed, the exact reconstruction,
and references built live against the tracer (docs/references.md, "Filtered films").

The first tests need no Mitsuba: known answers and hand computations. The live ones
(marker ``mitsuba``) check the positions against the rays Mitsuba traces, and build
filtered references from scratch, the path a user's scene takes on a fresh machine.
"""
import json
from pathlib import Path

import numpy as np
import pytest

from mitsuba_refs.reference.filtered import FilteredSums
from mitsuba_refs.reference.positions import (
    batch_positions,
    morton_decode_2d,
    pcg32_first_2d,
    pcg32_outputs,
    pixel_seeds,
    spiral_block_ids,
)
from mitsuba_refs.reference.render import choose_method
from pathtracer.sensors.film import ReconstructionFilter
from tests.budget import ALPHA

TENT = ReconstructionFilter.make("tent")
GAUSSIAN = ReconstructionFilter.make("gaussian")
BOX = ReconstructionFilter.make("box")

#: A user's scene whose film names no filter (hdrfilm's default gaussian), 1024x768 as written.
USER_SCENE = Path(__file__).parent / "data" / "filtered_user" / "scene.xml"


# ------------------------------------------------------------------ sample positions


def test_pcg32_gives_the_reference_implementations_known_answer():
    """O'Neill's pcg32-demo, ``pcg32_srandom(42, 54)``: its first six outputs."""
    outputs = pcg32_outputs(np.array([42], dtype=np.uint64), 54, 6)
    assert [int(v[0]) for v in outputs] == [0xA15C02B7, 0x7B47F409, 0xBA1D3330,
                                            0x83D2F293, 0xBFA4784B, 0xCBED606E]


def test_unit_floats_are_the_top_23_bits():
    first, second = pcg32_first_2d(np.arange(1000))
    bits = pcg32_outputs(np.arange(1000, dtype=np.uint64))
    assert first.dtype == np.float32 and np.all((first >= 0) & (first < 1))
    np.testing.assert_array_equal(first, (bits[0] >> 9) / np.float32(2 ** 23))
    np.testing.assert_array_equal(second, (bits[1] >> 9) / np.float32(2 ** 23))


def test_morton_order_interleaves_x_and_y_bits():
    x, y = morton_decode_2d(range(8))
    assert list(zip(x, y)) == [(0, 0), (1, 0), (0, 1), (1, 1), (2, 0), (3, 0), (2, 1), (3, 1)]


def test_spiral_starts_in_the_middle_and_turns_right_down_left_up():
    np.testing.assert_array_equal(spiral_block_ids(96, 96), [[6, 7, 8], [5, 0, 1], [4, 3, 2]])
    np.testing.assert_array_equal(spiral_block_ids(128, 64), [[7, 3, 4, 5], [6, 2, 0, 1]])
    np.testing.assert_array_equal(spiral_block_ids(40, 40), [[2, 3], [1, 0]])


def test_pixel_seeds_follow_blocks_and_morton_order():
    seeds = pixel_seeds(3, 40, 40)
    base = 3 * 40 * 40
    # pixel (0, 0) opens block (0, 0), the spiral's third (id 2): 1024 seeds per block
    assert [seeds[0, 0], seeds[0, 1], seeds[1, 0], seeds[1, 1]] == \
        [base + 2048, base + 2049, base + 2050, base + 2051]
    # pixel (39, 39) is (7, 7) in block (1, 1), the spiral's first: Morton 0b111111
    assert seeds[39, 39] == base + 63
    assert len(np.unique(seeds)) == seeds.size


def test_batch_positions_stay_in_their_pixels_but_for_rounding():
    x, y = batch_positions(1, 84, 64, 48)
    assert x.shape == y.shape == (48, 84 * 64)
    columns = np.arange(84 * 64) % 64
    rows = np.arange(48)[:, None]
    # how far each traced position lies outside the pixel the box film stores it in
    beyond = np.maximum.reduce([columns - x, x - columns - 1, rows - y, y - rows - 1,
                                np.zeros_like(x)])
    # float32 rounding puts a few samples just across a pixel edge (2^-11 px at most here)
    assert 0 < np.count_nonzero(beyond) < 0.01 * x.size
    near = beyond[(beyond > 0) & (beyond < 1)]
    assert near.max() <= 2.0 ** -11
    # ... and a copy boundary's rounding can send one to the other side of the image
    far = beyond >= 1
    assert np.count_nonzero(far) == 1 and x[far][0] < 1e-3 and beyond[far][0] > 62


# ------------------------------------------------------------------ the reconstruction


def _hand_sums(rfilter, width, height, xs, ys, values):
    """Per-pixel moments by the definition: every sample against every pixel centre."""
    w = np.zeros((height, width))
    wf = np.zeros((height, width, 3))
    wf2 = np.zeros((height, width, 3))
    for x, y, f in zip(xs, ys, values):
        for row in range(height):
            for col in range(width):
                weight = float(rfilter.eval(col + 0.5 - x)) * float(rfilter.eval(row + 0.5 - y))
                w[row, col] += weight
                wf[row, col] += weight * f
                wf2[row, col] += weight * f * f
    return wf / w[..., None], wf2 / w[..., None]


@pytest.mark.parametrize("rfilter", [TENT, GAUSSIAN, ReconstructionFilter.make("tent", 1.5)],
                         ids=["tent", "gaussian", "tent-1.5"])
def test_reconstruction_is_the_filter_weighted_moments(rfilter):
    """Samples stored in their pixels, a few traced just across an edge and one across the
    image (a batch sensor's copy boundary): the moments are those of the definition."""
    rng = np.random.default_rng(4)
    height, samples, width = 5, 3, 7
    rows = np.arange(height)[:, None, None]
    cols = np.arange(width)[None, None, :]
    x = cols + rng.uniform(0, 1, (height, samples, width))
    y = rows + rng.uniform(0, 1, (height, samples, width))
    x[0, 0, 0], y[1, 1, 2] = -1e-5, 2 + 1 + 3e-5            # just across an edge
    x[2, 0, 6], x[3, 2, 6] = 0.0004, 7.0                     # across the image; on its edge
    x[4, 1, 3] = 4.0                                          # on the pixel's right edge
    values = rng.uniform(0, 2, (height, samples, width, 3))
    sums = FilteredSums(rfilter, width, height)
    sums.add(values[:, :2], x[:, :2], y[:, :2])               # two calls, as a render makes
    sums.add(values[:, 2:], x[:, 2:], y[:, 2:])
    m1, m2 = sums.moments()
    h1, h2 = _hand_sums(rfilter, width, height, x.ravel(), y.ravel(),
                        values.reshape(-1, 3))
    np.testing.assert_allclose(m1, h1, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(m2, h2, rtol=1e-12, atol=1e-14)


def test_methods_of_a_filtered_film():
    assert choose_method("scalar_rgb", GAUSSIAN, "path", False) == "batch"
    assert choose_method("llvm_ad_rgb", TENT, "path", False) == "moments"
    assert choose_method("scalar_rgb", BOX, "path", False) == "batch"
    with pytest.raises(ValueError, match="tabulates the filter weights"):
        choose_method("scalar_rgb", GAUSSIAN, "path", False, "moments")
    with pytest.raises(ValueError, match="camera inside a medium needs a vectorised"):
        choose_method("scalar_rgb", TENT, "volpath", True)
    with pytest.raises(ValueError, match="needs scalar_rgb"):
        choose_method("llvm_ad_rgb", GAUSSIAN, "path", False, "batch")
    with pytest.raises(ValueError, match="light tracer's references need a box filter"):
        choose_method("scalar_rgb", GAUSSIAN, "ptracer", False)
    # The batch route samples the image's pixels only; a bordered film needs llvm_ad_rgb.
    from pathtracer.sensors.film import ReconstructionFilter
    bordered = ReconstructionFilter.make("gaussian", None, True)
    with pytest.raises(ValueError, match="film with sample_border needs a vectorised"):
        choose_method("scalar_rgb", bordered, "path", False)
    assert choose_method("llvm_ad_rgb", bordered, "path", False) == "moments"


# ------------------------------------------------------------------ against Mitsuba


@pytest.mark.mitsuba
def test_pcg32_is_mitsubas_independent_sampler(mi):
    sampler = mi.load_dict({"type": "independent"})
    seeds = np.random.default_rng(1).integers(0, 2 ** 32, 300, dtype=np.uint64)
    first, second = pcg32_first_2d(seeds)
    for seed, a, b in zip(seeds, first, second):
        sampler.seed(int(seed))
        point = sampler.next_2d()
        assert (float(point[0]), float(point[1])) == (float(a), float(b))


@pytest.mark.mitsuba
@pytest.mark.parametrize("copies,width,height", [(3, 24, 40), (5, 37, 29), (12, 64, 48)])
def test_positions_are_the_rays_mitsuba_traces(mi, copies, width, height):
    """Spiral blocks of several films (not multiples of 32 among them), batch copies:
    every ray of a 1-spp render is the camera's ray at the predicted position, exactly."""
    from mitsuba_refs.reference.positions import position_error
    assert position_error(copies, width, height, 1 + copies * 7919) == 0.0


@pytest.mark.mitsuba
def test_positions_hold_in_a_real_render(mi, tmp_path):
    """An emitter seen directly (max_depth 1): each sample of Mitsuba's own estimator is the
    emitter's radiance exactly where the ray at the predicted position hits it, else 0."""
    from mitsuba_refs.reference.batch import batch_sensor
    from mitsuba_refs.reference.filtered import integrator_with_blocks
    from tests.test_film import EDGE_SCENE
    path = tmp_path / "edge.xml"
    path.write_text(EDGE_SCENE)
    scene = mi.load_file(str(path))
    sensor = scene.sensors()[0]
    copies, width, height, seed = 3, 24, 16, 4242
    integrator = mi.load_dict(integrator_with_blocks({"type": "path", "max_depth": 1}))
    image = np.array(mi.render(scene, sensor=batch_sensor(sensor, copies, width, height),
                               integrator=integrator, spp=1, seed=seed))[..., :3]
    xs, ys = batch_positions(seed, copies, width, height)
    radiance = np.array([1, 0.5, 0.25], dtype=np.float32)
    hits = 0
    for (row, col), x in np.ndenumerate(xs):
        ray, _ = sensor.sample_ray(0.0, 0.0, mi.Point2f(x / width, ys[row, col] / height),
                                   mi.Point2f(0.5, 0.5))
        hit = scene.ray_intersect(ray).is_valid()
        hits += hit
        np.testing.assert_array_equal(image[row, col], radiance if hit else 0 * radiance)
    assert 0.1 * xs.size < hits < 0.9 * xs.size      # the emitter's edges are in the picture


@pytest.mark.mitsuba
@pytest.mark.statistical(assertions=2)
@pytest.mark.parametrize("kind", ["tent", "gaussian"])
def test_scalar_filtered_reference_matches_the_tracer_at_sharp_edges(mi, tmp_path, kind):
    """tests/test_film.py's sharp-edge check with a ``scalar_rgb`` reference: per pixel on
    the edges of a directly seen emitter, it agrees with the tracer's filtered film, and a
    box film is told apart."""
    from scipy import stats

    from mitsuba_refs.reference.render import render_reference
    from pathtracer import load_scene, render
    from pathtracer.sensors.film import effective_counts
    from tests.test_film import EDGE_SCENE, _pixel_z
    path = tmp_path / "edge.xml"
    path.write_text(EDGE_SCENE)
    ref = render_reference(path, {"rfilter": kind}, "path", 1024, 5, variant="scalar_rgb")
    assert (ref.metadata["variant"], ref.metadata["method"]) == ("scalar_rgb", "batch")
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


@pytest.mark.mitsuba
@pytest.mark.statistical(assertions=2)
@pytest.mark.parametrize("variant", ["scalar_rgb", "llvm_ad_rgb"])
def test_a_users_filtered_scene_gets_its_reference_built_live(mi, tmp_path, monkeypatch,
                                                              variant):
    """What a user's first ``mitsuba-refs compare FILE --resolution WxH`` does on a fresh
    install: the gaussian-filtered reference is built from scratch in an empty cache (in
    ``scalar_rgb`` by the batch method; in ``llvm_ad_rgb`` by its film, where a libLLVM
    >= 16 works), and the tracer agrees with it in mean and variance."""
    from mitsuba_refs.verdicts.compare import compare
    if variant == "llvm_ad_rgb":
        from mitsuba_refs.reference.variant import probe_llvm
        ok, detail = probe_llvm()
        if not ok:
            pytest.skip(f"llvm_ad_rgb unusable ({detail}): apt-get install libllvm19, or "
                        f"point DRJIT_LIBLLVM_PATH at a libLLVM >= 16")
    cache = tmp_path / "cache"
    monkeypatch.setenv("MITSUBA_REFS_CACHE", str(cache))
    monkeypatch.setenv("MITSUBA_REFS_VARIANT", variant)
    comparison = compare(str(USER_SCENE), "path", spp=32, alpha=ALPHA, convergence=False,
                         bounces=False, processes=2, resolution=(32, 24),
                         options={"max_depth": 3})
    sidecars = list(cache.glob("*.json"))
    assert len(sidecars) == 1 and sidecars[0].name.startswith("scene-")
    metadata = json.loads(sidecars[0].read_text())
    assert metadata["variant"] == variant
    assert metadata["method"] == ("batch" if variant == "scalar_rgb" else "moments")
    assert metadata["rfilter"] == {"type": "gaussian", "stddev": 0.5}
    assert (metadata["width"], metadata["height"], metadata["spp"]) == (32, 24, 4096)
    assert comparison.mean.agree, comparison.report()
    assert comparison.variance is not None and comparison.variance.agree, comparison.report()
