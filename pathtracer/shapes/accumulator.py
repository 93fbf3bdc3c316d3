"""The primitives of every shape, gathered while a scene is loaded, before they become
the scene's arrays."""
from __future__ import annotations

import numpy as np

from ..scene.xml import Plugin


class _Geometry:
    """Accumulates primitives of all shapes before they become arrays."""

    def __init__(self):
        self.tri_p, self.tri_n, self.tri_uv, self.tri_shape = [], [], [], []
        self.ntri = 0
        self.spheres, self.disks, self.curves, self.cylinders = [], [], [], []
        self.kind, self.prim, self.area, self.cdf, self.name = [], [], [], [], []

    def add_mesh(self, shape_id: int, p: np.ndarray, n: np.ndarray, uv: np.ndarray) -> None:
        """Add a mesh shape: (k, 3, 3) vertices, normals and (k, 3, 2) texture coordinates."""
        areas = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
        total = areas.sum()
        cdf = np.cumsum(areas) / total if total > 0 else np.arange(1, len(p) + 1) / len(p)
        cdf[-1] = 1.0
        self.tri_p.append(p)
        self.tri_n.append(n)
        self.tri_uv.append(uv)
        self.tri_shape.append(np.full(len(p), shape_id, dtype=np.int32))
        self.kind.append("mesh")
        self.prim.append((self.ntri, self.ntri + len(p)))
        self.area.append(total)
        self.cdf.append(cdf)
        self.ntri += len(p)

    def add_analytic(self, kind: str, table: list, entry, area: float) -> None:
        """Add one analytic shape (sphere, disk, curve, cylinder): ``entry`` goes into its
        ``table`` (e.g. ``self.spheres``); its primitive range is that one row."""
        table.append(entry)
        self.kind.append(kind)
        self.prim.append((len(table) - 1, len(table)))
        self.area.append(area)
        self.cdf.append(None)


def _shape_label(plugin: Plugin) -> str:
    ident = f' "{plugin.id}"' if plugin.id else ""
    return f"{plugin.type}{ident} ({plugin.file}:{plugin.line})"


def _bbox(geo: _Geometry, tri_p: np.ndarray) -> np.ndarray:
    lo, hi = [], []
    if len(tri_p):
        lo.append(tri_p.reshape(-1, 3).min(0))
        hi.append(tri_p.reshape(-1, 3).max(0))
    for c, r, *_ in geo.spheres:
        lo.append(c - r)
        hi.append(c + r)
    for m, _, _ in geo.disks:
        extent = np.sqrt(m[:3, 0] ** 2 + m[:3, 1] ** 2)
        lo.append(m[:3, 3] - extent)
        hi.append(m[:3, 3] + extent)
    for curve in geo.curves:
        curve_lo, curve_hi = curve.bounds()
        lo.append(curve_lo)
        hi.append(curve_hi)
    for m, _, _ in geo.cylinders:
        corners = np.array([[x, y, z, 1.0] for x in (-1, 1) for y in (-1, 1) for z in (0, 1)])
        world = corners @ m.T
        lo.append(world[:, :3].min(0))
        hi.append(world[:, :3].max(0))
    if not lo:
        return np.zeros((2, 3))
    return np.array([np.min(lo, axis=0), np.max(hi, axis=0)])
