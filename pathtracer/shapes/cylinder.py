r"""Mitsuba's analytic ``cylinder`` shape: intersection and surface data of its hits.

In its object frame the cylinder is the open tube :math:`x^2 + y^2 = 1`,
:math:`0 \le z \le 1` (no caps). The loader composes Mitsuba's object-to-world map
``to_world @ translate(p0) @ frame(p1 - p0) @ scale(radius, radius, |p1 - p0|)``, where
``frame(d)`` is Mitsuba's ``Frame3f(d)`` (:func:`pathtracer.core.vec.coordinate_system`
convention) taking local z to ``d``.

As in Mitsuba (``cylinder.cpp``), a ray is mapped to the object frame and the quadratic
:math:`A t^2 + B t + C = 0` of :math:`x^2 + y^2 = 1` solved; the nearer root counts
when it lies in :math:`[0, t_{max}]` with :math:`0 \le z \le 1`, else the farther one;
a ray whose segment stays inside the infinite tube misses. The hit point is moved
onto the surface, the normal is :math:`\partial p/\partial u \times \partial p/\partial v`
(outward; inward with ``flip_normals``), and the texture coordinates are
:math:`(\phi / 2\pi, z)` with :math:`\phi` in :math:`[0, 2\pi)` around the local z axis.
"""
from __future__ import annotations

import numpy as np

from ..core.vec import coordinate_system, normalize
from ..scene import transform
from ..scene.properties import Props
from ..scene.registry import register


def local_rays(to_local: np.ndarray, o: np.ndarray, d: np.ndarray):
    """Ray origins and directions (n, 3) in a (4, 4) affine ``to_local`` frame."""
    return o @ to_local[:3, :3].T + to_local[:3, 3], d @ to_local[:3, :3].T


def cylinder_t(to_local: np.ndarray, o: np.ndarray, d: np.ndarray, tmax) -> np.ndarray:
    """Ray parameter (n,) of the first hit with the unit tube in ``0 <= t <= tmax``, inf if none.

    ``t`` is the world ray's parameter (an affine map keeps it).
    """
    ol, dl = local_rays(to_local, o, d)
    a = dl[:, 0] ** 2 + dl[:, 1] ** 2
    b = 2.0 * (dl[:, 0] * ol[:, 0] + dl[:, 1] * ol[:, 1])
    c = ol[:, 0] ** 2 + ol[:, 1] ** 2 - 1.0
    with np.errstate(divide="ignore", invalid="ignore"):
        disc = b * b - 4.0 * a * c
        root = np.sqrt(disc)
        # The numerically stable pair of roots (as Mitsuba's solve_quadratic).
        q = np.where(b < 0.0, -0.5 * (b - root), -0.5 * (b + root))
        t0, t1 = q / a, c / q
    near, far = np.minimum(t0, t1), np.maximum(t0, t1)
    found = (a != 0.0) & (disc >= 0.0)
    z_near, z_far = ol[:, 2] + dl[:, 2] * near, ol[:, 2] + dl[:, 2] * far
    near_ok = (z_near >= 0.0) & (z_near <= 1.0) & (near >= 0.0)
    far_ok = (z_far >= 0.0) & (z_far <= 1.0) & (far <= tmax)
    outside = ~((near <= tmax) & (far >= 0.0))
    inside = (near < 0.0) & (far > tmax)
    hit = found & ~outside & ~inside & (near_ok | far_ok)
    t = np.where(near_ok, near, far)
    return np.where(hit & (t < tmax), t, np.inf)


def cylinder_surface(to_world: np.ndarray, to_local: np.ndarray, flip: np.ndarray,
                     p: np.ndarray):
    """Surface data at points ``p`` (n, 3) found by :func:`cylinder_t`.

    Parameters
    ----------
    to_world, to_local : (n, 4, 4) each hit's cylinder frame and its inverse.
    flip : (n,) bool, ``flip_normals`` (after a mirroring ``to_world``).

    Returns
    -------
    p : (n, 3) the point moved onto the tube; n : (n, 3) unit normal;
    uv : (n, 2) ``(phi / 2pi, z)``.
    """
    local = np.einsum("kij,kj->ki", to_local[:, :3, :3], p) + to_local[:, :3, 3]
    radius = np.hypot(local[:, 0], local[:, 1])
    on_tube = np.stack((local[:, 0] / radius, local[:, 1] / radius, local[:, 2]), axis=1)
    p = np.einsum("kij,kj->ki", to_world[:, :3, :3], on_tube) + to_world[:, :3, 3]
    phi = np.arctan2(local[:, 1], local[:, 0])
    phi = np.where(phi < 0.0, phi + 2.0 * np.pi, phi)
    dp_du = np.einsum("kij,kj->ki", to_world[:, :3, :3],
                      np.stack((-on_tube[:, 1], on_tube[:, 0], np.zeros(len(p))), axis=1))
    dp_dv = to_world[:, :3, 2]
    n = normalize(np.cross(dp_du, dp_dv))
    n = np.where(flip[:, None], -n, n)
    return p, n, np.stack((phi / (2.0 * np.pi), local[:, 2]), axis=1)


def cylinder_matrix(to_world: np.ndarray, p0, p1, radius: float) -> np.ndarray:
    """Mitsuba's object-to-world map of a cylinder from ``p0`` to ``p1`` of ``radius``."""
    axis = np.asarray(p1, np.float64) - np.asarray(p0, np.float64)
    length = float(np.linalg.norm(axis))
    z = axis / length
    s, t = (v[0] for v in coordinate_system(z[None]))
    frame = np.eye(4)
    frame[:3, 0], frame[:3, 1], frame[:3, 2] = s, t, z
    move = np.eye(4)
    move[:3, 3] = p0
    return to_world @ move @ frame @ np.diag([radius, radius, length, 1.0])


def fill_cylinders(scene, hit, sel, o, d):
    """Surface data of the hits ``sel`` on cylinders (rays ``o``, ``d`` of those rows)."""
    i = hit.prim[sel]
    p, n, uv = cylinder_surface(scene.cylinder_to_world[i], scene.cylinder_to_local[i],
                                scene.cylinder_flip[i], o + hit.t[sel, None] * d)
    hit.p[sel], hit.n[sel], hit.sh_n[sel] = p, n, n
    hit.uv[sel] = uv
    hit.shape[sel] = scene.cylinder_shape[i]


@register("shape", "cylinder")
def create(props: Props) -> None:
    """Mitsuba's analytic ``cylinder``: ``p0`` (0, 0, 0), ``p1`` (0, 0, 1), ``radius`` (1),
    open at both ends."""
    plugin, shape = props.plugin, props.shape
    m = shape.to_world
    if shape.emitter is not None:
        raise shape.emitter.error("an area emitter on a cylinder is not supported (this tracer "
                                  "samples area lights on meshes, spheres and disks only)")
    p0, p1 = props.point("p0", np.zeros(3)), props.point("p1", np.array([0.0, 0.0, 1.0]))
    radius = props.float("radius", 1.0)
    if not radius > 0 or not np.linalg.norm(p1 - p0) > 0:
        raise plugin.error("a cylinder needs radius > 0 and p0 != p1")
    transform.check_affine(m)
    full = cylinder_matrix(m, p0, p1, radius)
    if np.linalg.det(full[:3, :3]) <= 0:
        raise plugin.error("a mirroring to_world is not supported on a cylinder (Mitsuba flips "
                           "its normals by a rule this tracer does not reproduce)",
                           props.line("to_world"))
    # Mitsuba: 2 pi r l, r and l the lengths of the images of local x and z.
    shape.geometry.add_analytic("cylinder", shape.geometry.cylinders, (full, shape.flip, props.shape_id),
                                2.0 * np.pi * np.linalg.norm(full[:3, 0]) * np.linalg.norm(full[:3, 2]))
