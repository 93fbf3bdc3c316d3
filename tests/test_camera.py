"""Camera rays against Mitsuba's own perspective sensor (sensor.sample_ray)."""
import numpy as np
import pytest

from pathtracer.scene.load import load_scene
from pathtracer.sensors.perspective import camera_rays

SENSOR_XML = """<scene version="3.0.0">
  <sensor type="perspective">
    <float name="fov" value="{fov}"/>
    <string name="fov_axis" value="{axis}"/>
    <float name="near_clip" value="{near}"/>
    <float name="principal_point_offset_x" value="{offset[0]}"/>
    <float name="principal_point_offset_y" value="{offset[1]}"/>
    <transform name="to_world">
      <lookat origin="1, 2, 3" target="0.2, -0.1, 0.3" up="0.1, 1, 0"/>
    </transform>
    <film type="hdrfilm">
      <integer name="width" value="{width}"/>
      <integer name="height" value="{height}"/>
      <rfilter type="box"/>
    </film>
  </sensor>
</scene>"""

CASES = [("x", 45, 64, 48, 0.01), ("y", 30, 48, 64, 1.5), ("smaller", 60, 80, 32, 0.1),
         ("larger", 60, 32, 80, 0.01), ("diagonal", 70, 64, 64, 0.01)]
#: Principal point offsets (fractions of the film): none, and an off-axis frustum each way.
OFFSETS = [(0.0, 0.0), (0.13, -0.07), (-0.25, 0.5 / 48)]


def sensor_file(tmp_path, axis, fov, width, height, near, offset=(0.0, 0.0)):
    path = tmp_path / "camera.xml"
    path.write_text(SENSOR_XML.format(fov=fov, axis=axis, near=near, width=width, height=height,
                                      offset=offset))
    return path


@pytest.mark.parametrize("offset", OFFSETS)
@pytest.mark.parametrize("axis,fov,width,height,near", CASES)
def test_camera_rays_match_mitsuba(tmp_path, axis, fov, width, height, near, offset, mi):
    path = sensor_file(tmp_path, axis, fov, width, height, near, offset)
    camera = load_scene(str(path)).camera
    sensor = mi.load_file(str(path)).sensors()[0]

    rng = np.random.default_rng(3)
    count = 2000
    pixel = rng.integers(0, width * height, count)
    u = rng.random((count, 2))
    ours = camera_rays(camera, pixel, u)
    film = np.stack(((pixel % width + u[:, 0]) / width, (pixel // width + u[:, 1]) / height), axis=1)
    for k in range(count):
        ray, _ = sensor.sample_ray(0.0, 0.5, mi.Point2f(*film[k]), mi.Point2f(0.5, 0.5))
        np.testing.assert_allclose(ours.d[k], np.array(ray.d), atol=2e-6)
        np.testing.assert_allclose(ours.o[k], np.array(ray.o), atol=2e-5)
        assert ours.tmax[k] == pytest.approx(float(ray.maxt), rel=1e-5)


def test_image_orientation():
    """Row 0 is the top of the image and the image's right is -left (Mitsuba's convention)."""
    camera = load_scene("cornell-box", width=64, height=64).camera
    centre = camera_rays(camera, np.array([32 * 64 + 32]), np.zeros((1, 2))).d[0]
    top = camera_rays(camera, np.array([0 * 64 + 32]), np.zeros((1, 2))).d[0]
    right = camera_rays(camera, np.array([32 * 64 + 63]), np.zeros((1, 2))).d[0]
    up = camera.to_world[:3, 1]
    left = camera.to_world[:3, 0]
    assert np.dot(top - centre, up) > 0
    assert np.dot(right - centre, left) < 0


@pytest.mark.parametrize("axis,fov,width,height,near", CASES[:3])
def test_camera_connection_matches_mitsuba_sample_direction(tmp_path, axis, fov, width, height,
                                                            near, mi):
    """connect_to_camera (the light tracer's splat: pixel, direction, importance We / d^2)
    against the sensor's own ``sample_direction`` for points inside and outside the view.
    Without a principal point offset: Mitsuba 3.9.1's importance keeps the unmoved film
    rectangle (zero on part of the film its own rays cover); the offset's connections are
    tested against our own rays (test_principal_point_offset_moves_the_pixel_grid)."""
    from pathtracer.sensors.importance import connect_to_camera
    path = sensor_file(tmp_path, axis, fov, width, height, near)
    camera = load_scene(str(path)).camera
    sensor = mi.load_file(str(path)).sensors()[0]
    rng = np.random.default_rng(4)
    count = 300
    pixel = rng.integers(0, width * height, count)
    rays = camera_rays(camera, pixel, rng.random((count, 2)))
    points = rays.o + rays.d * rng.uniform(0.5, 4.0, count)[:, None]
    points[::10] += rng.normal(0.0, 3.0, (len(points[::10]), 3))     # some outside the view
    ours = connect_to_camera(camera, points)
    for k in range(count):
        it = mi.Interaction3f()
        it.p = mi.Point3f(*points[k])
        ds, weight = sensor.sample_direction(it, mi.Point2f(0.5, 0.5))
        if ds.pdf == 0:
            assert ours.pixel[k] == -1 and ours.importance[k] == 0
            continue
        uv = np.array(ds.uv)
        assert ours.pixel[k] == int(uv[1]) * width + int(uv[0])
        np.testing.assert_allclose(ours.film[k], uv, atol=1e-4)
        np.testing.assert_allclose(ours.wi[k], np.array(ds.d), atol=1e-5)
        assert ours.importance[k] == pytest.approx(float(np.array(weight)[0]), rel=1e-4)


def test_camera_connections_are_free_only_up_to_the_near_clip_plane():
    """Camera rays start on the near clip plane, so a connection to the pinhole must be
    unoccluded only that far: smallpt's camera sits behind the room's front wall (near clip
    140), and light paths joined to it would all be blocked by the wall."""
    from pathtracer.sensors.importance import connect_to_camera
    camera = load_scene("smallpt", width=16, height=12).camera
    rng = np.random.default_rng(4)
    pixel = rng.integers(0, 16 * 12, 500)
    rays = camera_rays(camera, pixel, rng.random((500, 2)))
    beyond = rng.uniform(1.0, 200.0, 500)
    connection = connect_to_camera(camera, rays.o + rays.d * beyond[:, None])
    np.testing.assert_allclose(connection.free_dist, beyond, rtol=1e-9)
    np.testing.assert_array_equal(connection.pixel, pixel)


def test_principal_point_offset_moves_the_pixel_grid(tmp_path):
    """An offset of half a pixel's width makes pixel column c see what c + 1/2 saw: the
    ray of (c, u) is the unshifted ray of (c, u + 1/2); connections invert it, and the
    importance is zero exactly outside the moved film."""
    from pathtracer.sensors.importance import connect_to_camera
    width, height = 16, 12
    plain = load_scene(str(sensor_file(tmp_path, "x", 50, width, height, 0.01))).camera
    moved = load_scene(str(sensor_file(tmp_path, "x", 50, width, height, 0.01,
                                       (0.5 / width, -0.5 / height)))).camera
    rng = np.random.default_rng(5)
    pixel = rng.integers(0, width * height, 400)
    u = rng.random((400, 2)) * 0.5
    ray = camera_rays(moved, pixel, u)
    np.testing.assert_allclose(ray.d, camera_rays(plain, pixel, u + [0.5, -0.5]).d, atol=1e-12)
    points = ray.o + ray.d * 2.0
    connection = connect_to_camera(moved, points)
    np.testing.assert_array_equal(connection.pixel, pixel)
    outside = camera_rays(plain, np.zeros(50, dtype=np.int64), rng.random((50, 2)) * [0.5, 1.0])
    assert np.all(connect_to_camera(moved, outside.o + outside.d * 2.0).importance == 0)


def test_thin_lens_refuses_a_principal_point_offset(tmp_path):
    path = sensor_file(tmp_path, "x", 50, 16, 12, 0.01, (0.1, 0.0))
    path.write_text(path.read_text().replace('type="perspective"', 'type="thinlens"'))
    with pytest.raises(Exception, match="principal_point_offset_x is not supported by the thinlens"):
        load_scene(str(path))
