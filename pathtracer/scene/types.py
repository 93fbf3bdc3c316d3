"""Plain-array description of a loaded scene.

The XML loader (:mod:`pathtracer.scene.build`) produces a :class:`Scene`; the
geometry, BSDF, emitter and integrator modules only read it. Everything a
wavefront needs per primitive lives in flat NumPy arrays so that a batch of
hits can gather its data with one fancy-indexing operation.

Conventions (Mitsuba 3's; tests/test_geometry.py and tests/test_scene_loading.py compare
them with Mitsuba's own intersections and shapes):

* Triangles of every mesh-like shape (``rectangle``, ``cube``, ``obj``,
  ``ply``) are concatenated into one triangle soup. ``tri_p[k]`` holds the
  three world-space vertices of triangle ``k``; the geometric normal is
  ``normalize(cross(p1 - p0, p2 - p0))``. ``tri_n[k]`` holds the three
  world-space shading normals (the face normal three times for flat shading).
* Spheres are analytic (intersected in float64). Disks are analytic planar
  shapes: the unit disk at z = 0 in local space, normal +z.
* ``shape_*`` arrays are indexed by shape id; every primitive knows its shape.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..sensors.perspective_sensor import Camera


@dataclass
class IntegratorSpec:
    """The ``<integrator>`` element: the tracer's integrator that renders it (``light`` for
    a file naming ``ptracer``) and its parameters as parsed."""

    name: str = "path"
    params: dict[str, Any] = field(default_factory=dict)


@dataclass
class Scene:
    """Everything the renderer needs, as flat arrays.

    Attributes
    ----------
    tri_p : (T, 3, 3) float64
        Vertices of every triangle, world space.
    tri_n : (T, 3, 3) float64
        Unit shading normals at the three vertices, world space.
    tri_shape : (T,) int32
        Shape id of each triangle.
    tri_uv : (T, 3, 2) float64 or None
        Texture coordinates at the three vertices (Mitsuba's per shape: the
        file's for meshes, else (0, 0), (1, 0), (0, 1) so that the
        interpolated uv is the barycentrics). None: not known (a scene built
        by hand), textures then see the barycentrics.
    sphere_center : (S, 3) float64
    sphere_radius : (S,) float64
    sphere_flip : (S,) bool
        ``flip_normals``: the normal points inwards.
    sphere_shape : (S,) int32
    sphere_to_local : (S, 3, 3) float64 or None
        Rotation from world axes to each sphere's object frame (for its
        texture coordinates); None: the world axes.
    disk_to_world : (D, 4, 4) float64
    disk_to_local : (D, 4, 4) float64
    disk_flip : (D,) bool
    disk_shape : (D,) int32
    curves : list of pathtracer.shapes.curves.CurveShape
        The ``bsplinecurve`` / ``linearcurve`` shapes.
    sdfgrids : list of pathtracer.shapes.sdfgrid.SDFGridShape
        The ``sdfgrid`` shapes.
    shape_kind : list of str
        ``'mesh'``, ``'sphere'``, ``'disk'``, ``'curve'``, ``'cylinder'`` or ``'sdfgrid'`` per shape.
    shape_prim : (N, 2) int64
        For a mesh, the half-open triangle range ``[begin, end)`` in ``tri_*``;
        for a sphere, disk or curve, ``[index, index + 1)`` in its own arrays.
    shape_bsdf : (N,) int32
        Index into ``bsdfs`` per shape.
    shape_emitter : (N,) int32
        Index into ``emitters`` per shape, -1 if the shape does not emit.
    shape_area : (N,) float64
        Surface area per shape (world space).
    shape_tri_cdf : list
        Per mesh shape, the normalised cumulative area of its triangles
        (for choosing a triangle proportionally to area); None otherwise.
    shape_name : list of str
        Human-readable origin, e.g. ``'rectangle "light" (scene.xml:42)'``.
    shape_attributes : dict
        Mitsuba's mesh attributes of the mesh shapes that have some, by shape index:
        ``{name: array}``, ``vertex_*`` per triangle corner (k, 3, C), ``face_*`` per
        triangle (k, C), rows in the shape's triangle order (see ``mesh_attribute``).
    bsdfs : list
        BSDF objects from :mod:`pathtracer.bsdfs`.
    emitters : list
        The :class:`pathtracer.emitters.base.Emitter` s: area, point, spot, directional,
        constant and envmap lights (one module each in :mod:`pathtracer.emitters`).
    environment : ConstantEmitter, EnvironmentMap or None
        The environment emitter (``constant`` or ``envmap``), if any (at most one is allowed).
    camera : Camera
    spp : int
        ``sample_count`` of the independent sampler.
    seed : int
        ``seed`` of the independent sampler.
    integrator : IntegratorSpec
    source : str
        Path (or built-in name) of the scene file.
    bbox : (2, 3) float64
        World bounding box of all finite geometry.
    media : list
        Participating media (:class:`pathtracer.media.HomogeneousMedium`).
    shape_interior, shape_exterior : (N,) int32 or None
        Index into ``media`` of the medium inside / outside each shape, -1 for
        none (vacuum); None when the scene has no media.
    camera_medium : int
        Index into ``media`` of the medium around the camera, -1 for vacuum.
    volume_elements : dict
        Where the first ``<medium>`` (key ``"medium"``) and the first ``null`` BSDF (key
        ``"null"``) are written: ``(file, line, element)``, for the renderer's refusal of an
        integrator that renders neither (:func:`pathtracer.render.driver.integrator_for`).
    """

    tri_p: np.ndarray
    tri_n: np.ndarray
    tri_shape: np.ndarray
    sphere_center: np.ndarray
    sphere_radius: np.ndarray
    sphere_flip: np.ndarray
    sphere_shape: np.ndarray
    disk_to_world: np.ndarray
    disk_to_local: np.ndarray
    disk_flip: np.ndarray
    disk_shape: np.ndarray
    shape_kind: list
    shape_prim: np.ndarray
    shape_bsdf: np.ndarray
    shape_emitter: np.ndarray
    shape_area: np.ndarray
    shape_tri_cdf: list
    shape_name: list
    bsdfs: list
    emitters: list
    environment: Any
    camera: Camera
    spp: int = 16
    seed: int = 0
    integrator: IntegratorSpec = field(default_factory=IntegratorSpec)
    source: str = "<memory>"
    tri_uv: np.ndarray | None = None
    sphere_to_local: np.ndarray | None = None
    curves: list = field(default_factory=list)
    sdfgrids: list = field(default_factory=list)
    bbox: np.ndarray = field(default_factory=lambda: np.zeros((2, 3)))
    media: list = field(default_factory=list)
    shape_interior: np.ndarray | None = None
    shape_exterior: np.ndarray | None = None
    camera_medium: int = -1
    shape_attributes: dict = field(default_factory=dict)
    volume_elements: dict = field(default_factory=dict)
    # Analytic cylinders (pathtracer.shapes.cylinder): object-to-world maps of the unit tube,
    # their inverses, flip_normals and shape ids.
    cylinder_to_world: np.ndarray = field(default_factory=lambda: np.zeros((0, 4, 4)))
    cylinder_to_local: np.ndarray = field(default_factory=lambda: np.zeros((0, 4, 4)))
    cylinder_flip: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    cylinder_shape: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int32))
    # Built lazily by pathtracer.shapes.intersect (BVH over tri_p).
    _accel: Any = None

    @property
    def num_triangles(self) -> int:
        return int(self.tri_p.shape[0])

    @property
    def num_emitters(self) -> int:
        return len(self.emitters)
