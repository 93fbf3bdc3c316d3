"""The render driver: determinism across batching and processes, exact statistics."""
import numpy as np
import pytest

from pathtracer import load_scene, render
from pathtracer.render.moments import block_statistics
from pathtracer.render.scheduling import plan_units


@pytest.fixture(scope="module")
def cbox():
    return load_scene("cornell-box", width=32, height=32)


def test_same_seed_same_image_whatever_the_batching(cbox):
    a = render(cbox, "path", spp=8, seed=5, processes=1, batch_size=1 << 14)
    b = render(cbox, "path", spp=8, seed=5, processes=1, batch_size=96)
    c = render(cbox, "path", spp=8, seed=5, processes=2, batch_size=512)
    for other in (b, c):
        assert np.array_equal(a.mean, other.mean)
        assert np.array_equal(a.variance, other.variance)


def test_different_seeds_differ(cbox):
    a = render(cbox, "path", spp=4, seed=1, processes=1)
    b = render(cbox, "path", spp=4, seed=2, processes=1)
    assert not np.array_equal(a.mean, b.mean)


def test_spp_beyond_one_sample_block_is_merged_exactly():
    """Pixels whose samples span several blocks: Chan's merge equals a direct computation."""
    from pathtracer.render.moments import mean_and_variance, pixel_statistics
    from pathtracer.render.moments import merge_block as _merge
    rng = np.random.default_rng(0)
    x = rng.exponential(size=(5, 700, 3))
    stats = pixel_statistics(5)
    for s0 in range(0, 700, 256):
        _merge(stats, (0, 5, s0, min(700, s0 + 256)), block_statistics(x[:, s0:s0 + 256]))
    assert np.all(stats[0] == 700)
    mean, variance = mean_and_variance(stats)
    np.testing.assert_allclose(mean, x.mean(axis=1), rtol=1e-13)
    np.testing.assert_allclose(variance, x.var(axis=1, ddof=1), rtol=1e-12)


def test_identical_samples_have_exactly_zero_variance():
    x = np.full((4, 37, 3), 0.1)
    n, mean, m2 = block_statistics(x)
    assert n == 37 and np.all(mean == 0.1) and np.all(m2 == 0.0)


def test_units_cover_every_sample_once():
    units = plan_units(n_pixels=1000, spp=600, batch_size=4096)
    covered = np.zeros((1000, 600), dtype=int)
    for p0, p1, s0, s1 in units:
        covered[p0:p1, s0:s1] += 1
    assert np.all(covered == 1)


def test_renders_in_threads_sharing_a_scene_match_sequential_ones(cbox):
    """Dask workers run renders in threads over one loaded scene: no shared scratch state
    (the small-mesh intersector's buffers once were, and images came out wrong)."""
    from concurrent.futures import ThreadPoolExecutor
    seeds = [11, 12, 13, 14]
    alone = [render(cbox, "path", spp=2, seed=s, processes=1, batch_size=512).mean for s in seeds]
    with ThreadPoolExecutor(4) as pool:
        threaded = list(pool.map(lambda s: render(cbox, "path", spp=2, seed=s, processes=1,
                                                  batch_size=512).mean, seeds))
    for a, b in zip(alone, threaded):
        assert np.array_equal(a, b)
