"""Mitsuba's ``serialized`` meshes, written here by an independent writer of the documented format."""
from __future__ import annotations

import struct
import zlib

import numpy as np
import pytest

from pathtracer.io.meshes import MeshFormatError, read_serialized
from pathtracer.scene.errors import SceneError
from pathtracer.scene.load import load_scene

SENSOR = ('<sensor type="perspective"><film type="hdrfilm"><integer name="width" value="8"/>'
          '<integer name="height" value="8"/><rfilter type="box"/></film></sensor>')


def shape_record(positions, faces, normals=None, uvs=None, face_normals=False, double=False,
                 version=4, name="shape"):
    """One shape as the format describes it: magic, version, then a zlib stream of
    flags, (v4) name, counts, positions, normals, uvs, indices."""
    flags = (0x0001 if normals is not None else 0) | (0x0002 if uvs is not None else 0)
    flags |= (0x0010 if face_normals else 0) | (0x2000 if double else 0x1000)
    real = "<f8" if double else "<f4"
    body = struct.pack("<I", flags)
    if version == 4:
        body += name.encode() + b"\0"
    body += struct.pack("<QQ", len(positions), len(faces))
    for array in (positions, normals, uvs):
        if array is not None:
            body += np.asarray(array, dtype=real).tobytes()
    body += np.asarray(faces, dtype="<u4").tobytes()
    return struct.pack("<HH", 0x041C, version) + zlib.compress(body)


def write_serialized(path, records, version=4):
    """Concatenate shape records and append the offset table and the shape count."""
    data, offsets = b"", []
    for record in records:
        offsets.append(len(data))
        data += record
    table = struct.pack(f"<{len(offsets)}{'Q' if version == 4 else 'I'}", *offsets)
    path.write_bytes(data + table + struct.pack("<I", len(offsets)))
    return str(path)


RNG = np.random.default_rng(7)
QUAD_P = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0.5], [-1, 1, 0.25]], dtype=float)
QUAD_F = np.array([[0, 1, 2], [0, 2, 3]])
QUAD_N = np.array([[0, 0, 1], [0, 0.6, 0.8], [0.6, 0, 0.8], [0, 0, 1]], dtype=float)
BLOB_P = RNG.normal(size=(7, 3))
BLOB_F = np.array([[0, 1, 2], [2, 3, 4], [4, 5, 6], [6, 0, 3]])


@pytest.fixture
def mesh_file(tmp_path):
    return write_serialized(tmp_path / "two.serialized", [
        shape_record(QUAD_P, QUAD_F, normals=QUAD_N, uvs=RNG.random((4, 2))),
        shape_record(BLOB_P, BLOB_F, double=True, face_normals=True)])


def test_reader_returns_what_was_written(mesh_file, tmp_path):
    quad = read_serialized(mesh_file, 0)
    np.testing.assert_array_equal(quad.positions, QUAD_P.astype(np.float32))
    np.testing.assert_array_equal(quad.normals, QUAD_N.astype(np.float32))
    np.testing.assert_array_equal(quad.faces, QUAD_F)
    blob = read_serialized(mesh_file, 1)
    np.testing.assert_array_equal(blob.positions, BLOB_P)  # double precision
    assert blob.normals is None
    v3 = write_serialized(tmp_path / "v3.serialized", [shape_record(QUAD_P, QUAD_F, version=3)],
                          version=3)
    np.testing.assert_array_equal(read_serialized(v3, 0).positions, QUAD_P.astype(np.float32))


def test_shape_index_out_of_range_and_corrupt_files(mesh_file, tmp_path):
    with pytest.raises(MeshFormatError, match="shape_index 2 is out of range"):
        read_serialized(mesh_file, 2)
    (tmp_path / "bad.serialized").write_bytes(b"not a mesh at all")
    with pytest.raises(MeshFormatError, match="not a Mitsuba serialized mesh"):
        read_serialized(str(tmp_path / "bad.serialized"))


def scene_with(tmp_path, mesh_file, extra="", index=0):
    path = tmp_path / "scene.xml"
    path.write_text(f'<scene version="3.0.0">{SENSOR}\n<shape type="serialized" id="s">'
                    f'<string name="filename" value="{mesh_file}"/>'
                    f'<integer name="shape_index" value="{index}"/>{extra}</shape></scene>')
    return str(path)


def test_scene_errors_name_the_shape(mesh_file, tmp_path):
    with pytest.raises(SceneError, match=r'scene.xml:2: <shape type="serialized">: .*out of range'):
        load_scene(scene_with(tmp_path, mesh_file, index=5))


TRANSFORM = ('<transform name="to_world"><scale x="2" y="1" z="0.5"/>'
             '<rotate x="0.6" y="0" z="0.8" angle="30"/><translate y="1"/></transform>')


@pytest.mark.mitsuba
@pytest.mark.parametrize("index, extra", [(0, ""), (0, TRANSFORM),
                                          (0, '<boolean name="face_normals" value="true"/>'),
                                          (1, TRANSFORM)])
def test_matches_mitsuba(mesh_file, tmp_path, index, extra, mi):
    """Mitsuba reads the same file: same world-space triangles and shading normals."""
    path = scene_with(tmp_path, mesh_file, extra, index)
    ours = load_scene(path)
    shape = mi.load_file(path).shapes()[0]
    positions = np.array(shape.vertex_positions_buffer(), dtype=float).reshape(-1, 3)
    faces = np.array(shape.faces_buffer(), dtype=np.int64).reshape(-1, 3)
    np.testing.assert_allclose(ours.tri_p, positions[faces], rtol=1e-6, atol=1e-6)
    normals = np.array(shape.vertex_normals_buffer(), dtype=float).reshape(-1, 3)
    if "face_normals" not in extra:
        # Shape 1 has the file's face-normal flag but no normals: Mitsuba ignores
        # the flag and computes smooth normals, as we do.
        np.testing.assert_allclose(ours.tri_n, normals[faces], rtol=1e-5, atol=1e-6)
    else:
        # Flat shading on both sides: Mitsuba stores no vertex normals.
        assert normals.size == 0
        geometric = np.cross(ours.tri_p[:, 1] - ours.tri_p[:, 0], ours.tri_p[:, 2] - ours.tri_p[:, 0])
        geometric /= np.linalg.norm(geometric, axis=1, keepdims=True)
        np.testing.assert_allclose(ours.tri_n, np.repeat(geometric[:, None], 3, axis=1), atol=1e-12)
