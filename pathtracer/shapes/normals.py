"""Normals of the triangle shapes (rectangle, cube, meshes) as Mitsuba transforms and flips them."""
from __future__ import annotations

import numpy as np

from ..scene import transform
from ..scene.properties import Props


def flip_winding(p: np.ndarray, n: np.ndarray, uv: np.ndarray):
    """Reverse the winding (flips the geometric normal) and negate the
    shading normals: Mitsuba's ``flip_normals`` on meshes. The texture
    coordinates follow their vertices."""
    return p[:, ::-1].copy(), -n[:, ::-1], uv[:, ::-1].copy()


def world_normals(props: Props, m: np.ndarray, n: np.ndarray) -> np.ndarray:
    """Object-space normals to world space as Mitsuba does: by the inverse
    transpose of ``to_world``, or by the matrix it tracks instead after a
    ``<rotate>`` about a non-unit axis."""
    normal_m = props.normal_matrix("to_world")
    if normal_m is None:
        return transform.apply_normals(m, n)
    return transform.apply_normal_matrix(normal_m, n)
