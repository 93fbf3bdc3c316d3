"""Refilled pools of paths: every camera ray gets exactly the sample it gets alone.

A pool (``Paths.pool``) keeps ``batch_size`` paths alive over several units of camera
rays, starting new camera paths whenever roulette has halved it. The renderer pools the
integrators whose class says ``refills = True``; these tests compare such a render, bit
for bit, with the same integrator run unit by unit (a subclass with its own ``radiance``),
and check the random streams and the bookkeeping pooling relies on.
"""
from types import SimpleNamespace

import numpy as np
import pytest

from pathtracer import load_scene, render
from pathtracer.core.rng import RandomStream, sample_keys
from pathtracer.integrators import INTEGRATORS
from pathtracer.integrators.wavefront import Paths
from pathtracer.render.scheduling import group_units, plan_units
from pathtracer.sensors.perspective import Rays

POOLED = ["path", "path_nee", "path_bsdf", "smallpt"]


def unpooled(name: str):
    """The integrator ``name`` with a ``radiance`` of its own: rendered one unit at a time."""
    cls = INTEGRATORS[name]

    class Unpooled(cls):
        def radiance(self, scene, rays, rng):
            return super().radiance(scene, rays, rng)

    return Unpooled


@pytest.fixture(scope="module")
def scenes():
    return {name: load_scene(name, width=24, height=16)
            for name in ("cornell-box", "smallpt", "sky-sphere", "quad-light-filtered",
                         "cornell-caustics-large-light")}


def _same_render(scene, name, batch_size=256, processes=1, **options):
    pooled = render(scene, INTEGRATORS[name](**options), spp=8, seed=11,
                    processes=processes, batch_size=batch_size)
    alone = render(scene, unpooled(name)(**options), spp=8, seed=11, processes=1,
                   batch_size=batch_size)
    np.testing.assert_array_equal(pooled.mean, alone.mean)
    np.testing.assert_array_equal(pooled.variance, alone.variance)
    return pooled


@pytest.mark.parametrize("name", POOLED)
@pytest.mark.parametrize("scene_name", ["cornell-box", "smallpt", "sky-sphere",
                                        "cornell-caustics-large-light"])
def test_pooled_render_is_bit_identical(scenes, name, scene_name):
    """(smallpt splits at the glass of the last scene while other paths carry radiance: a
    split that delivered every path's sum, not just the parents', would change the last
    bit of a pixel.)"""
    image = _same_render(scenes[scene_name], name)
    assert image.mean.max() > 0


@pytest.mark.parametrize("options", [
    dict(max_depth=1),             # every path ends at its first hit: empty pool iterations
    dict(max_depth=2), dict(max_depth=3),
    dict(hide_emitters=True),      # refilled camera rays skip the emitters too
    dict(roulette="constant"), dict(rr_depth=1), dict(roulette="off", max_depth=9),
])
@pytest.mark.parametrize("name", ["path", "smallpt"])
def test_pooled_render_is_bit_identical_with_every_option(scenes, name, options):
    _same_render(scenes["smallpt"], name, **options)


def test_pooled_render_with_a_filtered_film_and_two_processes(scenes):
    _same_render(scenes["quad-light-filtered"], "path", processes=2)
    _same_render(scenes["cornell-box"], "smallpt", batch_size=100, processes=2)


def test_the_pool_really_refills(scenes, monkeypatch):
    """The render above compares something: radiance sees several units, paths start late."""
    started, calls = [], []
    original = Paths._start
    monkeypatch.setattr(Paths, "_start", lambda self, camera: (
        started.append((len(self), len(camera))), original(self, camera))[1])
    integrator = INTEGRATORS["path"]()
    radiance = type(integrator).radiance
    monkeypatch.setattr(type(integrator), "radiance", _counting(radiance, calls))
    render(scenes["cornell-box"], integrator, spp=8, seed=1, processes=1, batch_size=256)
    assert max(calls) == 4 * 256          # POOL_UNITS units per call
    assert len(started) > 10
    for live, new in started:             # at most half full, topped up to the batch size
        assert live <= 128 and live + new <= 256
    assert sum(live + new == 256 for live, new in started) > len(started) // 2


def _counting(radiance, calls):
    def counted(self, scene, rays, rng):
        calls.append(len(rays))
        return radiance(self, scene, rays, rng)
    return counted


def test_only_integrators_that_say_so_are_pooled():
    assert all(INTEGRATORS[name]().refills for name in POOLED)
    # recursive branches per depth and bdpt / light splat: never pooled
    assert not any(INTEGRATORS[name]().refills for name in ("recursive", "direct", "light"))
    assert not unpooled("path")().refills          # a subclass (a student's) is not
    integrator = INTEGRATORS["path"]()
    render(load_scene("cornell-box", width=8, height=8), integrator, spp=2, processes=1)
    assert integrator.pool_size is None             # the renderer pooled its own copy


def test_groups_cover_every_unit_once_in_order():
    units = plan_units(n_pixels=1000, spp=600, batch_size=4096)
    for per_group, processes in ((4, 1), (4, 2), (4, 64), (1, 1), (7, 3)):
        groups = group_units(units, per_group, processes)
        assert [u for g in groups for u in g] == units
        assert max(map(len, groups)) <= per_group
        # a group is never larger than the processes' fair share: none is left idle
        assert max(map(len, groups)) <= -(-len(units) // processes)


# ---------------------------------------------------------------------------------------
# the random streams: a path draws its own numbers whenever it joins

def test_a_stream_that_joins_late_continues_its_own_sequence():
    keys = sample_keys(3, np.arange(10))
    alone = RandomStream(keys.copy())
    reference = [alone.next_1d() for _ in range(8)]
    early = RandomStream(keys[:6].copy())
    for _ in range(4):
        early.next_1d()
    late = RandomStream(keys[6:].copy())
    late.next_1d()                          # the late paths used one number (their film sample)
    pool = early.joined(late)
    assert pool.counter == 4 and list(pool.lag[6:]) == [3] * 4 and list(pool.lag[:6]) == [0] * 6
    for k in range(2):
        u = pool.next_1d()
        np.testing.assert_array_equal(u[:6], reference[4 + k][:6])
        np.testing.assert_array_equal(u[6:], reference[1 + k][6:])
    kept = pool.subset(np.array([7, 2]))
    np.testing.assert_array_equal(kept.next_1d(), [reference[3][7], reference[6][2]])


def test_branching_does_not_depend_on_the_lag():
    keys = sample_keys(5, np.arange(4))
    alone = RandomStream(keys.copy())
    alone.next_1d()
    expected = alone.branch(3).next_1d()
    ahead = RandomStream(sample_keys(5, np.arange(100, 102)))
    for _ in range(5):
        ahead.next_1d()
    late = RandomStream(keys.copy())
    late.next_1d()
    pool = ahead.joined(late)
    np.testing.assert_array_equal(pool.subset(np.arange(2, 6)).branch(3).next_1d(), expected)


def test_joining_a_stream_ahead_is_refused():
    behind, ahead = RandomStream(np.zeros(2, np.uint64)), RandomStream(np.ones(2, np.uint64), 3)
    with pytest.raises(ValueError, match="ahead"):
        behind.joined(ahead)


def test_a_pool_delivers_every_camera_ray_once():
    """Paths.pool on its own: declared fields start with each camera ray's own values."""
    n = 10
    rays = Rays(np.arange(3.0 * n).reshape(n, 3), np.tile([0.0, 0.0, 1.0], (n, 1)),
                np.full(n, np.inf))

    def trace_camera(camera):
        return SimpleNamespace(p=camera.o.copy(), valid=np.ones(len(camera), bool))

    paths = Paths.pool(rays, RandomStream(np.arange(n, dtype=np.uint64)), 4, trace_camera)
    paths.declare(origin=rays.o, first=True)
    seen = []
    while paths:
        np.testing.assert_array_equal(paths.origin, rays.o[paths.row])
        seen += list(paths.row[paths.first])
        paths.add_radiance(np.ones((len(paths), 3)))
        paths.keep(paths.depth < paths.row % 3)          # path i lives i mod 3 + 1 vertices
        paths.first = np.zeros(len(paths), bool)
        paths.wo = np.tile([0.0, 0.0, 1.0], (len(paths), 1))
        paths.depth += 1
        paths.hit.n = np.zeros((len(paths), 3))
        _advance(paths)
    assert sorted(seen) == list(range(n))
    np.testing.assert_array_equal(paths.L[:, 0], np.arange(n) % 3 + 1)


def _advance(paths):
    """next_hit without a scene: the hits stay, the pool refills."""
    import pathtracer.integrators.wavefront as wavefront
    keep_trace, keep_spawn = wavefront.trace, wavefront.spawn
    wavefront.trace = lambda scene, rays: SimpleNamespace(p=rays.o, valid=np.ones(len(rays), bool))
    wavefront.spawn = lambda hit, wo: Rays(hit.p, wo, np.full(len(wo), np.inf))
    try:
        paths.next_hit(None)
    finally:
        wavefront.trace, wavefront.spawn = keep_trace, keep_spawn
