"""Mitsuba's ``sphere``: its ray intersection and the surface data of its hits.

The loader keeps each sphere as its world centre and radius, whether its normals point
inward (``flip_normals``, or a mirroring ``to_world``), its shape id and the rotation to
its object frame (for texture coordinates): the scene's ``sphere_*`` arrays.
"""
from __future__ import annotations

import numpy as np

from ..core.vec import normalize, put_rows, scale, unscale
from ..scene import transform
from ..scene.properties import Props
from ..scene.registry import register


@register("shape", "sphere")
def create(props: Props) -> None:
    """A ``sphere``: ``center`` (0, 0, 0) and ``radius`` (1), moved by a ``to_world`` that
    may only translate, rotate and scale uniformly."""
    plugin, shape = props.plugin, props.shape
    m, flip = shape.to_world, shape.flip
    center = props.point("center", np.zeros(3))
    radius = props.float("radius", 1.0)
    full = m @ transform.translate(center) @ transform.scale([radius] * 3)
    lin = full[:3, :3]
    s2 = np.trace(lin.T @ lin) / 3.0
    if s2 == 0 or not np.allclose(lin.T @ lin, s2 * np.eye(3), rtol=0, atol=1e-6 * s2):
        raise plugin.error("a sphere's to_world may only translate, rotate and scale "
                           "uniformly (non-uniform scale or shear would make an ellipsoid)")
    if np.linalg.det(lin) < 0:
        flip = not flip  # Mitsuba: a mirroring transform turns the sphere inside out
    # Object frame for texture coordinates: the inverse of the rotation (a
    # mirror included) left after dividing out the radius.
    to_local = (lin / np.sqrt(s2)).T
    shape.geometry.add_analytic("sphere", shape.geometry.spheres,
                                (full[:3, 3].copy(), float(np.sqrt(s2)), flip, props.shape_id, to_local),
                                4.0 * np.pi * s2)


def sphere_t(center, radius, o, d, tmax):
    """Nearest root ``0 < t < tmax`` of the ray-sphere quadratic (inf if none).

    Like Mitsuba, the ray origin is first moved to the point of the ray
    closest to the center, which keeps the discriminant accurate for rays
    starting far away or grazing the sphere.
    """
    # Per component: (n, 3) arrays broadcast against (3,) or (n, 1) ones run ~5x slower.
    dx, dy, dz = d[:, 0], d[:, 1], d[:, 2]
    lx, ly, lz = o[:, 0] - center[0], o[:, 1] - center[1], o[:, 2] - center[2]
    dd = dx * dx
    dd += dy * dy
    dd += dz * dz
    t_mid = lx * dx
    t_mid += ly * dy
    t_mid += lz * dz
    t_mid = -t_mid / dd  # parameter of the point closest to the center
    qx, qy, qz = lx + t_mid * dx, ly + t_mid * dy, lz + t_mid * dz
    c = qx * qx
    c += qy * qy
    c += qz * qz
    c -= radius * radius
    disc = -dd * c  # (B/2)^2 - A C, with B = 0 at the closest point
    with np.errstate(invalid="ignore"):
        half = np.sqrt(disc) / dd
    t0, t1 = t_mid - half, t_mid + half
    t = np.where(t0 > 0, t0, t1)
    ok = (disc >= 0) & (t > 0) & (t < tmax)
    return np.where(ok, t, np.inf)


def fill_spheres(scene, hit, sel, o, d):
    """Surface data of the hits ``sel`` on spheres (rays ``o``, ``d`` of those rows)."""
    i = hit.prim[sel]
    c, r = scene.sphere_center[i], scene.sphere_radius[i]
    # Reproject onto the sphere (Mitsuba: p = c + r * normalize(ray(t) - c)).
    nrm = normalize(o + hit.t[sel, None] * d - c)
    p = c + scale(nrm, r)
    put_rows(hit.p, sel, p)
    local = unscale(p - c, r)
    nrm = scale(nrm, np.where(scene.sphere_flip[i], -1.0, 1.0))
    put_rows(hit.n, sel, nrm)
    put_rows(hit.sh_n, sel, nrm)
    hit.shape[sel] = scene.sphere_shape[i]
    phi = np.arctan2(local[:, 1], local[:, 0])
    phi = np.where(phi < 0, phi + 2 * np.pi, phi)
    hit.uv[sel, 0] = phi / (2 * np.pi)
    hit.uv[sel, 1] = np.arccos(np.clip(local[:, 2], -1.0, 1.0)) / np.pi
