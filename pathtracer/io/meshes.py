"""OBJ, PLY and Mitsuba ``serialized`` triangle-mesh readers and Mitsuba's vertex-normal rule.

The readers return object-space data; :mod:`pathtracer.scene.build` applies
``to_world`` and decides between file normals, recomputed smooth normals and
flat normals, in the same order as Mitsuba (transform first, then recompute).
"""
from __future__ import annotations

import math
import os
import struct
import zlib
from dataclasses import dataclass, field

import numpy as np

from ..core.vec import dot_einsum, unit
from .ply_attributes import ply_attributes


class MeshFormatError(ValueError):
    """A mesh file that cannot be read; the loader adds the scene location."""


@dataclass
class MeshData:
    """An indexed triangle mesh.

    Attributes
    ----------
    positions : (V, 3) float64
    normals : (V, 3) float64 or None
        Per-vertex normals stored in the file, if any.
    faces : (F, 3) int64
        Vertex indices of each triangle, in file order.
    texcoords : (V, 2) float64 or None
        Per-vertex texture coordinates stored in the file, if any, as stored
        (the loader applies ``flip_tex_coords``).
    attributes : dict
        Mitsuba's mesh attributes: ``"vertex_<name>"`` -> (V, C), ``"face_<name>"`` ->
        (F, C) float64 arrays, C = 1 or 3 (4 for a colour with alpha), e.g.
        ``vertex_color`` (:mod:`pathtracer.io.ply_attributes`). Only PLY files carry them
        (Mitsuba 3.9.1's OBJ reader reads none and its serialized reader skips the colours).
    """

    positions: np.ndarray
    normals: np.ndarray | None
    faces: np.ndarray
    texcoords: np.ndarray | None = None
    attributes: dict = field(default_factory=dict)


def read_obj(path: str) -> MeshData:
    """Read a Wavefront OBJ file.

    As in Mitsuba 3.9.1's reader, a mesh vertex is one distinct ``v/vt/vn``
    index triple (a position used with two texture coordinates becomes two
    vertices, which matters for recomputed normals), and an index a corner
    leaves out is *inherited from the previous corner of the same face*
    (``f 1/1 2 3`` gives keys 1/1, 2/1, 3/1). Polygons are fan-triangulated
    ``(v0, v[i-1], v[i])``. Only ``v``, ``vt``, ``vn`` and ``f`` lines matter
    (``vt``: the first two numbers, u and v).

    Face corners without a ``vt`` index get NaN texture coordinates when
    others have one (Mitsuba 3.9.1 reports NaN uv there).

    Raises
    ------
    MeshFormatError
        On a malformed line, a NaN or infinite coordinate, an invalid or
        negative index, or normals given for only some face corners (Mitsuba
        leaves the others undefined).
    """
    positions, normals, texcoords = [], [], []
    vertex_of_key: dict[tuple, int] = {}
    keys: list[tuple] = []
    triangles: list[tuple] = []
    with open(path, "r", encoding="utf-8", errors="replace") as f:
        for lineno, line in enumerate(f, 1):
            tokens = line.split()
            if not tokens:
                continue
            head = tokens[0]
            try:
                if head in ("v", "vn"):
                    values = [float(t) for t in tokens[1:4]]
                    if len(values) != 3:
                        raise ValueError
                    if not all(math.isfinite(v) for v in values):
                        raise MeshFormatError(f"{os.path.basename(path)}:{lineno}: "
                                              f"{'vertex' if head == 'v' else 'normal'} "
                                              f"\"{line.strip()}\" is not finite")
                    (positions if head == "v" else normals).append(values)
                elif head == "vt":
                    values = [float(t) for t in tokens[1:3]]
                    if len(values) != 2:
                        raise ValueError
                    if not all(math.isfinite(v) for v in values):
                        raise MeshFormatError(f"{os.path.basename(path)}:{lineno}: texture "
                                              f"coordinate \"{line.strip()}\" is not finite")
                    texcoords.append(values)
                elif head == "f":
                    corners = []
                    key = [0, 0, 0]
                    for t in tokens[1:]:
                        parts = t.split("/")
                        if len(parts) > 3:
                            raise ValueError
                        for slot, text in enumerate(parts):
                            if text:
                                key[slot] = int(text)
                        if min(key) < 0:
                            raise MeshFormatError(
                                f"{os.path.basename(path)}:{lineno}: negative (relative) OBJ "
                                "indices are not supported (Mitsuba rejects them too)")
                        if not 1 <= key[0] <= len(positions):
                            raise MeshFormatError(
                                f"{os.path.basename(path)}:{lineno}: reference to invalid vertex {key[0]}")
                        if key[1] > len(texcoords):
                            raise MeshFormatError(
                                f"{os.path.basename(path)}:{lineno}: reference to invalid texture coordinate {key[1]}")
                        if key[2] > len(normals):
                            raise MeshFormatError(
                                f"{os.path.basename(path)}:{lineno}: reference to invalid normal {key[2]}")
                        frozen = tuple(key)
                        if frozen not in vertex_of_key:
                            vertex_of_key[frozen] = len(keys)
                            keys.append(frozen)
                        corners.append(vertex_of_key[frozen])
                    for i in range(2, len(corners)):
                        triangles.append((corners[0], corners[i - 1], corners[i]))
            except MeshFormatError:
                raise
            except ValueError:
                raise MeshFormatError(f"{os.path.basename(path)}:{lineno}: could not parse "
                                      f"line \"{line.strip()}\"") from None
    if not triangles:
        raise MeshFormatError(f"{os.path.basename(path)}: no faces")
    key_arr = np.array(keys, dtype=np.int64)
    pos = np.array(positions, dtype=float)[key_arr[:, 0] - 1]
    nrm = None
    if normals:
        if np.any(key_arr[:, 2] == 0):
            raise MeshFormatError(f"{os.path.basename(path)}: the file has vn normals but some "
                                  "face corners use none (Mitsuba leaves those undefined)")
        nrm = np.array(normals, dtype=float)[key_arr[:, 2] - 1]
    uv = None
    if texcoords and np.any(key_arr[:, 1] != 0):
        # Corners without a vt get NaN, as in Mitsuba (textures there are black).
        table = np.vstack((np.full((1, 2), np.nan), np.array(texcoords, dtype=float)))
        uv = table[key_arr[:, 1]]
    return MeshData(pos, nrm, np.array(triangles, dtype=np.int64), uv)


_PLY_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1",
    "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2",
    "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}


def _ply_header(f, name: str):
    """Parse the header; returns (format, elements) with elements as
    ``[(name, count, [(prop, type, list_count_type or None)])]``."""
    if f.readline().strip() != b"ply":
        raise MeshFormatError(f"{name}: not a PLY file (missing 'ply' magic)")
    fmt, elements = None, []
    while True:
        raw = f.readline()
        if not raw:
            raise MeshFormatError(f"{name}: PLY header has no end_header")
        tokens = raw.decode("ascii", "replace").split()
        if not tokens or tokens[0] in ("comment", "obj_info"):
            continue
        if tokens[0] == "end_header":
            break
        try:
            if tokens[0] == "format":
                fmt = tokens[1]
                if fmt not in ("ascii", "binary_little_endian", "binary_big_endian"):
                    raise MeshFormatError(f"{name}: unknown PLY format \"{fmt}\"")
            elif tokens[0] == "element":
                elements.append((tokens[1], int(tokens[2]), []))
            elif tokens[0] == "property":
                if tokens[1] == "list":
                    elements[-1][2].append((tokens[4], _PLY_TYPES[tokens[3]], _PLY_TYPES[tokens[2]]))
                else:
                    elements[-1][2].append((tokens[2], _PLY_TYPES[tokens[1]], None))
            else:
                raise MeshFormatError(f"{name}: unexpected PLY header line \"{' '.join(tokens)}\"")
        except (IndexError, KeyError, ValueError):
            raise MeshFormatError(f"{name}: invalid PLY header line \"{' '.join(tokens)}\"") from None
    if fmt is None:
        raise MeshFormatError(f"{name}: PLY header has no format line")
    return fmt, elements


def _ply_dtype(props, endian: str) -> np.dtype:
    """Fixed-size record of one element; lists are assumed to hold 3 entries
    (the only case Mitsuba accepts), which the caller verifies."""
    fields = []
    for prop, typ, count_type in props:
        if count_type is None:
            fields.append((prop, endian + typ))
        else:
            fields.append((prop + ".count", endian + count_type))
            fields.append((prop, endian + typ, (3,)))
    return np.dtype(fields)


def read_ply(path: str) -> MeshData:
    """Read an ASCII or binary (little/big endian) PLY triangle mesh.

    Vertex properties ``x, y, z`` are required, ``nx, ny, nz`` are used when
    all present, and so are texture coordinates named ``u, v``, ``s, t`` or
    ``texture_u, texture_v`` (Mitsuba's names). Faces come from
    ``vertex_indices`` or ``vertex_index`` and must be triangles, as Mitsuba
    requires. NaN or infinite coordinates are refused.
    """
    name = os.path.basename(path)
    with open(path, "rb") as f:
        fmt, elements = _ply_header(f, name)
        body = f.read()
    data = {}
    if fmt == "ascii":
        tokens = body.split()
        pos = 0
        for el_name, count, props in elements:
            width = sum(1 if c is None else 4 for _, _, c in props)
            dtype = _ply_dtype(props, "<")
            chunk = tokens[pos:pos + width * count]
            if len(chunk) != width * count:
                raise MeshFormatError(f"{name}: element {el_name}: file too short "
                                      "(or a face is not a triangle)")
            rows = np.array(chunk, dtype=float).reshape(count, width)
            rec = np.zeros(count, dtype=dtype)
            col = 0
            for field_name in dtype.names:
                n = 3 if dtype[field_name].shape else 1
                rec[field_name] = rows[:, col:col + n].reshape(rec[field_name].shape)
                col += n
            data[el_name] = rec
            pos += width * count
    else:
        endian = "<" if fmt == "binary_little_endian" else ">"
        offset = 0
        for el_name, count, props in elements:
            dtype = _ply_dtype(props, endian)
            size = dtype.itemsize * count
            if offset + size > len(body):
                raise MeshFormatError(f"{name}: element {el_name}: file too short "
                                      "(or a face is not a triangle)")
            data[el_name] = np.frombuffer(body, dtype=dtype, count=count, offset=offset)
            offset += size
    return _ply_mesh(data, elements, name)


#: Vertex properties Mitsuba's PLY reader takes as texture coordinates, in its order.
PLY_TEXCOORD_NAMES = (("u", "v"), ("s", "t"), ("texture_u", "texture_v"))


def _ply_mesh(data: dict, elements, name: str) -> MeshData:
    props = {el_name: [p for p, _, _ in el_props] for el_name, _, el_props in elements}
    if "vertex" not in data or not {"x", "y", "z"} <= set(props["vertex"]):
        raise MeshFormatError(f"{name}: PLY file has no vertex element with x, y, z")
    for el_name, _, el_props in elements:
        if el_name == "vertex" and any(c is not None for _, _, c in el_props):
            raise MeshFormatError(f"{name}: list properties on vertices are not supported")
    v = data["vertex"]
    positions = np.stack([v["x"], v["y"], v["z"]], axis=1).astype(float)
    normals = None
    if {"nx", "ny", "nz"} <= set(props["vertex"]):
        normals = np.stack([v["nx"], v["ny"], v["nz"]], axis=1).astype(float)
    for what, values in (("vertex", positions), ("normal", normals)):
        bad = np.flatnonzero(~np.isfinite(values).all(axis=1)) if values is not None else []
        if len(bad):
            raise MeshFormatError(f"{name}: {len(bad)} {what} value(s) are not finite "
                                  f"(the first is vertex {bad[0]}: {values[bad[0]].tolist()})")
    texcoords = None
    for u_name, v_name in PLY_TEXCOORD_NAMES:
        if {u_name, v_name} <= set(props["vertex"]):
            texcoords = np.stack([v[u_name], v[v_name]], axis=1).astype(float)
            break
    face_field = next((k for k in ("vertex_indices", "vertex_index")
                       if k in props.get("face", [])), None)
    if face_field is None:
        raise MeshFormatError(f"{name}: PLY file has no face element with vertex_indices")
    faces = data["face"]
    if np.any(faces[face_field + ".count"] != 3):
        raise MeshFormatError(f"{name}: only triangle faces are supported "
                              "(Mitsuba's PLY reader requires them too)")
    idx = faces[face_field].astype(np.int64)
    if idx.size and (idx.min() < 0 or idx.max() >= len(positions)):
        raise MeshFormatError(f"{name}: face refers to a vertex that does not exist")
    attributes = ply_attributes("vertex_", v, _reserved_vertex_names(props["vertex"]))
    attributes.update(ply_attributes("face_", faces, {face_field}))
    return MeshData(positions, normals, idx.reshape(-1, 3), texcoords, attributes)


def _reserved_vertex_names(names) -> set:
    """Vertex properties that are positions, normals or texture coordinates, not attributes."""
    reserved = {"x", "y", "z", "nx", "ny", "nz"}
    for pair in PLY_TEXCOORD_NAMES:
        if set(pair) <= set(names):
            reserved |= set(pair)
            break
    return reserved


#: Magic number and versions of Mitsuba's serialized format.
SERIALIZED_MAGIC = 0x041C
SERIALIZED_VERSIONS = (3, 4)
# Flags in the header of each compressed shape.
HAS_NORMALS, HAS_TEXCOORDS, HAS_COLORS = 0x0001, 0x0002, 0x0008
FACE_NORMALS, SINGLE_PRECISION, DOUBLE_PRECISION = 0x0010, 0x1000, 0x2000


def _serialized_offsets(data: bytes, name: str) -> tuple[list[int], int]:
    """Start of each shape and the format version, from the table at the end of the file.

    The file ends with one offset per shape (uint64 in version 4, uint32 in
    version 3) followed by the uint32 shape count; every shape starts with
    the uint16 magic number and uint16 version.
    """
    if len(data) < 8:
        raise MeshFormatError(f"{name}: too short for a serialized mesh")
    magic, version = struct.unpack_from("<HH", data, 0)
    if magic != SERIALIZED_MAGIC or version not in SERIALIZED_VERSIONS:
        raise MeshFormatError(f"{name}: not a Mitsuba serialized mesh (magic 0x{magic:04x}, "
                              f"version {version})")
    (count,) = struct.unpack_from("<I", data, len(data) - 4)
    width = 8 if version == 4 else 4
    table = len(data) - 4 - width * count
    if count == 0 or table < 4:
        raise MeshFormatError(f"{name}: corrupt shape table ({count} shapes)")
    offsets = list(struct.unpack_from(f"<{count}{'Q' if width == 8 else 'I'}", data, table))
    if any(not 0 <= o < table for o in offsets):
        raise MeshFormatError(f"{name}: corrupt shape table (offset beyond the data)")
    return offsets + [table], version


def _take(buffer: bytes, offset: int, dtype: str, count: int, name: str):
    size = np.dtype(dtype).itemsize * count
    if offset + size > len(buffer):
        raise MeshFormatError(f"{name}: shape data ends early")
    return np.frombuffer(buffer, dtype=dtype, count=count, offset=offset), offset + size


def read_serialized(path: str, shape_index: int = 0) -> MeshData:
    """Read shape ``shape_index`` of a Mitsuba ``.serialized`` file.

    Each shape is a zlib stream holding: uint32 flags; in version 4 a
    NUL-terminated name; uint64 vertex and triangle counts; positions,
    then (by flag) normals, texture coordinates and colours (read past), in
    float32 or float64; then the triangles' vertex indices, uint32 (uint64 when there
    are more than 2^32 - 1 vertices). All little endian. The face-normal
    flag is ignored, as Mitsuba 3.9.1 ignores it (only the shape's
    ``face_normals`` property makes a mesh flat).

    Raises
    ------
    MeshFormatError
        On a malformed file or a ``shape_index`` out of range.
    """
    name = os.path.basename(path)
    with open(path, "rb") as f:
        data = f.read()
    bounds, version = _serialized_offsets(data, name)
    if not 0 <= shape_index < len(bounds) - 1:
        raise MeshFormatError(f"{name}: shape_index {shape_index} is out of range (the file "
                              f"holds shapes 0..{len(bounds) - 2})")
    start, end = bounds[shape_index], bounds[shape_index + 1]
    try:
        stream = zlib.decompressobj().decompress(data[start + 4:end])
    except zlib.error as e:
        raise MeshFormatError(f"{name}: shape {shape_index}: corrupt compressed data "
                              f"({e})") from None
    (flags,) = struct.unpack_from("<I", stream, 0)
    offset = 4
    if version == 4:
        offset = stream.index(b"\0", offset) + 1  # skip the shape's name
    n_vertices, n_triangles = struct.unpack_from("<QQ", stream, offset)
    offset += 16
    real = "<f8" if flags & DOUBLE_PRECISION else "<f4"
    positions, offset = _take(stream, offset, real, 3 * n_vertices, name)
    normals = None
    if flags & HAS_NORMALS:
        normals, offset = _take(stream, offset, real, 3 * n_vertices, name)
        normals = normals.reshape(-1, 3).astype(float)
    texcoords = None
    if flags & HAS_TEXCOORDS:
        texcoords, offset = _take(stream, offset, real, 2 * n_vertices, name)
        texcoords = texcoords.reshape(-1, 2).astype(float)
    if flags & HAS_COLORS:
        _, offset = _take(stream, offset, real, 3 * n_vertices, name)
    index = "<u8" if n_vertices > 0xFFFFFFFF else "<u4"
    faces, offset = _take(stream, offset, index, 3 * n_triangles, name)
    faces = faces.astype(np.int64).reshape(-1, 3)
    if n_triangles == 0:
        raise MeshFormatError(f"{name}: shape {shape_index} has no triangles")
    if faces.max() >= n_vertices:
        raise MeshFormatError(f"{name}: shape {shape_index}: face refers to a vertex that does "
                              "not exist")
    return MeshData(positions.reshape(-1, 3).astype(float), normals, faces, texcoords)


def unit_angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angle between rows of unit vectors, accurate also near 0 and pi
    (``2 asin(|a - b| / 2)`` instead of ``acos(a . b)``)."""
    dot = dot_einsum(a, b)
    near = 2.0 * np.arcsin(np.clip(np.linalg.norm(a - b, axis=1) / 2, 0, 1))
    far = np.pi - 2.0 * np.arcsin(np.clip(np.linalg.norm(a + b, axis=1) / 2, 0, 1))
    return np.where(dot < 0, far, near)


def smooth_vertex_normals(positions: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Mitsuba's rule for meshes without normals (Thuermer & Wuethrich 1998).

    Each non-degenerate face adds its *unit* normal, weighted by the interior
    angle at the corner, to each of its three vertices; the sums are
    normalised. A vertex that receives nothing gets (1, 0, 0), as in Mitsuba.
    """
    p = positions[faces]  # (F, 3, 3)
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    valid = dot_einsum(n, n) > 0
    n = unit(n)
    acc = np.zeros_like(positions)
    for k in range(3):
        e1 = unit(p[:, (k + 1) % 3] - p[:, k])
        e2 = unit(p[:, (k + 2) % 3] - p[:, k])
        w = np.where(valid, unit_angle(e1, e2), 0.0)
        np.add.at(acc, faces[:, k], n * w[:, None])
    length = np.linalg.norm(acc, axis=1)
    out = acc / np.where(length > 0, length, 1.0)[:, None]
    out[length == 0] = (1.0, 0.0, 0.0)
    return out
