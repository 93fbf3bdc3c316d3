"""Scene loader: transforms, substitution, shapes, meshes, sensor; and, when
Mitsuba is installed, the same numbers as Mitsuba 3 for small fixtures."""
from __future__ import annotations

import os
import textwrap

import numpy as np
import pytest

from pathtracer.io.meshes import read_obj, read_ply, smooth_vertex_normals
from pathtracer.scene import transform
from pathtracer.scene.errors import SceneError
from pathtracer.scene.load import load_scene
from pathtracer.sensors.perspective_sensor import x_fov_from

DATA = os.path.join(os.path.dirname(__file__), "data")

SENSOR = """
    <sensor type="perspective">
        <float name="fov" value="40"/>
        <transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm">
            <integer name="width" value="64"/><integer name="height" value="48"/>
            <rfilter type="box"/>
        </film>
    </sensor>"""


def write_scene(tmp_path, body: str, sensor: str = SENSOR, name: str = "scene.xml") -> str:
    path = tmp_path / name
    path.write_text(f'<scene version="3.0.0">\n{sensor}\n{textwrap.dedent(body)}\n</scene>\n')
    return str(path)


# -- transforms ---------------------------------------------------------------

def test_translate_scale_rotate_matrices():
    np.testing.assert_allclose(transform.translate([1, 2, 3])[:3, 3], [1, 2, 3])
    np.testing.assert_allclose(np.diag(transform.scale([2, 3, 4])), [2, 3, 4, 1])
    # 90 degrees about z takes x to y (right-handed).
    r = transform.rotate([0, 0, 1], 90)
    np.testing.assert_allclose(r[:3, :3] @ [1, 0, 0], [0, 1, 0], atol=1e-15)
    # 90 degrees about x takes y to z; about y takes z to x.
    np.testing.assert_allclose(transform.rotate([1, 0, 0], 90)[:3, :3] @ [0, 1, 0], [0, 0, 1], atol=1e-15)
    np.testing.assert_allclose(transform.rotate([0, 1, 0], 90)[:3, :3] @ [0, 0, 1], [1, 0, 0], atol=1e-15)
    # Mitsuba does not normalise the axis: Rodrigues' formula with a = (0, 0, 2)
    # gives cos I + sin [a]x + (1 - cos) a a^T = [[0, -2, 0], [2, 0, 0], [0, 0, 4]].
    np.testing.assert_allclose(transform.rotate([0, 0, 2], 90)[:3, :3],
                               [[0, -2, 0], [2, 0, 0], [0, 0, 4]], atol=1e-15)


def test_lookat_by_hand():
    m = transform.look_at([1, 2, 3], [1, 2, 0], [0, 1, 0])
    # dir = -z, left = cross(up, dir) = cross(y, -z) = -x, up' = cross(dir, left) = y
    expected = np.array([[-1, 0, 0, 1], [0, 1, 0, 2], [0, 0, -1, 3], [0, 0, 0, 1]], float)
    np.testing.assert_allclose(m, expected, atol=1e-15)


def test_lookat_without_up_is_orthonormal():
    m = transform.look_at([0, 0, 0], [1, 2, 3])
    np.testing.assert_allclose(m[:3, :3] @ m[:3, :3].T, np.eye(3), atol=1e-12)
    np.testing.assert_allclose(m[:3, 2], np.array([1, 2, 3]) / np.sqrt(14))


def test_composition_order_first_listed_is_innermost(tmp_path):
    # Scale by 2 then translate by x+1: the corner (1,1,0) goes to (3,2,0);
    # the other order would give (4,2,0).
    path = write_scene(tmp_path, """
        <shape type="rectangle">
            <transform name="to_world">
                <scale value="2"/>
                <translate x="1"/>
                <rotate z="1" angle="90"/>
            </transform>
        </shape>""")
    scene = load_scene(path)
    expected = transform.rotate([0, 0, 1], 90) @ transform.translate([1, 0, 0]) @ transform.scale([2, 2, 2])
    corners = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], float)
    want = transform.apply_points(expected, corners)
    got = np.unique(scene.tri_p.reshape(-1, 3).round(12), axis=0)
    np.testing.assert_allclose(got, np.unique(want.round(12), axis=0), atol=1e-12)
    np.testing.assert_allclose(scene.shape_area, [16.0])


def test_matrix_row_major_and_value_forms(tmp_path):
    path = write_scene(tmp_path, """
        <shape type="sphere" id="a">
            <transform name="to_world">
                <matrix value="2 0 0 1  0 2 0 2  0 0 2 3  0 0 0 1"/>
            </transform>
        </shape>
        <shape type="sphere" id="b">
            <transform name="to_world"><scale value="3"/><translate value="1, -1, 0.5"/></transform>
        </shape>
        <shape type="sphere" id="c">
            <point name="center" x="1" y="2" z="3"/><float name="radius" value="0.5"/>
        </shape>""")
    s = load_scene(path)
    np.testing.assert_allclose(s.sphere_center, [[1, 2, 3], [1, -1, 0.5], [1, 2, 3]])
    np.testing.assert_allclose(s.sphere_radius, [2, 3, 0.5])
    np.testing.assert_allclose(s.shape_area, 4 * np.pi * np.array([4, 9, 0.25]))
    np.testing.assert_allclose(s.bbox, [[-2, -4, -2.5], [4, 4, 5]])


def test_sphere_rotation_allowed_mirror_flips(tmp_path):
    path = write_scene(tmp_path, """
        <shape type="sphere"><transform name="to_world"><rotate x="1" angle="30"/><scale value="2"/></transform></shape>
        <shape type="sphere"><transform name="to_world"><scale x="-1" y="1" z="1"/></transform></shape>""")
    s = load_scene(path)
    np.testing.assert_allclose(s.sphere_radius, [2, 1])
    assert list(s.sphere_flip) == [False, True]


# -- substitution, refs ---------------------------------------------------------

def test_default_and_params(tmp_path):
    sensor = SENSOR.replace('<film type="hdrfilm">',
                            '<sampler type="independent"><integer name="sample_count" value="$spp"/>'
                            '</sampler><film type="hdrfilm">')
    # Mitsuba reads top to bottom: the <default>s come before their uses.
    path = write_scene(tmp_path, """
        <default name="spp" value="8"/>
        <default name="refl" value="0.25"/>
        """ + sensor + """
        <integrator type="path"><integer name="max_depth" value="$depth"/></integrator>
        <bsdf type="diffuse" id="mat"><rgb name="reflectance" value="$refl, 0.5, $refl"/></bsdf>
        <shape type="rectangle"><ref id="mat"/></shape>
        <shape type="cube"><ref name="bsdf" id="mat"/></shape>""", sensor="")
    s = load_scene(path, depth=3)
    assert s.spp == 8 and s.integrator.params == {"max_depth": 3}
    assert s.integrator.name == "path"
    with pytest.raises(SceneError, match=r"parameter\(s\) typo not declared by the file"):
        load_scene(path, depth=3, typo=1)
    s = load_scene(path, depth="7", spp=2, refl=0.125)
    assert s.spp == 2 and s.integrator.params["max_depth"] == 7
    assert len(s.bsdfs) == 1 and list(s.shape_bsdf) == [0, 0]
    np.testing.assert_allclose(s.bsdfs[0].reflectance, [0.125, 0.5, 0.125])


def test_defaults_of_plugins(tmp_path):
    path = write_scene(tmp_path, """
        <shape type="rectangle"><emitter type="area"/></shape>
        <shape type="disk"><bsdf type="dielectric"/></shape>
        <shape type="cube"><bsdf type="roughconductor"/></shape>
        <emitter type="point"><point name="position" value="0, 1, 0"/></emitter>
        <emitter type="constant"/>""")
    s = load_scene(path)
    assert s.integrator.name == "path" and s.spp == 4 and s.seed == 0
    assert [type(b).__name__ for b in s.bsdfs] == ["Diffuse", "Dielectric", "RoughConductor"]
    np.testing.assert_allclose(s.bsdfs[0].reflectance, 0.0)   # Mitsuba's default on an emitter
    assert s.bsdfs[1].int_ior == pytest.approx(1.5046) and s.bsdfs[1].ext_ior == pytest.approx(1.000277)
    assert s.bsdfs[2].distribution == "beckmann"
    assert s.bsdfs[2].alpha_u == pytest.approx(0.1) and s.bsdfs[2].alpha_v == pytest.approx(0.1)
    assert list(s.shape_emitter) == [0, -1, -1]
    np.testing.assert_allclose(s.emitters[0].radiance, 1.0)
    np.testing.assert_allclose(s.emitters[1].position, [0, 1, 0])
    assert s.environment is s.emitters[2]
    assert s.camera.near_clip == 0.01 and s.camera.far_clip == 1e4
    assert s.camera.width == 64 and s.camera.height == 48
    line = open(path).read().splitlines().index('<shape type="rectangle"><emitter type="area"/></shape>') + 1
    assert s.shape_name[0] == f"rectangle (scene.xml:{line})"


def test_bsdf_parameters(tmp_path):
    path = write_scene(tmp_path, """
        <shape type="rectangle"><bsdf type="twosided"><bsdf type="conductor">
            <rgb name="specular_reflectance" value="0.9 0.8 0.7"/></bsdf></bsdf></shape>
        <shape type="rectangle"><bsdf type="dielectric">
            <string name="int_ior" value="water"/><float name="ext_ior" value="1.1"/></bsdf></shape>
        <shape type="rectangle"><bsdf type="roughconductor">
            <string name="distribution" value="ggx"/><float name="alpha_u" value="0.2"/>
            <float name="alpha_v" value="0.3"/></bsdf></shape>""")
    s = load_scene(path)
    assert type(s.bsdfs[0]).__name__ == "TwoSided"
    assert s.bsdfs[1].int_ior == pytest.approx(1.333) and s.bsdfs[1].ext_ior == 1.1
    assert (s.bsdfs[2].distribution, s.bsdfs[2].alpha_u, s.bsdfs[2].alpha_v) == ("ggx", 0.2, 0.3)


def test_builtin_scene_by_name():
    names = [f[:-4] for f in os.listdir(os.path.join(os.path.dirname(__file__), "..",
                                                      "pathtracer", "data", "scenes")) if f.endswith(".xml")]
    assert "cornell-box" in names      # shipped with the package: missing is a defect
    s = load_scene("cornell-box")
    assert s.num_triangles > 0 and s.source == "cornell-box"


# -- shapes -----------------------------------------------------------------

def geometric_normals(p):
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    return n / np.linalg.norm(n, axis=1, keepdims=True)


def test_rectangle_and_cube_orientation(tmp_path):
    path = write_scene(tmp_path, """
        <shape type="rectangle"/>
        <shape type="rectangle"><boolean name="flip_normals" value="true"/></shape>
        <shape type="rectangle"><transform name="to_world"><scale x="-1"/></transform></shape>
        <shape type="cube"><transform name="to_world"><scale x="2"/></transform></shape>""")
    s = load_scene(path)
    for k, z in enumerate([1, -1, 1]):
        tri = s.tri_shape == k
        np.testing.assert_allclose(geometric_normals(s.tri_p[tri]), [[0, 0, z]] * 2, atol=1e-15)
        np.testing.assert_allclose(s.tri_n[tri], [[[0, 0, z]] * 3] * 2, atol=1e-15)
        assert s.shape_area[k] == pytest.approx(4.0)
    cube = s.tri_shape == 3
    p = s.tri_p[cube]
    assert p.shape == (12, 3, 3)
    centroid = p.mean(axis=1)
    n = geometric_normals(p)
    assert np.all(np.einsum("ij,ij->i", n, centroid) > 0)  # outward
    np.testing.assert_allclose(s.tri_n[cube], np.repeat(n[:, None], 3, axis=1), atol=1e-15)
    assert s.shape_area[3] == pytest.approx(2 * (4 + 8 + 8))  # 4 x 2 x 2 box
    cdf = s.shape_tri_cdf[3]
    assert cdf[-1] == 1.0 and np.all(np.diff(cdf) > 0)
    np.testing.assert_array_equal(s.shape_prim, [[0, 2], [2, 4], [4, 6], [6, 18]])


def test_disk_area_and_arrays(tmp_path):
    path = write_scene(tmp_path, """
        <shape type="disk"><boolean name="flip_normals" value="true"/>
            <transform name="to_world"><scale x="2" y="3"/><rotate x="1" angle="40"/><translate z="1"/>
            </transform></shape>
        <shape type="disk"><transform name="to_world">
            <matrix value="1 1 0 0 0 1 0 0 0 0 1 0 0 0 0 1"/></transform></shape>""")
    s = load_scene(path)
    np.testing.assert_allclose(s.shape_area, [np.pi * 6, np.pi])  # shear keeps area
    assert list(s.disk_flip) == [True, False] and s.shape_kind == ["disk", "disk"]
    np.testing.assert_allclose(s.disk_to_world[0] @ s.disk_to_local[0], np.eye(4), atol=1e-12)


# -- meshes -----------------------------------------------------------------

def test_obj_fan_triangulation_and_vertex_split():
    mesh = read_obj(os.path.join(DATA, "pyramid.obj"))
    assert mesh.normals is None
    # The quad 1 4 3 2 becomes (1,4,3), (1,3,2); four apex faces follow.
    assert mesh.faces.shape == (6, 3)
    # Keys (v, vt, vn), a missing index inherited within a face:
    # f 1/1 4 3 2 -> 1/1 4/1 3/1 2/1;  f 1/1 2 5 -> 1/1 2/1 5/1;  f 2 3 5 -> new keys
    # 2 3 5;  f 3 4 5 -> 4 new;  f 4 1/2 5 -> 1/2 and 5/2 new: 11 mesh vertices.
    assert len(mesh.positions) == 11
    np.testing.assert_allclose(mesh.positions[mesh.faces[0]], [[0, 0, 0], [0, 1, 0], [2, 1, 0]])


def test_smooth_normals_are_angle_weighted():
    # Two triangles sharing vertex 0: a 90-degree corner in the plane z=0 and a
    # 45-degree corner in the plane x=0. Weights are angles, not areas.
    p = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 5, 5], [0, 0, 1]], float)
    faces = np.array([[0, 1, 2], [0, 3, 4]])
    n = smooth_vertex_normals(p, faces)
    want = 0.5 * np.pi * np.array([0, 0, 1]) + 0.25 * np.pi * np.array([1, 0, 0])
    np.testing.assert_allclose(n[0], want / np.linalg.norm(want))
    np.testing.assert_allclose(n[1], [0, 0, 1])


def write_binary_ply(path, positions, faces, normals=None, endian="<"):
    fmt = "binary_little_endian" if endian == "<" else "binary_big_endian"
    props = "property float x\nproperty float y\nproperty float z\n"
    fields = [("x", endian + "f4"), ("y", endian + "f4"), ("z", endian + "f4")]
    if normals is not None:
        props += "property float nx\nproperty float ny\nproperty float nz\n"
        fields += [("nx", endian + "f4"), ("ny", endian + "f4"), ("nz", endian + "f4")]
    header = (f"ply\nformat {fmt} 1.0\nelement vertex {len(positions)}\n{props}"
              f"element face {len(faces)}\nproperty list uchar uint vertex_indices\nend_header\n")
    v = np.zeros(len(positions), dtype=fields)
    for i, k in enumerate("xyz"):
        v[k] = positions[:, i]
        if normals is not None:
            v["n" + k] = normals[:, i]
    f = np.zeros(len(faces), dtype=[("n", "u1"), ("i", endian + "u4", (3,))])
    f["n"], f["i"] = 3, faces
    with open(path, "wb") as out:
        out.write(header.encode() + v.tobytes() + f.tobytes())


def test_ply_ascii_and_binary_agree(tmp_path):
    ascii_mesh = read_ply(os.path.join(DATA, "tetra.ply"))
    for endian in "<>":
        path = tmp_path / f"tetra{endian == '<'}.ply"
        write_binary_ply(path, ascii_mesh.positions, ascii_mesh.faces, endian=endian)
        binary = read_ply(str(path))
        np.testing.assert_array_equal(binary.positions, ascii_mesh.positions)
        np.testing.assert_array_equal(binary.faces, ascii_mesh.faces)
    with_n = read_ply(os.path.join(DATA, "quad_normals.ply"))
    assert with_n.normals.shape == (4, 3) and with_n.faces.tolist() == [[0, 1, 2], [0, 2, 3]]


def test_mesh_normals_transform_and_face_normals(tmp_path):
    path = write_scene(tmp_path, f"""
        <shape type="obj"><string name="filename" value="{DATA}/tri_normals.obj"/>
            <transform name="to_world"><scale x="2" y="1" z="0.5"/></transform></shape>
        <shape type="obj"><string name="filename" value="{DATA}/tri_normals.obj"/>
            <boolean name="face_normals" value="true"/></shape>
        <shape type="ply"><string name="filename" value="{DATA}/quad_normals.ply"/>
            <boolean name="flip_normals" value="true"/></shape>""")
    s = load_scene(path)
    a = s.tri_shape == 0
    # Normals go through the inverse transpose diag(1/2, 1, 2), then unit length.
    n_file = np.array([0.1, 0, 1]) * [0.5, 1, 2]
    np.testing.assert_allclose(s.tri_n[a][0, 1], n_file / np.linalg.norm(n_file))
    b = s.tri_shape == 1
    np.testing.assert_allclose(s.tri_n[b], np.repeat(geometric_normals(s.tri_p[b])[:, None], 3, axis=1))
    c = s.tri_shape == 2
    np.testing.assert_allclose(geometric_normals(s.tri_p[c]), [[0, 0, -1]] * 2, atol=1e-7)
    assert np.all(s.tri_n[c][:, :, 2] < 0)


# -- sensor -----------------------------------------------------------------

def test_fov_axis_conversion():
    aspect = 2.0
    assert x_fov_from(30, "x", aspect) == 30
    half = np.deg2rad(15)
    assert x_fov_from(30, "y", aspect) == pytest.approx(np.rad2deg(2 * np.arctan(np.tan(half) * 2)))
    assert x_fov_from(30, "smaller", aspect) == x_fov_from(30, "y", aspect)
    assert x_fov_from(30, "larger", aspect) == 30
    assert x_fov_from(30, "smaller", 0.5) == 30
    d = 2 * np.tan(half)
    assert x_fov_from(30, "diagonal", aspect) == pytest.approx(
        np.rad2deg(2 * np.arctan(d / np.sqrt(5) * 2 / 2)))


def test_sensor_fields(tmp_path):
    sensor = SENSOR.replace('<float name="fov" value="40"/>',
                            '<float name="fov" value="40"/><string name="fov_axis" value="y"/>'
                            '<float name="near_clip" value="0.5"/>')
    s = load_scene(write_scene(tmp_path, "", sensor=sensor))
    assert s.camera.x_fov == pytest.approx(x_fov_from(40, "y", 64 / 48))
    assert s.camera.near_clip == 0.5
    np.testing.assert_allclose(s.camera.to_world, transform.look_at([0, 0, 5], [0, 0, 0], [0, 1, 0]))


# -- comparison with Mitsuba ----------------------------------------------------

def mitsuba_triangles(shape):
    pos = np.array(shape.vertex_positions_buffer(), dtype=float).reshape(-1, 3)
    nrm = np.array(shape.vertex_normals_buffer(), dtype=float).reshape(-1, 3)
    faces = np.array(shape.faces_buffer(), dtype=np.int64).reshape(-1, 3)
    return pos[faces], (nrm[faces] if nrm.size else None)


def test_meshes_match_mitsuba(tmp_path, mi):
    ply_bin = tmp_path / "tetra_bin.ply"
    tetra = read_ply(os.path.join(DATA, "tetra.ply"))
    write_binary_ply(ply_bin, tetra.positions, tetra.faces)
    xf = ('<transform name="to_world"><scale x="2" y="0.5" z="1.5"/>'
          '<rotate x="0.48" y="0.6" z="0.64" angle="35"/><translate x="0.3"/></transform>')
    body = f"""
        <shape type="obj" id="pyr"><string name="filename" value="{DATA}/pyramid.obj"/>{xf}</shape>
        <shape type="obj" id="trin"><string name="filename" value="{DATA}/tri_normals.obj"/>{xf}</shape>
        <shape type="ply" id="tet"><string name="filename" value="{DATA}/tetra.ply"/>{xf}</shape>
        <shape type="ply" id="tetb"><string name="filename" value="{ply_bin}"/>{xf}</shape>
        <shape type="ply" id="quad"><string name="filename" value="{DATA}/quad_normals.ply"/>{xf}</shape>"""
    path = write_scene(tmp_path, body)
    ours = load_scene(path)
    theirs = {sh.id(): sh for sh in mi.load_file(path).shapes()}
    for k, ident in enumerate(["pyr", "trin", "tet", "tetb", "quad"]):
        p, n = mitsuba_triangles(theirs[ident])
        mask = ours.tri_shape == k
        np.testing.assert_allclose(ours.tri_p[mask], p, atol=1e-5, err_msg=ident)
        np.testing.assert_allclose(ours.tri_n[mask], n, atol=1e-5, err_msg=ident)


def assert_same_faces(ours_p, ours_n, their_p, their_n):
    """Same planar faces (grouped by geometric normal): same corners, area and
    shading normals, whichever diagonal splits each quad."""
    def groups(p, n):
        geo = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
        area = 0.5 * np.linalg.norm(geo, axis=1)
        unit = geo / (2 * area[:, None])
        out = []
        for i in range(len(p)):
            for g in out:
                if np.dot(g[0], unit[i]) > 1 - 1e-6:
                    g[1].append(i)
                    break
            else:
                out.append((unit[i], [i]))
        return [(u, p[idx].reshape(-1, 3), area[idx].sum(), n[idx].reshape(-1, 3)) for u, idx in out]

    def same_points(a, b):
        d = np.linalg.norm(a[:, None] - b[None], axis=2)
        return d.min(axis=1).max() < 1e-5 and d.min(axis=0).max() < 1e-5

    mine, theirs = groups(ours_p, ours_n), groups(their_p, their_n)
    assert len(mine) == len(theirs)
    for u, pts, area, nrm in mine:
        match = [g for g in theirs if np.dot(g[0], u) > 1 - 1e-5]
        assert len(match) == 1, f"no face with normal {u} in Mitsuba's mesh"
        _, pts2, area2, nrm2 = match[0]
        assert same_points(pts, pts2) and area == pytest.approx(area2, rel=1e-5)
        assert same_points(nrm, nrm2)


def test_cube_and_rectangle_match_mitsuba(tmp_path, mi):
    xf = ('<transform name="to_world"><scale x="1" y="2" z="3"/><rotate value="0.6 0 0.8" angle="20"/>'
          '<translate y="1"/></transform>')
    path = write_scene(tmp_path, f"""
        <shape type="cube" id="cube">{xf}</shape>
        <shape type="rectangle" id="rect">{xf}</shape>""")
    ours = load_scene(path)
    theirs = {sh.id(): sh for sh in mi.load_file(path).shapes()}
    for k, ident in enumerate(["cube", "rect"]):
        p, n = mitsuba_triangles(theirs[ident])
        mask = ours.tri_shape == k
        assert_same_faces(ours.tri_p[mask], ours.tri_n[mask], p, n)
        assert ours.shape_area[k] == pytest.approx(theirs[ident].surface_area(), rel=1e-5)


def test_disk_and_sphere_match_mitsuba(tmp_path, mi):
    path = write_scene(tmp_path, """
        <shape type="disk" id="disk"><transform name="to_world"><scale x="2" y="0.5"/>
            <matrix value="1 0.3 0 0 0 1 0.2 0 0 0 1 0 0 0 0 1"/><translate z="2"/></transform></shape>
        <shape type="sphere" id="sph"><float name="radius" value="0.5"/>
            <transform name="to_world"><rotate y="1" angle="33"/><scale value="3"/><translate x="1"/>
            </transform></shape>""")
    ours = load_scene(path)
    theirs = {sh.id(): sh for sh in mi.load_file(path).shapes()}
    assert ours.shape_area[0] == pytest.approx(theirs["disk"].surface_area(), rel=1e-5)
    assert ours.shape_area[1] == pytest.approx(theirs["sph"].surface_area(), rel=1e-5)
    bb = theirs["sph"].bbox()
    np.testing.assert_allclose(ours.sphere_center[0], (np.array(bb.min) + np.array(bb.max)) / 2, atol=1e-5)


@pytest.mark.parametrize("axis", ["x", "y", "diagonal", "smaller", "larger"])
@pytest.mark.parametrize("size", [(64, 48), (40, 80)])
def test_x_fov_matches_mitsuba(tmp_path, mi, axis, size):
    sensor = SENSOR.replace('<float name="fov" value="40"/>',
                            f'<float name="fov" value="40"/><string name="fov_axis" value="{axis}"/>')
    sensor = sensor.replace('value="64"', f'value="{size[0]}"').replace('value="48"', f'value="{size[1]}"')
    path = write_scene(tmp_path, "", sensor=sensor)
    params = mi.traverse(mi.load_file(path).sensors()[0])
    assert load_scene(path).camera.x_fov == pytest.approx(float(params["x_fov"]), rel=1e-6)


def test_transforms_match_mitsuba(tmp_path, mi):
    sensor = SENSOR.replace(
        '<lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/>',
        '<rotate value="0, 1, 0" angle="17"/><lookat origin="1, 2, 3" target="-1, 0.5, 0" up="0.1, 1, 0.2"/>'
        '<rotate x="1" angle="-25"/><translate value="0.5 0 -1"/>')
    path = write_scene(tmp_path, "", sensor=sensor)
    ours = load_scene(path).camera.to_world
    theirs = np.array(mi.traverse(mi.load_file(path).sensors()[0])["to_world"].matrix, dtype=float)
    np.testing.assert_allclose(ours, theirs, atol=1e-6)
    T = mi.ScalarTransform4f
    np.testing.assert_allclose(transform.look_at([1, 2, 3], [0, 0, 0], [0, 0, 1]),
                               np.array(T().look_at([1, 2, 3], [0, 0, 0], [0, 0, 1]).matrix), atol=1e-6)
    axis = np.array([1, 2, 3]) / np.sqrt(14)
    np.testing.assert_allclose(transform.rotate(axis, 70),
                               np.array(T().rotate(axis, 70).matrix), atol=1e-6)


def test_builtin_scenes_match_mitsuba(mi):
    """Every shipped scene: same total area, camera, film, spp and emitter count.
    (Mitsuba merges meshes that share a BSDF, so shapes are compared in total.)"""
    from pathtracer.scene.load import BUILTIN_DIR, builtin_scene_path
    names = sorted(f[:-4] for f in os.listdir(BUILTIN_DIR) if f.endswith(".xml"))
    if not names:
        pytest.skip("no built-in scenes yet")
    for name in names:
        ours = load_scene(name)
        theirs = mi.load_file(builtin_scene_path(name))
        sensor = theirs.sensors()[0]
        params = mi.traverse(sensor)
        assert sum(ours.shape_area) == pytest.approx(
            sum(s.surface_area() for s in theirs.shapes()), rel=1e-5), name
        assert ours.camera.x_fov == pytest.approx(float(params["x_fov"]), rel=1e-6), name
        np.testing.assert_allclose(ours.camera.to_world, np.array(params["to_world"].matrix),
                                   atol=1e-4, err_msg=name)
        assert (ours.camera.width, ours.camera.height) == tuple(sensor.film().size()), name
        from mitsuba_refs.reference.rfilter import film_filter
        assert ours.camera.rfilter == film_filter(sensor.film()), name
        assert ours.spp == sensor.sampler().sample_count(), name
        assert len(ours.emitters) == len(theirs.emitters()), name


def test_default_bsdf_is_black_on_emitters(tmp_path):
    """As Mitsuba: a shape without a BSDF is diffuse 0.5, an emitting one diffuse 0 (a lamp's
    own surface reflects nothing: a grey one made a ground lit by a large light 0.8 % too bright)."""
    scene = load_scene(write_scene(tmp_path, """
        <shape type="rectangle"/>
        <shape type="rectangle"><emitter type="area"/></shape>
        <shape type="sphere"/>"""))
    reflectance = [scene.bsdfs[b].reflectance for b in scene.shape_bsdf]
    np.testing.assert_array_equal(reflectance, [[0.5] * 3, [0.0] * 3, [0.5] * 3])


def test_storage_only_film_options_and_literal_sample_count(tmp_path):
    """Options that change how Mitsuba stores the image, not its values, are accepted."""
    sensor = ('<sensor type="perspective"><float name="fov" value="40"/>'
              '<sampler type="independent"><integer name="sample_count" value="24"/></sampler>'
              '<film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="6"/>'
              '<string name="pixel_format" value="rgba"/><string name="component_format" value="float16"/>'
              '<string name="file_format" value="openexr"/><boolean name="sample_border" value="true"/>'
              '<boolean name="compensate" value="true"/><boolean name="banner" value="false"/>'
              '<rfilter type="box"/></film></sensor>')
    s = load_scene(write_scene(tmp_path, "", sensor=sensor))
    assert (s.camera.width, s.camera.height, s.spp) == (8, 6, 24)
