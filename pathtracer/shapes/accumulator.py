"""What a shape's factory is given, and the primitives of every shape gathered while a
scene loads, before they become the scene's arrays.

Each shape kind's module registers a factory, ``create(props)``, with
``@register("shape", "<mitsuba name>")`` (:mod:`pathtracer.scene.registry`). The
loader reads what every shape has (``to_world``, ``flip_normals``, the nested BSDF,
emitter and media) into the :class:`ShapeParams` at ``props.shape``; the factory reads
the kind's own properties from ``props`` and adds its primitives to
``props.shape.geometry``, a :class:`GeometryAccumulator`, under ``props.shape_id``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..scene.xml import Plugin


@dataclass
class ShapeParams:
    """What the loader reads of every shape before the kind's own properties, and where the
    shape's primitives go (``props.shape`` of a shape's factory).

    Attributes
    ----------
    to_world : (4, 4) ndarray
        The shape's ``to_world``, after the ``instance``'s that draws it (if any).
    flip : bool
        ``flip_normals``.
    emitter : Plugin or None
        The nested area emitter (the kinds that cannot be sampled refuse one).
    geometry : GeometryAccumulator
        The primitives of the scene's shapes, which the factory adds to.
    """

    to_world: np.ndarray
    flip: bool
    emitter: Plugin | None
    geometry: GeometryAccumulator


class GeometryAccumulator:
    """The primitives of all shapes, per kind, before they become the scene's arrays
    (:meth:`scene_fields`).

    Triangles of every mesh shape go into ``tri_*`` (:meth:`add_mesh`); each analytic
    shape is one row of its kind's table (:meth:`add_analytic`): ``spheres`` (centre,
    radius, flip, shape id, rotation to the object frame), ``disks`` and ``cylinders``
    (object-to-world map, flip, shape id), ``curves`` (:class:`~.curves.CurveShape`),
    ``sdfgrids`` (:class:`~.sdfgrid.SDFGridShape`).
    Per shape: ``kind``, its primitive range ``prim``, ``area``, the triangle ``cdf``
    of a mesh (None otherwise) and ``name``.
    """

    def __init__(self):
        self.tri_p, self.tri_n, self.tri_uv, self.tri_shape = [], [], [], []
        self.ntri = 0
        self.spheres, self.disks, self.curves, self.cylinders = [], [], [], []
        self.sdfgrids = []
        self.kind, self.prim, self.area, self.cdf, self.name = [], [], [], [], []
        self.attributes: dict[int, dict] = {}

    def add_mesh(self, shape_id: int, p: np.ndarray, n: np.ndarray, uv: np.ndarray,
                 attributes: dict | None = None) -> None:
        """Add a mesh shape: (k, 3, 3) vertices, normals and (k, 3, 2) texture coordinates;
        its mesh attributes (``vertex_*``: (k, 3, C) per corner, ``face_*``: (k, C)), if any."""
        if attributes:
            self.attributes[shape_id] = attributes
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

    def scene_fields(self) -> dict:
        """The :class:`~pathtracer.scene.types.Scene` fields of the shapes: each kind's
        arrays, the per-shape tables and the bounding box."""
        tri_p = np.concatenate(self.tri_p) if self.tri_p else np.zeros((0, 3, 3))
        tri_n = np.concatenate(self.tri_n) if self.tri_n else np.zeros((0, 3, 3))
        tri_uv = np.concatenate(self.tri_uv) if self.tri_uv else np.zeros((0, 3, 2))
        tri_shape = np.concatenate(self.tri_shape) if self.tri_shape else np.zeros(0, np.int32)
        sph, dsk, cyl = self.spheres, self.disks, self.cylinders
        return dict(
            tri_p=tri_p, tri_n=tri_n, tri_shape=tri_shape, tri_uv=tri_uv,
            sphere_center=np.array([s[0] for s in sph]).reshape(-1, 3),
            sphere_radius=np.array([s[1] for s in sph], dtype=float),
            sphere_flip=np.array([s[2] for s in sph], dtype=bool),
            sphere_shape=np.array([s[3] for s in sph], dtype=np.int32),
            sphere_to_local=np.array([s[4] for s in sph]).reshape(-1, 3, 3),
            disk_to_world=np.array([d[0] for d in dsk]).reshape(-1, 4, 4),
            disk_to_local=np.array([np.linalg.inv(d[0]) for d in dsk]).reshape(-1, 4, 4),
            disk_flip=np.array([d[1] for d in dsk], dtype=bool),
            disk_shape=np.array([d[2] for d in dsk], dtype=np.int32),
            curves=self.curves, sdfgrids=self.sdfgrids,
            cylinder_to_world=np.array([c[0] for c in cyl]).reshape(-1, 4, 4),
            cylinder_to_local=np.array([np.linalg.inv(c[0]) for c in cyl]).reshape(-1, 4, 4),
            cylinder_flip=np.array([c[1] for c in cyl], dtype=bool),
            cylinder_shape=np.array([c[2] for c in cyl], dtype=np.int32),
            shape_kind=self.kind,
            shape_prim=np.array(self.prim, dtype=np.int64).reshape(-1, 2),
            shape_area=np.array(self.area, dtype=float),
            shape_tri_cdf=self.cdf, shape_name=self.name, shape_attributes=self.attributes,
            bbox=self._bounds(tri_p))

    def _bounds(self, tri_p: np.ndarray) -> np.ndarray:
        """(2, 3) world bounding box (lo, hi) of every primitive; ``tri_p`` the triangles
        concatenated."""
        lo, hi = [], []
        if len(tri_p):
            lo.append(tri_p.reshape(-1, 3).min(0))
            hi.append(tri_p.reshape(-1, 3).max(0))
        for c, r, *_ in self.spheres:
            lo.append(c - r)
            hi.append(c + r)
        for m, _, _ in self.disks:
            extent = np.sqrt(m[:3, 0] ** 2 + m[:3, 1] ** 2)
            lo.append(m[:3, 3] - extent)
            hi.append(m[:3, 3] + extent)
        for tree in self.curves + self.sdfgrids:     # the shapes with a tree of their own
            tree_lo, tree_hi = tree.bounds()
            lo.append(tree_lo)
            hi.append(tree_hi)
        for m, _, _ in self.cylinders:
            corners = np.array([[x, y, z, 1.0] for x in (-1, 1) for y in (-1, 1) for z in (0, 1)])
            world = corners @ m.T
            lo.append(world[:, :3].min(0))
            hi.append(world[:, :3].max(0))
        if not lo:
            return np.zeros((2, 3))
        return np.array([np.min(lo, axis=0), np.max(hi, axis=0)])


def shape_label(plugin: Plugin) -> str:
    """How a shape is named in the scene's ``shape_name``: type, id and where it is defined."""
    ident = f' "{plugin.id}"' if plugin.id else ""
    return f"{plugin.type}{ident} ({plugin.file}:{plugin.line})"
