"""Texture coordinates that remember where on a mesh they were taken.

Most textures are functions of ``uv`` alone; Mitsuba's ``mesh_attribute`` reads the
mesh's own per-vertex or per-face data at the hit instead, so it needs the shape, the
triangle and the barycentrics. :func:`pathtracer.shapes.intersect.texture_uv` returns
its ``(n, 2)`` coordinates as a :class:`SurfaceUV`, an ``ndarray`` that carries them:
every texture and BSDF uses it as the plain array it is, and selecting rows
(``uv[rows]``) selects the same rows of what it carries. Any other array derived from
it (arithmetic, a column) carries nothing.
"""
from __future__ import annotations

import numpy as np


class SurfaceUV(np.ndarray):
    """(n, 2) texture coordinates with, per row, ``shape`` (the shape index), ``prim``
    (the triangle index into ``scene.tri_*``, -1 off meshes) and ``bary`` ((n, 2), the
    barycentrics ``b1, b2`` of corners 1 and 2 of that triangle)."""

    def __new__(cls, uv, shape, prim, bary):
        obj = np.asarray(uv, np.float64).view(cls)
        obj.shape_index, obj.prim, obj.bary = shape, prim, bary
        return obj

    def __array_finalize__(self, obj):
        self.shape_index = self.prim = self.bary = None

    @property
    def located(self) -> bool:
        """Whether the rows still know their hits."""
        return self.prim is not None

    def __getitem__(self, key):
        out = super().__getitem__(key)
        if not (isinstance(out, SurfaceUV) and self.located and out.ndim == 2):
            return out.view(np.ndarray) if isinstance(out, SurfaceUV) else out
        rows = key
        if isinstance(key, tuple):
            if len(key) > 2 or (len(key) == 2 and key[1] != slice(None)):
                return out.view(np.ndarray)
            rows = key[0]
        out.shape_index, out.prim, out.bary = self.shape_index[rows], self.prim[rows], self.bary[rows]
        return out
