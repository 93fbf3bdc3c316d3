"""Mesh attributes: read from PLY files as Mitsuba 3.9.1 groups them, interpolated with the
hit's barycentrics by the ``mesh_attribute`` texture, and the errors of a file that asks for
one a shape does not have.

Without Mitsuba: the attribute names and values of a hand-written PLY file; the texture at
ray hits against the barycentric interpolation of the file's numbers, computed here from
the hit points. Against Mitsuba (``mitsuba`` marker): the same file's attribute buffers.
The rendered images are compared with Mitsuba in tests/test_agreement.py (``lights-cameras``).
"""
from pathlib import Path

import numpy as np
import pytest

from pathtracer import load_scene, render
from pathtracer.io.meshes import read_ply
from pathtracer.scene.errors import SceneError
from pathtracer.scene.load import scene_file
from pathtracer.shapes.intersect import intersect, texture_uv
from pathtracer.textures import MeshAttribute

PLY = """ply
format ascii 1.0
element vertex 3
property float x
property float y
property float z
property uchar red
property uchar green
property uchar blue
property float n_x
property float n_y
property float n_z
property float weight_x
property float foo
property float t_x
property float t_y
property float c_r
property float c_g
property float c_b
element face 1
property list uchar int vertex_indices
property float id_0
end_header
0 0 0 255 128 0 1 2 3 0.5 9 1 1 0.1 0.2 0.3
1 0 0 10 20 30 4 5 6 0.25 9 1 1 0.4 0.5 0.6
0 1 0 0 0 0 7 8 9 0.125 9 1 1 0.7 0.8 0.9
3 0 1 2 42
"""

GRID = Path(scene_file("lights-cameras")).parent / "vertex-colors.ply"
SCENE = """<scene version="3.0.0">
  <sensor type="perspective"><float name="fov" value="40"/>
    <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/>
      <rfilter type="box"/></film></sensor>
  <shape type="ply"><string name="filename" value="{ply}"/>{flip}
    <bsdf type="{bsdf}">{texture}</bsdf></shape>
  <emitter type="constant"/>
</scene>"""


def attribute_texture(name, param="reflectance", scale=None):
    extra = "" if scale is None else f'<float name="scale" value="{scale}"/>'
    return (f'<texture type="mesh_attribute" name="{param}"><string name="name" '
            f'value="{name}"/>{extra}</texture>')


def load(tmp_path, texture, ply=GRID, bsdf="diffuse", flip=""):
    path = tmp_path / "scene.xml"
    path.write_text(SCENE.format(ply=ply, texture=texture, bsdf=bsdf, flip=flip))
    return load_scene(str(path))


def test_ply_attributes_are_grouped_as_mitsuba_groups_them(tmp_path):
    path = tmp_path / "attributes.ply"
    path.write_text(PLY)
    attributes = read_ply(str(path)).attributes
    assert sorted(attributes) == ["face_id", "vertex_c_color", "vertex_color", "vertex_n",
                                  "vertex_weight"]
    # Integer colours are kept as stored (Mitsuba 3.9.1 only warns that they exceed [0, 1]).
    np.testing.assert_array_equal(attributes["vertex_color"], [[255, 128, 0], [10, 20, 30], [0, 0, 0]])
    np.testing.assert_allclose(attributes["vertex_n"], [[1, 2, 3], [4, 5, 6], [7, 8, 9]])
    np.testing.assert_allclose(attributes["vertex_weight"], [[0.5], [0.25], [0.125]])
    np.testing.assert_allclose(attributes["vertex_c_color"], [[0.1, 0.2, 0.3], [0.4, 0.5, 0.6],
                                                              [0.7, 0.8, 0.9]], rtol=1e-6)
    np.testing.assert_array_equal(attributes["face_id"], [[42]])


def hits_on_grid(scene, count=400, seed=2):
    """Rays straight down onto the grid mesh (z = 0, [-1, 1]^2): the hits and their points."""
    rng = np.random.default_rng(seed)
    xy = rng.uniform(-0.98, 0.98, (count, 2))
    o = np.column_stack((xy, np.full(count, 2.0)))
    d = np.tile([0.0, 0.0, -1.0], (count, 1))
    hit = intersect(scene, o, d)
    assert hit.valid.all()
    return hit, xy


def interpolate_by_hand(xy, table):
    """The file's vertex values at points of the 4 x 4 grid, by barycentric interpolation in
    the grid's cells (triangles (a, b, d), (a, d, c) of cell a = j 4 + i, as written)."""
    step = 2.0 / 3.0
    i = np.minimum(((xy[:, 0] + 1) / step).astype(int), 2)
    j = np.minimum(((xy[:, 1] + 1) / step).astype(int), 2)
    fx, fy = (xy[:, 0] + 1) / step - i, (xy[:, 1] + 1) / step - j
    a, b = j * 4 + i, j * 4 + i + 1
    c, d = a + 4, a + 5
    lower = fx >= fy          # triangle (a, b, d): weights (1 - fx, fx - fy, fy)
    out = np.where(lower[:, None],
                   (1 - fx)[:, None] * table[a] + (fx - fy)[:, None] * table[b] + fy[:, None] * table[d],
                   (1 - fy)[:, None] * table[a] + (fy - fx)[:, None] * table[c] + fx[:, None] * table[d])
    face = np.where(lower, 2 * (j * 3 + i), 2 * (j * 3 + i) + 1)
    return out, face


@pytest.mark.parametrize("flip", ["", '<boolean name="flip_normals" value="true"/>'])
def test_vertex_colour_is_interpolated_with_the_barycentrics(tmp_path, flip):
    scene = load(tmp_path, attribute_texture("vertex_color", scale=2), flip=flip)
    texture = scene.bsdfs[0].reflectance
    assert isinstance(texture, MeshAttribute)
    hit, xy = hits_on_grid(scene)
    values = texture.eval(texture_uv(scene, hit, np.arange(len(xy))))
    expected, _ = interpolate_by_hand(xy, read_ply(str(GRID)).attributes["vertex_color"])
    np.testing.assert_allclose(values, 2 * expected, rtol=2e-5, atol=1e-6)


def test_face_attribute_is_the_triangles_value_and_rows_keep_their_hits(tmp_path):
    scene = load(tmp_path, attribute_texture("face_value", "alpha"), bsdf="roughconductor")
    texture = scene.bsdfs[0].alpha_u
    hit, xy = hits_on_grid(scene)
    uv = texture_uv(scene, hit, np.arange(len(xy)))
    _, face = interpolate_by_hand(xy, np.zeros((16, 1)))
    expected = read_ply(str(GRID)).attributes["face_value"][face, 0]
    np.testing.assert_allclose(texture.eval_1(uv), expected, atol=1e-7)
    rows = np.flatnonzero(xy[:, 0] > 0)   # a row selection keeps each row's own hit
    np.testing.assert_allclose(texture.eval_1(uv[rows]), expected[rows], atol=1e-7)
    np.testing.assert_allclose(texture.eval(uv[rows]), np.repeat(expected[rows, None], 3, axis=1),
                               atol=1e-7)


def test_a_vertex_coloured_mesh_renders(tmp_path):
    scene = load(tmp_path, attribute_texture("vertex_color"))
    result = render(scene, "path", spp=2, seed=1, processes=1)
    assert np.isfinite(result.mean).all() and result.mean.max() > 0


@pytest.mark.parametrize("texture,bsdf,message", [
    (attribute_texture("color"), "diffuse", "must start with \"vertex_\" or \"face_\""),
    (attribute_texture("vertex_missing"), "diffuse", "has no attribute \"vertex_missing\""),
    (attribute_texture("vertex_color", "alpha"), "roughconductor", "3 channels where one value"),
    (attribute_texture("vertex_color", "diffuse_reflectance"), "plastic", "has no mean"),
])
def test_errors_name_the_texture(tmp_path, texture, bsdf, message):
    with pytest.raises(SceneError, match=message) as error:
        load(tmp_path, texture, bsdf=bsdf)
    assert "scene.xml:" in str(error.value)


def test_an_attribute_on_a_shape_without_one_is_refused(tmp_path):
    path = tmp_path / "scene.xml"
    path.write_text(SCENE.format(ply=GRID, texture="", bsdf="diffuse", flip="").replace(
        "<emitter type=\"constant\"/>", '<shape type="sphere"><bsdf type="diffuse">'
        + attribute_texture("vertex_color") + '</bsdf></shape><emitter type="constant"/>'))
    with pytest.raises(SceneError, match=r"the shape sphere .* has no attribute \"vertex_color\""):
        load_scene(str(path))


def test_attributes_match_mitsuba(tmp_path, mi):
    path = tmp_path / "attributes.ply"
    path.write_text(PLY)
    ours = read_ply(str(path)).attributes
    params = mi.traverse(mi.load_dict({"type": "ply", "filename": str(path)}))
    for name in ("vertex_color", "vertex_n", "vertex_weight", "vertex_c_color", "face_id"):
        np.testing.assert_allclose(np.array(params[name]), ours[name].ravel(), rtol=1e-6)
    grid = read_ply(str(GRID)).attributes
    params = mi.traverse(mi.load_dict({"type": "ply", "filename": str(GRID)}))
    for name, values in grid.items():
        np.testing.assert_allclose(np.array(params[name]), values.ravel(), rtol=1e-6)
