"""Mitsuba's ``cube``: the box [-1, 1]^3, twelve triangles."""
from __future__ import annotations

import numpy as np

from ..core.vec import unit
from ..scene import transform
from ..scene.properties import Props
from ..scene.registry import register
from .normals import flip_winding, world_normals

# Texture coordinates of Mitsuba's cube, per face (axis, sign): u and v as
# 0.5 + 0.5 * (sign_u * x[axis_u]), 0.5 + 0.5 * (sign_v * x[axis_v]) of the local
# corner x (measured with Mitsuba 3.9.1: SurfaceInteraction3f.uv of cube hits).
_CUBE_UV = {(0, 1.0): ((1, 1.0), (2, -1.0)), (0, -1.0): ((1, 1.0), (2, 1.0)),
            (1, 1.0): ((0, -1.0), (2, -1.0)), (1, -1.0): ((2, 1.0), (0, 1.0)),
            (2, 1.0): ((1, 1.0), (0, 1.0)), (2, -1.0): ((1, -1.0), (0, 1.0))}


def _cube_local():
    """12 triangles of [-1, 1]^3, counter-clockwise seen from outside, the
    outward face normal of each corner and Mitsuba's texture coordinates."""
    tris, normals, uvs = [], [], []
    for axis in range(3):
        for sign in (1.0, -1.0):
            n = np.zeros(3)
            n[axis] = sign
            u = np.zeros(3)
            u[(axis + 1) % 3] = 1.0
            v = np.cross(n, u)  # (u, v, n) right-handed: u x v = n
            quad = [n - u - v, n + u - v, n + u + v, n - u + v]
            tris += [[quad[0], quad[1], quad[2]], [quad[0], quad[2], quad[3]]]
            normals += [[n, n, n]] * 2
            (au, su), (av, sv) = _CUBE_UV[(axis, sign)]
            uv = [[0.5 + 0.5 * su * c[au], 0.5 + 0.5 * sv * c[av]] for c in quad]
            uvs += [[uv[0], uv[1], uv[2]], [uv[0], uv[2], uv[3]]]
    return np.array(tris), np.array(normals), np.array(uvs)


@register("shape", "cube")
def create(props: Props) -> None:
    """A ``cube``: its twelve triangles; ``face_normals`` (false) shades each face flat
    with its geometric normal."""
    shape = props.shape
    m = shape.to_world
    local_p, local_n, uv = _cube_local()
    p = transform.apply_points(m, local_p.reshape(-1, 3)).reshape(-1, 3, 3)
    if props.bool("face_normals", False):
        geo_n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
        n = np.repeat(unit(geo_n)[:, None], 3, axis=1)
    else:
        n = world_normals(props, m, local_n.reshape(-1, 3)).reshape(-1, 3, 3)
    if shape.flip:
        p, n, uv = flip_winding(p, n, uv)
    shape.geometry.add_mesh(props.shape_id, p, n, uv)
