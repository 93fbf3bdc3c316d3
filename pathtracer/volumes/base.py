r"""What every volume is: values over space in a box, Mitsuba's ``Volume``.

A volume maps a world-space point to an RGB value through ``to_world``:
its *local* coordinates are :math:`x_\text{local} = \text{to\_world}^{-1}\,x`,
and its domain is the unit cube :math:`[0, 1]^3` in local coordinates. The
world-space box around that cube (:attr:`Volume.bbox`) is where a
heterogeneous medium has any density: Mitsuba samples collisions only inside
it, whatever the shapes that bound the medium.
"""
from __future__ import annotations

import numpy as np

from ..scene.properties import Props, registered
from ..scene.xml import Plugin

#: The corners of the unit cube.
_CORNERS = np.array([[x, y, z] for x in (0.0, 1.0) for y in (0.0, 1.0) for z in (0.0, 1.0)])


class Volume:
    """Base of the volumes: ``to_local``, the world box, :meth:`eval` and :meth:`max`.

    Attributes
    ----------
    to_local : (4, 4) world -> local affine matrix (``to_world`` inverted).
    bbox : (2, 3) world-space box (min, max) around the local unit cube.
    """

    def __init__(self, to_local: np.ndarray):
        self.to_local = np.asarray(to_local, dtype=np.float64)
        to_world = np.linalg.inv(self.to_local)
        corners = _CORNERS @ to_world[:3, :3].T + to_world[:3, 3]
        self.bbox = np.stack((corners.min(0), corners.max(0)))

    def local(self, p: np.ndarray) -> np.ndarray:
        """Local coordinates (n, 3) of world points ``p`` (n, 3)."""
        return p @ self.to_local[:3, :3].T + self.to_local[:3, 3]

    def eval(self, p: np.ndarray) -> np.ndarray:
        """RGB values (n, 3) at world points ``p`` (n, 3)."""
        raise NotImplementedError

    def max(self) -> float:
        """The largest value over every voxel and channel (Mitsuba's ``Volume::max``)."""
        raise NotImplementedError

    def is_grey(self) -> bool:
        """Every value has equal channels."""
        raise NotImplementedError


def build_volume(plugin: Plugin, folders: list[str]) -> Volume:
    """The :class:`Volume` of a ``<volume>`` element (files looked up in ``folders``)."""
    create = registered(plugin, "volume")
    return create(Props(plugin, folders=folders))


def box_interval(bbox: np.ndarray, o: np.ndarray, d: np.ndarray):
    """Where rays ``o + t d`` (n, 3) cross the box ``bbox`` (2, 3): Mitsuba's
    ``BoundingBox::ray_intersect`` -> (hit (n,) bool, mint (n,), maxt (n,)).

    ``mint``/``maxt`` are the entry and exit parameters of the whole line (mint may be
    negative, for an origin inside); a direction parallel to a slab counts as inside it
    when the origin lies between its planes.
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / d
        t1 = (bbox[0] - o) * inv
        t2 = (bbox[1] - o) * inv
    parallel = d == 0
    inside = (o >= bbox[0]) & (o <= bbox[1])
    lo = np.where(parallel, np.where(inside, -np.inf, np.inf), np.minimum(t1, t2))
    hi = np.where(parallel, np.where(inside, np.inf, -np.inf), np.maximum(t1, t2))
    mint, maxt = lo.max(axis=1), hi.min(axis=1)
    return maxt >= mint, mint, maxt


def invert(plugin: Plugin, props: Props, to_world: np.ndarray) -> np.ndarray:
    """``to_world`` inverted, or the error naming it when it is singular."""
    if abs(np.linalg.det(to_world[:3, :3])) < 1e-300:
        raise plugin.error("to_world is singular (a zero scale?)", props.line_of("to_world")
                           if props.has("to_world") else None)
    return np.linalg.inv(to_world)
