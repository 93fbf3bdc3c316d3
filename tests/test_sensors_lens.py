"""The ``orthographic`` and ``thinlens`` sensors: their rays by hand and against Mitsuba's
own ``sample_ray``, and the integrators that cannot use them.

Without Mitsuba: the orthographic camera's rays are parallel, start on the rectangle
``to_world ([-1, 1] x [-1/a, 1/a] x {near})`` and run for ``far - near``; a thin lens with
its lens sample at the centre is the pinhole camera, and every lens point of one film
position sends its ray through the same point of the focal plane.
"""
import numpy as np
import pytest

from pathtracer import load_scene, render
from pathtracer.core.rng import RandomStream, sample_keys
from pathtracer.scene.errors import SceneError
from pathtracer.sensors.perspective import camera_rays
from pathtracer.sensors.primary import sample_camera_rays

SCENE = """<scene version="3.0.0">
  <sensor type="{kind}">{extra}
    <transform name="to_world">{transform}</transform>
    <film type="hdrfilm"><integer name="width" value="{width}"/><integer name="height" value="{height}"/>
      <rfilter type="box"/></film>
  </sensor>
  <shape type="sphere"><emitter type="area"/></shape>
</scene>"""
LOOKAT = '<lookat origin="1, 2, 3" target="0.2, -0.1, 0.3" up="0.1, 1, 0"/>'


def load(tmp_path, kind, extra="", transform=LOOKAT, width=8, height=4):
    path = tmp_path / "sensor.xml"
    path.write_text(SCENE.format(kind=kind, extra=extra, transform=transform, width=width,
                                 height=height))
    return path, load_scene(str(path))


def film_samples(count, width, height, seed=3):
    rng = np.random.default_rng(seed)
    return rng.integers(0, width * height, count), rng.random((count, 2)), rng.random((count, 2))


def test_orthographic_rays_by_hand(tmp_path):
    transform = '<scale x="2" y="3"/><translate x="1" y="2" z="3"/>'
    _, scene = load(tmp_path, "orthographic", '<float name="near_clip" value="0.5"/>',
                    transform, width=4, height=2)
    camera = scene.camera
    # Pixel 0 (top left), centre of the pixel: s = (1/8, 1/4), camera point (3/4, 1/4, 0.5).
    rays = camera.sample_rays(np.array([0, 7]), np.array([[0.5, 0.5], [0.0, 0.0]]))
    np.testing.assert_allclose(rays.o[0], [1 + 2 * 0.75, 2 + 3 * 0.25, 3.5])
    # Pixel 7 (bottom right), its corner: s = (3/4, 1/2), camera point (-1/2, 0, 0.5).
    np.testing.assert_allclose(rays.o[1], [1 - 2 * 0.5, 2.0, 3.5])
    np.testing.assert_allclose(rays.d, [[0, 0, 1], [0, 0, 1]])
    np.testing.assert_allclose(rays.tmax, 1e4 - 0.5)


def test_thin_lens_with_a_centred_lens_sample_is_the_pinhole(tmp_path):
    _, scene = load(tmp_path, "thinlens", '<float name="fov" value="50"/><float name='
                    '"aperture_radius" value="0.3"/><float name="focus_distance" value="4"/>')
    pixel, u, _ = film_samples(500, 8, 4)
    lens = scene.camera.lens_rays(pixel, u, np.full((500, 2), 0.5))
    pinhole = camera_rays(scene.camera, pixel, u)
    np.testing.assert_allclose(lens.d, pinhole.d, atol=1e-12)
    np.testing.assert_allclose(lens.o, pinhole.o, atol=1e-12)
    np.testing.assert_allclose(lens.tmax, pinhole.tmax, rtol=1e-12)


def test_thin_lens_rays_meet_on_the_focal_plane(tmp_path):
    _, scene = load(tmp_path, "thinlens", '<float name="fov" value="50"/><float name='
                    '"aperture_radius" value="0.3"/><float name="focus_distance" value="4"/>')
    camera = scene.camera
    pixel, u, u_lens = film_samples(500, 8, 4)
    rays = camera.lens_rays(pixel, u, u_lens)
    to_local = np.linalg.inv(camera.to_world)
    o = rays.o @ to_local[:3, :3].T + to_local[:3, 3]
    d = rays.d @ to_local[:3, :3].T
    t = (4.0 - o[:, 2]) / d[:, 2]
    focus = o + t[:, None] * d
    # The focal point of a film position: the pinhole ray scaled to z = 4, by hand.
    s_x, s_y = (pixel % 8 + u[:, 0]) / 8, (pixel // 8 + u[:, 1]) / 4
    tan_half = np.tan(np.radians(50) / 2)
    expected = 4.0 * np.stack(((1 - 2 * s_x) * tan_half, (1 - 2 * s_y) * tan_half / 2,
                               np.ones(500)), axis=1)
    np.testing.assert_allclose(focus, expected, atol=1e-9)
    # The rays start on the near plane, from points of the lens disk (radius 0.3).
    start = o - (0.01 / d[:, 2])[:, None] * d
    np.testing.assert_allclose(start[:, 2], 0.0, atol=1e-12)
    assert np.all(np.hypot(start[:, 0], start[:, 1]) <= 0.3 + 1e-12)
    assert np.hypot(start[:, 0], start[:, 1]).max() > 0.25


def test_thin_lens_draws_its_lens_point_from_the_samples_streams(tmp_path):
    _, scene = load(tmp_path, "thinlens", '<float name="fov" value="50"/><float name='
                    '"aperture_radius" value="0.3"/>')
    pixel = np.arange(32)
    rng = RandomStream(sample_keys(7, pixel))
    u_film = rng.next_2d()
    rays = sample_camera_rays(scene.camera, pixel, u_film, rng)
    again = RandomStream(sample_keys(7, pixel))
    again.next_2d()
    expected = scene.camera.lens_rays(pixel, u_film, again.next_2d())
    np.testing.assert_array_equal(rays.d, expected.d)
    assert rng.counter == 4


def test_sensor_errors(tmp_path):
    with pytest.raises(SceneError, match="aperture_radius"):
        load(tmp_path, "thinlens", '<float name="fov" value="50"/>')
    with pytest.raises(SceneError, match="scale factors"):
        load(tmp_path, "thinlens", '<float name="aperture_radius" value="0.1"/>',
             '<scale value="2"/>')
    with pytest.raises(SceneError, match="fov"):
        load(tmp_path, "orthographic", '<float name="fov" value="50"/>')


@pytest.mark.parametrize("integrator", ["light", "bdpt"])
@pytest.mark.parametrize("kind,extra", [("orthographic", ""),
                                        ("thinlens", '<float name="aperture_radius" value="0.1"/>')])
def test_splatting_integrators_refuse_the_sensor(tmp_path, kind, extra, integrator):
    _, scene = load(tmp_path, kind, extra)
    with pytest.raises(ValueError, match=f"the {integrator} integrator does not support the {kind} sensor"):
        render(scene, integrator, spp=1, seed=0, processes=1)


def test_bdpt_strategy_images_refuse_the_thin_lens(tmp_path):
    from pathtracer.integrators.bdpt import BDPTIntegrator
    from pathtracer.render.strategies import render_strategies
    _, scene = load(tmp_path, "thinlens", '<float name="aperture_radius" value="0.1"/>')
    with pytest.raises(ValueError, match="the bdpt integrator does not support the thinlens sensor"):
        render_strategies(scene, BDPTIntegrator(max_depth=3), spp=1, seed=0)


@pytest.mark.parametrize("kind,extra", [
    ("orthographic", '<float name="near_clip" value="0.3"/>'),
    ("thinlens", '<float name="fov" value="40"/><float name="aperture_radius" value="0.2"/>'
                 '<float name="focus_distance" value="2.5"/><float name="near_clip" value="0.1"/>')])
def test_rays_match_mitsuba(tmp_path, kind, extra, mi):
    transform = ('<scale x="1.5" y="0.7"/>' if kind == "orthographic" else "") + LOOKAT
    path, scene = load(tmp_path, kind, extra, transform, width=16, height=10)
    sensor = mi.load_file(str(path)).sensors()[0]
    pixel, u, u_lens = film_samples(1000, 16, 10)
    if kind == "orthographic":
        ours = scene.camera.sample_rays(pixel, u)
    else:
        ours = scene.camera.lens_rays(pixel, u, u_lens)
    film = np.stack(((pixel % 16 + u[:, 0]) / 16, (pixel // 16 + u[:, 1]) / 10), axis=1)
    for k in range(len(pixel)):
        ray, _ = sensor.sample_ray(0.0, 0.5, mi.Point2f(*film[k]), mi.Point2f(*u_lens[k]))
        np.testing.assert_allclose(ours.d[k], np.array(ray.d), atol=2e-6)
        np.testing.assert_allclose(ours.o[k], np.array(ray.o), atol=2e-5)
        assert ours.tmax[k] == pytest.approx(float(ray.maxt), rel=1e-5)
