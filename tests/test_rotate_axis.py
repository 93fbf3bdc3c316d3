"""``<rotate>`` about a non-unit axis, reproduced as Mitsuba 3.9.1 builds it.

Mitsuba does not normalise the axis (Rodrigues' formula with the axis as
given scales and shears too), and it keeps the transpose of that matrix as
its inverse, so normals are transformed by the rotation matrix itself rather
than by its true inverse transpose.
"""
from __future__ import annotations

import numpy as np
import pytest

from pathtracer.scene.load import load_scene

SENSOR = ('<sensor type="perspective"><film type="hdrfilm"><integer name="width" value="8"/>'
          '<integer name="height" value="8"/><rfilter type="box"/></film></sensor>')
ROTATE = '<rotate x="0" y="1" z="1" angle="30"/><translate x="0.5"/>'
PLY = ("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
       "property float z\nproperty float nx\nproperty float ny\nproperty float nz\n"
       "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
       "-1 -1 0 0 0 1\n1 -1 0 0 0.6 0.8\n0 1 0 0.6 0 0.8\n3 0 1 2\n")


def by_hand(axis, degrees):
    """cos I + sin [a]x + (1 - cos) a a^T, with the axis as given."""
    a = np.asarray(axis, float)
    c, s = np.cos(np.radians(degrees)), np.sin(np.radians(degrees))
    cross = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return c * np.eye(3) + s * cross + (1 - c) * np.outer(a, a)


def write_scene(tmp_path, shapes: str) -> str:
    (tmp_path / "tri.ply").write_text(PLY)
    path = tmp_path / "scene.xml"
    path.write_text(f'<scene version="3.0.0">{SENSOR}{shapes}</scene>')
    return str(path)


def shape(kind: str, transform: str, extra: str = "") -> str:
    return f'<shape type="{kind}">{extra}<transform name="to_world">{transform}</transform></shape>'


PLY_FILE = '<string name="filename" value="tri.ply"/>'


def test_positions_use_the_unnormalised_matrix_and_normals_the_matrix_itself(tmp_path):
    scene = load_scene(write_scene(tmp_path, shape("ply", ROTATE, PLY_FILE)))
    m = by_hand([0, 1, 1], 30)
    local = np.array([[-1, -1, 0], [1, -1, 0], [0, 1, 0]], float)
    np.testing.assert_allclose(scene.tri_p[0], local @ m.T + [0.5, 0, 0], atol=1e-12)
    normals = np.array([[0, 0, 1], [0, 0.6, 0.8], [0.6, 0, 0.8]]) @ m.T
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    np.testing.assert_allclose(scene.tri_n[0], normals, atol=1e-12)


def test_mesh_without_normals_equals_the_matrix_form(tmp_path):
    """Recomputed normals follow the geometry, so <matrix> of the same product is equivalent
    (how a user can write such a transform explicitly)."""
    matrix = np.eye(4)
    matrix[:3, :3] = by_hand([0, 0, 1], -15) @ by_hand([0, 1, 1], 15)
    values = " ".join(repr(float(v)) for v in matrix.ravel())
    cube_rot = shape("cube", '<rotate x="0" y="1" z="1" angle="15"/><rotate z="1" angle="-15"/>',
                     '<boolean name="face_normals" value="true"/>')
    cube_mat = shape("cube", f'<matrix value="{values}"/>', '<boolean name="face_normals" value="true"/>')
    a = load_scene(write_scene(tmp_path, cube_rot))
    b = load_scene(write_scene(tmp_path, cube_mat))
    np.testing.assert_allclose(a.tri_p, b.tri_p, atol=1e-14)
    np.testing.assert_allclose(a.tri_n, b.tri_n, atol=1e-14)


def vertex_normal_map(corners, normals) -> set:
    """The (corner position, normal) pairs, rounded to what float32 storage preserves."""
    return {tuple(np.round(np.concatenate([p, n]), 5))
            for p, n in zip(corners.reshape(-1, 3), normals.reshape(-1, 3))}


@pytest.mark.mitsuba
def test_matches_mitsuba(tmp_path, mi):
    shapes = (shape("ply", ROTATE, PLY_FILE) + shape("cube", ROTATE) +
              shape("rectangle", '<scale value="0.5"/>' + ROTATE))
    path = write_scene(tmp_path, shapes)
    ours = load_scene(path)
    theirs = mi.load_file(path)
    for sh in theirs.shapes():
        positions = np.array(sh.vertex_positions_buffer(), dtype=float).reshape(-1, 3)
        faces = np.array(sh.faces_buffer(), dtype=np.int64).reshape(-1, 3)
        normals = np.array(sh.vertex_normals_buffer(), dtype=float).reshape(-1, 3)
        first, last = ours.shape_prim[{1: 0, 12: 1, 2: 2}[len(faces)]]
        # Compare corner by corner (the two may split a quad differently).
        assert vertex_normal_map(ours.tri_p[first:last], ours.tri_n[first:last]) == \
            vertex_normal_map(positions[faces], normals[faces])
    # And the rectangle's shading normal where a ray hits it.
    first, last = ours.shape_prim[2]
    centre = ours.tri_p[first:last].reshape(-1, 3).mean(axis=0)
    normal = ours.tri_n[first, 0]
    si = theirs.ray_intersect(mi.Ray3f(mi.Point3f(*(centre + 3 * normal)), mi.Vector3f(*-normal)))
    assert si.is_valid()
    np.testing.assert_allclose(np.array(si.sh_frame.n), normal, atol=2e-6)
