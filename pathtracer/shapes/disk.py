"""Mitsuba's ``disk``: the unit disk of the local z = 0 plane, its ray intersection and the
surface data of its hits."""
from __future__ import annotations

import numpy as np

from ..core.vec import dot, normalize, put_rows, scale
from ..scene import transform
from ..scene.properties import Props
from ..scene.registry import register


@register("shape", "disk")
def create(props: Props) -> None:
    """A ``disk`` (no properties of its own): the unit disk moved by an affine ``to_world``."""
    plugin, shape = props.plugin, props.shape
    m = shape.to_world
    transform.check_affine(m)
    if props.normal_matrix("to_world") is not None:
        raise plugin.error("a disk rotated about a non-unit axis is not supported (Mitsuba "
                           "then transforms its normal inconsistently with its surface)",
                           props.line("to_world"))
    # The unit disk maps to an ellipse of area pi |u x v| (u, v = images of x, y).
    shape.geometry.add_analytic("disk", shape.geometry.disks, (m, shape.flip, props.shape_id),
                                np.pi * np.linalg.norm(np.cross(m[:3, 0], m[:3, 1])))


def disk_t(to_local, o, d, tmax):
    """Ray parameter where rays meet the unit disk z = 0 of a local frame (inf if not)."""
    m, shift = to_local[:3, :3], to_local[:3, 3]

    def local(v, k, offset=0.0):   # component k of v in the disk's frame, per column
        return v[:, 0] * m[k, 0] + v[:, 1] * m[k, 1] + v[:, 2] * m[k, 2] + offset

    with np.errstate(divide="ignore", invalid="ignore"):
        t = -local(o, 2, shift[2]) / local(d, 2)
        x = local(o, 0, shift[0]) + t * local(d, 0)
        y = local(o, 1, shift[1]) + t * local(d, 1)
        ok = (t > 0) & (t < tmax) & (x * x + y * y <= 1.0)
    return np.where(ok, t, np.inf)


def fill_disks(scene, hit, sel, o, d):
    """Surface data of the hits ``sel`` on disks (rays ``o``, ``d`` of those rows)."""
    i = hit.prim[sel]
    to_world, to_local = scene.disk_to_world[i], scene.disk_to_local[i]
    # Normal transform = inverse transpose: row 2 of to_local's linear part.
    nrm = normalize(to_local[:, 2, :3])
    p = o + hit.t[sel, None] * d
    # Reproject onto the plane through the disk center (as Mitsuba does).
    center = to_world[:, :3, 3]
    p = p + scale(nrm, dot(center - p, nrm))
    put_rows(hit.p, sel, p)
    local = np.einsum("kij,kj->ki", to_local[:, :3, :3], p) + to_local[:, :3, 3]
    put_rows(hit.uv, sel, local[:, :2])
    nrm = scale(nrm, np.where(scene.disk_flip[i], -1.0, 1.0))
    put_rows(hit.n, sel, nrm)
    put_rows(hit.sh_n, sel, nrm)
    hit.shape[sel] = scene.disk_shape[i]
