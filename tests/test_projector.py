"""The ``projector`` emitter: next-event values in closed form, the image's orientation,
and the integrators that cannot start light paths on it.

A projector at height h looking straight down on the plane y = 0 gives every point of the
lit square (|x|, |z| <= h tan(fov / 2)) the irradiance ``pi k E / h^2`` (``k`` its scale,
``E`` a constant texture) and nothing outside it; with an image, the point of image position
``s`` receives that texel. Images against Mitsuba: tests/test_agreement.py
(``lights-cameras``).
"""
import numpy as np
import pytest

from pathtracer import load_scene, render
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


@pytest.mark.parametrize("integrator", ["light", "bdpt"])
def test_light_paths_refuse_the_projector(tmp_path, integrator):
    scene = load(tmp_path)
    with pytest.raises(ValueError, match="does not support projector emitters"):
        render(scene, integrator, spp=1, seed=0, processes=1)


def test_projector_errors(tmp_path):
    with pytest.raises(SceneError, match="either fov or focal_length"):
        load(tmp_path, fov='<float name="fov" value="40"/><string name="focal_length" value="30mm"/>')
    with pytest.raises(SceneError, match="unsupported property"):
        load(tmp_path, fov='<float name="fov" value="40"/><float name="intensity" value="3"/>')
