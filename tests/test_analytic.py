"""Analytic scenes: every integrator against closed-form radiance.

Expected pixel values average the closed form over each pixel's footprint
(sub x sub stratified sub-pixel positions, intersected with the scene; 32 x 32
where a silhouette crosses pixels, so that the coverage error, at most 1/32 of
a pixel, stays far below the Monte Carlo noise of the render); the renders
are compared with them by the tile-aggregated z test of
``mitsuba_refs.stats`` (the expected image has no variance).
"""
import numpy as np
import pytest

from mitsuba_refs.report.wording import verdict_line
from mitsuba_refs.stats import MeanTestOptions, compare_means
from pathtracer import INTEGRATORS, load_scene, render
from pathtracer.sensors.perspective import camera_rays
from pathtracer.shapes.intersect import intersect
from tests.budget import ALPHA

pytestmark = pytest.mark.statistical(assertions=1)

#: The surface integrators (the volumetric ones have their closed forms in test_media.py).
ALL = sorted(name for name, cls in INTEGRATORS.items() if not cls.handles_media)
#: Integrators that only sample BSDFs: a point light is a Dirac delta they can never hit.
BSDF_ONLY = ("path_bsdf", "smallpt")
#: Light paths cannot start on an environment yet (light and bdpt refuse it: test_light.py).
WITH_ENVIRONMENT = [i for i in ALL if i not in ("light", "bdpt")]


def footprint_average(scene, radiance_at, sub=4):
    """Mean of ``radiance_at(hit, d)`` over sub x sub stratified positions in every pixel."""
    width, height = scene.camera.width, scene.camera.height
    pixels = np.arange(width * height)
    grid = (np.stack(np.meshgrid(np.arange(sub), np.arange(sub)), -1).reshape(-1, 2) + 0.5) / sub
    total = np.zeros((width * height, 3))
    for offset in grid:
        rays = camera_rays(scene.camera, pixels, np.tile(offset, (len(pixels), 1)))
        total += radiance_at(intersect(scene, rays.o, rays.d, rays.tmax), rays.d)
    return (total / len(grid)).reshape(height, width, 3)


def assert_matches(result, expected):
    agreement = compare_means(result.mean, result.variance, result.spp,
                              expected, np.zeros_like(expected), 1 << 30, alpha=ALPHA, options=MeanTestOptions(tile=8))
    assert agreement.agree, verdict_line(agreement)


def polygon_irradiance(x, vertices, normal, radiance):
    """Lambert's formula: E = Le/2 |sum_k theta_k (g_k . n)| for a uniformly emitting polygon."""
    u = [v - x for v in vertices]
    u = [w / np.linalg.norm(w, axis=1, keepdims=True) for w in u]
    total = np.zeros(len(x))
    for k in range(len(u)):
        a, b = u[k], u[(k + 1) % len(u)]
        theta = np.arccos(np.clip(np.sum(a * b, axis=1), -1, 1))
        g = np.cross(a, b)
        g /= np.linalg.norm(g, axis=1, keepdims=True)
        total += theta * (g @ normal)
    return radiance / 2 * np.abs(total)


def quad_light_case(width: int, height: int):
    """The quad-light scene and its closed form: a diffuse plane (albedo 0.5) under a square
    light (Le = 10, half size 0.5, height 1); Lambert's polygon formula gives its radiance."""
    rho, Le, h, s = 0.5, 10.0, 1.0, 0.5
    scene = load_scene("quad-light", width=width, height=height, albedo=rho, radiance=Le,
                       light_height=h, half_size=s)
    corners = [np.array(c, float) for c in ((-s, h, -s), (s, h, -s), (s, h, s), (-s, h, s))]
    plane = scene.shape_name.index(next(n for n in scene.shape_name if "plane" in n))

    def radiance_at(hit, d):
        on_plane = hit.valid & (hit.shape == plane)
        E = polygon_irradiance(hit.p, corners, np.array([0.0, 1.0, 0.0]), Le)
        return np.where(on_plane, rho / np.pi * E, 0.0)[:, None] * np.ones(3)

    return scene, footprint_average(scene, radiance_at, sub=32)


@pytest.mark.parametrize("integrator", ALL)
def test_quad_light_over_plane(integrator):
    scene, expected = quad_light_case(32, 24)
    result = render(scene, integrator, spp=64, seed=11, processes=1)
    assert_matches(result, expected)


@pytest.mark.parametrize("integrator", [i for i in ALL if i not in BSDF_ONLY])
def test_point_light_over_plane(integrator):
    rho, I, h = 0.5, 10.0, 1.0
    scene = load_scene("point-light", width=32, height=24, albedo=rho, intensity=I, light_height=h)

    def radiance_at(hit, d):
        r2 = hit.p[:, 0] ** 2 + hit.p[:, 2] ** 2 + h ** 2
        L = rho / np.pi * I * h / r2 ** 1.5
        return np.where(hit.valid, L, 0.0)[:, None] * np.ones(3)

    result = render(scene, integrator, spp=16, seed=12, processes=1)
    assert_matches(result, footprint_average(scene, radiance_at))


@pytest.mark.parametrize("integrator", BSDF_ONLY)
def test_point_light_is_invisible_to_bsdf_sampling(integrator):
    """Without shadow rays no path can ever reach a point light: the image is black."""
    scene = load_scene("point-light", width=16, height=12)
    result = render(scene, integrator, spp=4, seed=1, processes=1)
    assert np.all(result.mean == 0)


@pytest.mark.parametrize("integrator", WITH_ENVIRONMENT)
def test_diffuse_sphere_under_constant_sky(integrator):
    rho, sky = 0.5, 1.0
    scene = load_scene("sky-sphere", width=32, height=32, albedo=rho, radiance=sky)

    def radiance_at(hit, d):
        return np.where(hit.valid, rho * sky, sky)[:, None] * np.ones(3)

    result = render(scene, integrator, spp=32, seed=13, processes=1)
    assert_matches(result, footprint_average(scene, radiance_at, sub=32))


@pytest.mark.parametrize("integrator", ALL)
def test_furnace_is_le_over_one_minus_rho(integrator):
    rho, Le = 0.5, 1.0
    depth = 2 if integrator == "direct" else -1
    scene = load_scene("furnace", width=16, height=16, albedo=rho, radiance=Le)
    result = render(scene, integrator, spp=64, seed=14, processes=1, max_depth=depth)
    expected_value = Le * (1 + rho) if depth == 2 else Le / (1 - rho)
    assert_matches(result, np.full_like(result.mean, expected_value))


@pytest.mark.parametrize("max_depth", [1, 2, 5])
def test_furnace_bsdf_sampling_has_zero_variance(max_depth):
    """Cosine sampling, no roulette, finite depth: every sample is Le (1 - rho^D) / (1 - rho)."""
    rho, Le = 0.5, 1.0
    scene = load_scene("furnace", width=8, height=8, albedo=rho, radiance=Le)
    result = render(scene, "path_bsdf", spp=16, seed=3, processes=1,
                    max_depth=max_depth, roulette="off")
    expected = Le * (1 - rho ** max_depth) / (1 - rho)
    np.testing.assert_allclose(result.mean, expected, rtol=1e-12)
    assert np.all(result.variance == 0.0)


def test_furnace_uniform_hemisphere_same_mean_more_variance():
    scene = load_scene("furnace", width=8, height=8)
    cosine = render(scene, "path_bsdf", spp=64, seed=4, processes=1, max_depth=3, roulette="off")
    uniform = render(scene, "path_bsdf", spp=64, seed=4, processes=1, max_depth=3,
                     roulette="off", hemisphere="uniform")
    assert_matches(uniform, cosine.mean)
    assert uniform.variance.mean() > 0.01 and np.all(cosine.variance == 0)
