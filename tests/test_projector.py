"""The ``projector`` emitter: next-event values in closed form, the image's orientation,
and the light paths that leave it.

A projector at height h looking straight down on the plane y = 0 gives every point of the
lit square (|x|, |z| <= h tan(fov / 2)) the irradiance ``pi k E / h^2`` (``k`` its scale,
``E`` a constant texture) and nothing outside it; with an image, the point of image position
``s`` receives that texel. Light paths (light tracing, BDPT) leave it with the intensity
next-event estimation sees. Images against Mitsuba: tests/test_agreement.py
(``lights-cameras``) and tests/test_textured_area.py (``light``, live ``ptracer``).
"""
import numpy as np
import pytest

from pathtracer import load_scene
from pathtracer.emitters.projector import ProjectorEmitter
from pathtracer.emitters.scene_emitters import sample_emitter
from pathtracer.scene.errors import SceneError
from pathtracer.shapes.intersect import Hit
from pathtracer.textures import BitmapTexture

SCENE = """<scene version="3.0.0">
  <sensor type="perspective"><float name="fov" value="40"/>
    <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/>
      <rfilter type="box"/></film></sensor>
  <shape type="rectangle"><transform name="to_world"><rotate x="1" angle="-90"/></transform></shape>
  <emitter type="projector">{irradiance}<float name="scale" value="1.5"/>{fov}
    <transform name="to_world"><lookat origin="0, 2, 0" target="0, 0, 0" up="0, 0, 1"/></transform>
  </emitter>
</scene>"""


def load(tmp_path, irradiance='<rgb name="irradiance" value="1, 2, 3"/>',
         fov='<float name="fov" value="60"/>'):
    path = tmp_path / "scene.xml"
    path.write_text(SCENE.format(irradiance=irradiance, fov=fov))
    return load_scene(str(path))


def floor_hits(points):
    count = len(points)
    n = np.tile([0.0, 1.0, 0.0], (count, 1))
    return Hit(np.ones(count, bool), np.zeros(count), points, n, n, np.zeros(count, np.int32),
               np.zeros(count, np.int64), np.zeros((count, 2)))


def irradiance_on_floor(scene, points):
    u = np.random.default_rng(0).random((len(points), 3))
    sample = sample_emitter(scene, floor_hits(points), u[:, 2], u[:, :2], test_visibility=False)
    assert np.all(sample.delta) and np.all(sample.pdf == 1.0)
    return sample.weight * sample.wo[:, 1:2]   # times the floor's cosine


def test_a_constant_image_lights_a_plane_facing_it_uniformly(tmp_path):
    scene = load(tmp_path)
    edge = 2.0 * np.tan(np.radians(30))
    rng = np.random.default_rng(1)
    inside = np.column_stack((rng.uniform(-edge, edge, 200) * 0.999, np.zeros(200),
                              rng.uniform(-edge, edge, 200) * 0.999))
    expected = np.pi * 1.5 * np.array([1.0, 2.0, 3.0]) / 4.0
    np.testing.assert_allclose(irradiance_on_floor(scene, inside), np.tile(expected, (200, 1)),
                               rtol=1e-12)
    outside = np.array([[1.001 * edge, 0, 0], [0, 0, -1.001 * edge], [0, 3.0, 0]])
    np.testing.assert_array_equal(irradiance_on_floor(scene, outside), 0.0)


def test_each_point_receives_the_texel_it_is_projected_from():
    texels = np.random.default_rng(4).random((3, 5, 3))
    light = ProjectorEmitter(to_world=np.eye(4), irradiance=BitmapTexture(texels, "nearest"),
                             scale=1.0, x_fov=50.0, aspect=5 / 3)
    # Image position s of texel (column c, row r) centre -> camera-space point at z = 2.
    column, row = np.meshgrid(np.arange(5), np.arange(3))
    s_x, s_y = (column.ravel() + 0.5) / 5, (row.ravel() + 0.5) / 3
    tan_x = np.tan(np.radians(25))
    z = 2.0
    points = np.column_stack(((1 - 2 * s_x) * tan_x * z, (1 - 2 * s_y) * tan_x * 3 / 5 * z,
                              np.full(15, z)))
    sample = light.sample_direction(None, points, np.zeros((15, 2)))
    cos = -sample.wo[:, 2]
    np.testing.assert_allclose(sample.weight * (z ** 2 * cos / np.pi)[:, None],
                               texels.astype(np.float32)[row.ravel(), column.ravel()], rtol=1e-12)


def test_the_image_aspect_sets_the_vertical_field_of_view(tmp_path):
    from PIL import Image
    Image.fromarray(np.full((2, 4, 3), 200, np.uint8)).save(tmp_path / "wide.png")
    scene = load(tmp_path, '<texture type="bitmap" name="irradiance"><string name="filename" '
                           'value="wide.png"/></texture>')
    light = scene.emitters[0]
    assert light.aspect == 2.0 and light.tan_y == pytest.approx(np.tan(np.radians(30)) / 2)


def test_light_paths_leave_with_the_intensity_next_event_estimation_sees():
    """A light path's intensity along d over the squared distance is next-event estimation's
    weight at the point along d, its weight is that intensity over its density, and the
    density integrates to 1 over the sphere: with an image and a to_world that scales and
    shears (where |v| is not 1 / cos)."""
    texels = np.random.default_rng(6).random((3, 5, 3)) + 0.1
    to_world = np.array([[1.2, 0.3, 0.0, 0.5], [0.0, 0.9, 0.2, -0.4], [0.1, 0.0, 1.4, 2.0],
                         [0.0, 0.0, 0.0, 1.0]])
    light = ProjectorEmitter(to_world=to_world, irradiance=BitmapTexture(texels, "nearest"),
                             scale=1.7, x_fov=50.0, aspect=5 / 3)
    rng = np.random.default_rng(8)
    u = rng.random((500, 2))
    d, pdf_dir, weight = light.sample_ray_direction(np.zeros((500, 3)), u)
    assert np.all(pdf_dir > 0)
    np.testing.assert_allclose(pdf_dir, light.pdf_ray_direction(None, d), rtol=1e-9)
    intensity = light.eval_towards(None, d)
    np.testing.assert_allclose(weight, intensity / pdf_dir[:, None], rtol=1e-9)
    dist = rng.uniform(0.5, 3.0, 500)
    nee = light.sample_direction(None, light.position + d * dist[:, None], np.zeros((500, 2)))
    np.testing.assert_allclose(nee.weight, intensity / dist[:, None] ** 2, rtol=1e-9)
    # The density's integral, from 400k directions uniform in a 60-degree cone about the axis
    # that holds every sampled direction (fixed seed): the frustum is 8 % of the cone, so the
    # estimate's relative standard error is 0.6 % (it gives 0.990).
    from pathtracer.core.sampling import square_to_uniform_cone
    from pathtracer.core.vec import to_world as frame_to_world
    axis = to_world[:3, 2] / np.linalg.norm(to_world[:3, 2])
    cos_max = 0.5
    assert np.all(d @ axis > cos_max)
    local = square_to_uniform_cone(np.random.default_rng(9).random((400_000, 2)), cos_max)
    directions = frame_to_world(local, np.broadcast_to(axis, local.shape))
    inside = light.pdf_ray_direction(None, directions)
    total = 2 * np.pi * (1 - cos_max) * inside.mean()
    assert total == pytest.approx(1.0, abs=0.03)


def test_projector_errors(tmp_path):
    with pytest.raises(SceneError, match="either fov or focal_length"):
        load(tmp_path, fov='<float name="fov" value="40"/><string name="focal_length" value="30mm"/>')
    with pytest.raises(SceneError, match="unsupported property"):
        load(tmp_path, fov='<float name="fov" value="40"/><float name="intensity" value="3"/>')
