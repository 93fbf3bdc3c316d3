r"""Surface derivatives :math:`\partial p/\partial u`, :math:`\partial p/\partial v` at hits,
and the shading frame Mitsuba builds from them.

Mitsuba 3 orients its shading frame by the texture parameterisation: the tangent
``sh_frame.s`` is :math:`\partial p/\partial u` made orthogonal to the shading normal
(Gram-Schmidt), ``t = n x s``. The tracer's BSDFs work in a frame built from the normal
alone (:func:`pathtracer.core.vec.coordinate_system`); only BSDFs that read the tangent plane
(``normalmap``, ``bumpmap``) need Mitsuba's, and they get it from here, per hit kind as
Mitsuba computes it (``mesh.cpp``, ``sphere.cpp``, ``disk.cpp``, ``cylinder.cpp``):

* meshes (rectangles and cubes included): from the corners' texture coordinates,
  :math:`[\partial p/\partial u, \partial p/\partial v] = [p_1 - p_0, p_2 - p_0]\,
  [uv_1 - uv_0, uv_2 - uv_0]^{-1}`; a degenerate parameterisation falls back to
  :func:`~pathtracer.core.vec.coordinate_system` of the geometric normal;
* spheres: :math:`2\pi\,M(-y, x, 0)` and :math:`\pi\,M(z\cos\phi, z\sin\phi, -\sqrt{x^2+y^2})`
  of the unit-sphere point, :math:`M` the sphere's object-to-world map;
* disks: :math:`M(\cos\phi, \sin\phi, 0)` and :math:`2\pi r\,M(-\sin\phi, \cos\phi, 0)`;
* cylinders: :math:`2\pi\,M(-y, x, 0)` and :math:`M(0, 0, 1)`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.vec import coordinate_system, dot, normalize, to_local


@dataclass
class LocalGeometry:
    """Differential geometry of a batch of hits in the tracer's local shading frame.

    Attributes
    ----------
    n_geo : (m, 3) geometric normal.
    dp_du, dp_dv : (m, 3) surface derivatives.
    tangent : (m, 3) Mitsuba's ``sh_frame.s`` (z = 0 up to rounding).
    dp_du_world : (m, 3) ``dp_du`` in world coordinates (``bumpmap`` reads it as Mitsuba does).
    """

    n_geo: np.ndarray
    dp_du: np.ndarray
    dp_dv: np.ndarray
    tangent: np.ndarray
    dp_du_world: np.ndarray


def local_geometry(scene, hit, rows: np.ndarray) -> LocalGeometry:
    """:class:`LocalGeometry` of the hits ``rows`` (valid hits), in the frame of ``hit.sh_n``."""
    dp_du, dp_dv = surface_derivatives(scene, hit, rows)
    sh_n = hit.sh_n[rows]
    tangent = dp_du - dot(sh_n, dp_du)[:, None] * sh_n
    length = np.linalg.norm(tangent, axis=1)
    fallback = coordinate_system(sh_n)[0]
    with np.errstate(invalid="ignore", divide="ignore"):
        tangent = np.where((length > 0)[:, None], tangent / length[:, None], fallback)
    return LocalGeometry(to_local(hit.n[rows], sh_n), to_local(dp_du, sh_n),
                         to_local(dp_dv, sh_n), to_local(tangent, sh_n), dp_du)


def surface_derivatives(scene, hit, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World-space ``dp_du`` and ``dp_dv`` (m, 3) at the hits ``rows`` (see the module docstring)."""
    rows = np.asarray(rows)
    dp_du, dp_dv = np.zeros((len(rows), 3)), np.zeros((len(rows), 3))
    kind = np.asarray(scene.shape_kind)[hit.shape[rows]] if len(rows) else np.zeros(0, str)
    prim = hit.prim[rows]
    for name, derivatives in (("mesh", _mesh), ("sphere", _sphere), ("disk", _disk),
                              ("cylinder", _cylinder)):
        sel = np.flatnonzero(kind == name)
        if len(sel):
            dp_du[sel], dp_dv[sel] = derivatives(scene, hit, rows[sel], prim[sel])
    return dp_du, dp_dv


def _mesh(scene, hit, rows, tri):
    p, uv = scene.tri_p[tri], scene.tri_uv[tri]
    dp0, dp1 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    duv0, duv1 = uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]
    det = duv0[:, 0] * duv1[:, 1] - duv0[:, 1] * duv1[:, 0]
    valid = np.isfinite(det) & (det != 0.0)
    inv = np.where(valid, 1.0 / np.where(valid, det, 1.0), 0.0)[:, None]
    dp_du = (duv1[:, 1, None] * dp0 - duv0[:, 1, None] * dp1) * inv
    dp_dv = (duv0[:, 0, None] * dp1 - duv1[:, 0, None] * dp0) * inv
    s, t = coordinate_system(hit.n[rows])
    return np.where(valid[:, None], dp_du, s), np.where(valid[:, None], dp_dv, t)


def _sphere(scene, hit, rows, i):
    radius = scene.sphere_radius[i]
    rotation = scene.sphere_to_local[i]               # world -> object (rotation)
    local = np.einsum("kij,kj->ki", rotation, normalize(hit.p[rows] - scene.sphere_center[i]))
    rd = np.hypot(local[:, 0], local[:, 1])
    with np.errstate(invalid="ignore", divide="ignore"):
        cos_phi, sin_phi = local[:, 0] / rd, local[:, 1] / rd
    du = 2.0 * np.pi * np.stack((-local[:, 1], local[:, 0], np.zeros(len(i))), axis=1)
    dv = np.pi * np.stack((local[:, 2] * cos_phi, local[:, 2] * sin_phi, -rd), axis=1)
    dv = np.where((rd == 0.0)[:, None], np.array([np.pi, 0.0, 0.0]), dv)
    to_world = radius[:, None, None] * np.transpose(rotation, (0, 2, 1))
    return np.einsum("kij,kj->ki", to_world, du), np.einsum("kij,kj->ki", to_world, dv)


def _disk(scene, hit, rows, i):
    local = hit.uv[rows]                             # local (x, y) on the unit disk
    r = np.hypot(local[:, 0], local[:, 1])
    with np.errstate(invalid="ignore", divide="ignore"):
        inv_r = np.where(r > 0.0, 1.0 / r, 0.0)
    cos_phi, sin_phi = local[:, 0] * inv_r, local[:, 1] * inv_r
    m = scene.disk_to_world[i][:, :3, :3]
    du = np.einsum("kij,kj->ki", m, np.stack((cos_phi, sin_phi, np.zeros(len(i))), axis=1))
    dv = np.einsum("kij,kj->ki", m, np.stack((-sin_phi, cos_phi, np.zeros(len(i))), axis=1))
    return du, dv * (2.0 * np.pi * r)[:, None]


def _cylinder(scene, hit, rows, i):
    to_local_m, m = scene.cylinder_to_local[i], scene.cylinder_to_world[i]
    local = np.einsum("kij,kj->ki", to_local_m[:, :3, :3], hit.p[rows]) + to_local_m[:, :3, 3]
    du = 2.0 * np.pi * np.stack((-local[:, 1], local[:, 0], np.zeros(len(i))), axis=1)
    return np.einsum("kij,kj->ki", m[:, :3, :3], du), m[:, :3, 2].copy()
