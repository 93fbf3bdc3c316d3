"""Triangle meshes read from files: Mitsuba's ``obj``, ``ply`` and ``serialized`` shapes."""
from __future__ import annotations

import os

import numpy as np

from ..core.vec import unit
from ..io import meshes
from ..scene import transform
from ..scene.properties import Props, find_file
from ..scene.registry import register
from ..scene.xml import Plugin
from .normals import flip_winding, world_normals

_BARYCENTRIC_UV = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])


@register("shape", "obj", "ply", "serialized")
def create(props: Props) -> None:
    """An ``obj``, ``ply`` or ``serialized`` mesh: ``filename``, ``face_normals`` (false),
    ``flip_tex_coords`` (true for obj files, false for ply; not for serialized) and the
    serialized file's ``shape_index`` (0)."""
    shape = props.shape
    p, n, uv, attributes = _mesh_triangles(props.plugin, props, props.folders, shape.to_world)
    if shape.flip:
        p, n, uv = flip_winding(p, n, uv)
        # Vertex attributes follow their corners, as the texture coordinates do.
        attributes = {k: (v[:, ::-1].copy() if v.ndim == 3 else v) for k, v in attributes.items()}
    shape.geometry.add_mesh(props.shape_id, p, n, uv, attributes)


def _load_mesh(plugin: Plugin, props: Props, folders: list[str]) -> meshes.MeshData:
    """The file's mesh (format by the shape's type), its errors located at ``filename``."""
    path = find_file(plugin, props, "filename", folders)
    try:
        if plugin.type == "obj":
            return meshes.read_obj(path)
        if plugin.type == "ply":
            return meshes.read_ply(path)
        index = props.int("shape_index", 0)
        return meshes.read_serialized(path, index)
    except meshes.MeshFormatError as e:
        raise plugin.error(str(e), props.line("filename")) from None
    except OSError as e:
        raise plugin.error(f"cannot read mesh file \"{os.path.basename(path)}\": "
                           f"{e.strerror or e}", props.line("filename")) from None


def _mesh_triangles(plugin, props, folders, m):
    """World-space triangles, shading normals, texture coordinates and mesh attributes of an
    obj/ply/serialized shape (vertex attributes per corner (k, 3, C), face ones (k, C))."""
    data = _load_mesh(plugin, props, folders)
    face_normals = props.bool("face_normals", False)
    # Mitsuba flips v (v -> 1 - v) by default for OBJ files only; its serialized
    # shape has no flip_tex_coords parameter (never flips).
    flip_v = plugin.type != "serialized" and props.bool("flip_tex_coords", plugin.type == "obj")
    pos = transform.apply_points(m, data.positions)
    p = pos[data.faces]
    if data.texcoords is None:
        # Without stored coordinates Mitsuba's uv is the barycentrics (b1, b2).
        uv = np.broadcast_to(_BARYCENTRIC_UV, (len(p), 3, 2)).copy()
    else:
        uv = data.texcoords[data.faces]
        if flip_v:
            uv[:, :, 1] = 1.0 - uv[:, :, 1]
    if face_normals:
        geo = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
        n = np.repeat(unit(geo)[:, None], 3, axis=1)
    elif data.normals is not None:
        n = world_normals(props, m, data.normals)[data.faces]
    else:
        # Mitsuba recomputes after applying to_world, so angles are world angles.
        n = meshes.smooth_vertex_normals(pos, data.faces)[data.faces]
    attributes = {name: (values[data.faces] if name.startswith("vertex_") else values)
                  for name, values in data.attributes.items()}
    return p, n, uv, attributes
