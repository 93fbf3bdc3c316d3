"""Mitsuba's ``rectangle``: the square [-1, 1]^2 of the local z = 0 plane, two triangles."""
from __future__ import annotations

import numpy as np

from ..scene import transform
from ..scene.properties import Props
from ..scene.registry import register
from .normals import flip_winding, world_normals

_RECT_LOCAL = np.array([[[-1, -1, 0], [1, -1, 0], [1, 1, 0]],
                        [[-1, -1, 0], [1, 1, 0], [-1, 1, 0]]], dtype=float)


@register("shape", "rectangle")
def create(props: Props) -> None:
    """A ``rectangle`` (no properties of its own): its two triangles."""
    shape = props.shape
    p, n, uv = _planar_mesh(_RECT_LOCAL, np.array([0.0, 0.0, 1.0]), shape.to_world, shape.flip,
                            props)
    shape.geometry.add_mesh(props.shape_id, p, n, uv)


def _planar_mesh(corners_local, normal_local, m, flip, props):
    """Triangles of a flat shape whose normal is the transformed local normal
    (Mitsuba's rectangle: normal by the inverse transpose, even when ``m``
    mirrors; the winding follows the true geometric normal). Texture
    coordinates: Mitsuba's rectangle maps local (x, y) in [-1, 1]^2 to
    ((x + 1) / 2, (y + 1) / 2)."""
    p = transform.apply_points(m, corners_local.reshape(-1, 3)).reshape(-1, 3, 3)
    uv = 0.5 * (corners_local[:, :, :2] + 1.0)
    n = world_normals(props, m, normal_local[None])[0]
    geo = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    if np.dot(geo[0], n) < 0:
        p, uv = p[:, ::-1].copy(), uv[:, ::-1].copy()
    nn = np.broadcast_to(n, p.shape).copy()
    return flip_winding(p, nn, uv) if flip else (p, nn, uv)
