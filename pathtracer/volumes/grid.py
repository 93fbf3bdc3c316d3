r"""Mitsuba's ``gridvolume``: values on a voxel grid read from a ``.vol`` file.

Lookup (Dr.Jit's texture, which Mitsuba's grid uses): a world point goes to
local coordinates :math:`u \in [0, 1]^3` (``to_world`` inverted, then with
``use_grid_bbox`` the file's box mapped onto the unit cube). With a grid of
:math:`R_x \times R_y \times R_z` cells, cell :math:`i` has its centre at
:math:`(i + \tfrac12) / R`:

- ``nearest``: the cell :math:`\lfloor u R \rfloor`;
- ``trilinear``: :math:`s = u R - \tfrac12`, :math:`i_0 = \lfloor s \rfloor`,
  :math:`w = s - i_0`, and the eight cells :math:`i_0 + \{0, 1\}^3`
  weighted by :math:`\prod_k (w_k \text{ or } 1 - w_k)`.

A cell index outside :math:`[0, R)` is wrapped by ``wrap_mode``: ``clamp``
(to the edge cell), ``repeat`` (modulo :math:`R`) or ``mirror``
(:math:`m = i \bmod 2R`, then :math:`2R - 1 - m` where :math:`m \ge R`). The
wrap matters inside the box too, within half a cell of its faces.

:meth:`GridVolume.max` is the largest stored value over all cells and
channels, or ``max_value`` when given (Mitsuba then trusts it: a heterogeneous
medium uses it as its majorant). One channel reads the same in R, G and B;
three are RGB as stored (Mitsuba's RGB variants do no conversion).
"""
from __future__ import annotations

import numpy as np

from ..io.vol import VolFormatError, read_vol
from ..scene.properties import Props, children, find_file
from ..scene.registry import register
from .base import Volume, invert

FILTERS = ("trilinear", "nearest")
WRAP_MODES = ("clamp", "repeat", "mirror")


def wrap(index: np.ndarray, size: int, mode: str) -> np.ndarray:
    """Integer cell indices wrapped into [0, size) by ``mode`` (Dr.Jit's rules)."""
    if mode == "clamp":
        return np.clip(index, 0, size - 1)
    if mode == "repeat":
        return np.mod(index, size)
    m = np.mod(index, 2 * size)
    return np.where(m >= size, 2 * size - 1 - m, m)


def grid_lookup(data: np.ndarray, u: np.ndarray, filter_type: str = "trilinear",
                wrap_mode: str = "clamp") -> np.ndarray:
    """Values (n, channels) of the grid ``data`` (z, y, x, channels) at local points ``u`` (n, 3).

    ``u`` is (x, y, z) in the unit cube; see the module docstring for the filters.
    """
    res = np.array([data.shape[2], data.shape[1], data.shape[0]])
    if filter_type == "nearest":
        i = np.floor(u * res).astype(np.int64)
        x, y, z = (wrap(i[:, k], res[k], wrap_mode) for k in range(3))
        return data[z, y, x]
    s = u * res - 0.5
    i0 = np.floor(s).astype(np.int64)
    w1 = s - i0
    w0 = 1.0 - w1
    ix = [wrap(i0[:, 0] + b, res[0], wrap_mode) for b in (0, 1)]
    iy = [wrap(i0[:, 1] + b, res[1], wrap_mode) for b in (0, 1)]
    iz = [wrap(i0[:, 2] + b, res[2], wrap_mode) for b in (0, 1)]
    wx, wy, wz = (w0[:, 0], w1[:, 0]), (w0[:, 1], w1[:, 1]), (w0[:, 2], w1[:, 2])
    out = np.zeros((len(u), data.shape[3]))
    for bz in (0, 1):
        for by in (0, 1):
            for bx in (0, 1):
                weight = wx[bx] * wy[by] * wz[bz]
                out += weight[:, None] * data[iz[bz], iy[by], ix[bx]]
    return out


class GridVolume(Volume):
    """A ``.vol`` grid placed by ``to_local`` (world -> unit cube)."""

    def __init__(self, data: np.ndarray, to_local: np.ndarray, filter_type: str = "trilinear",
                 wrap_mode: str = "clamp", max_value: float | None = None):
        super().__init__(to_local)
        if data.shape[3] not in (1, 3):
            raise ValueError(f"a grid of {data.shape[3]} channels gives no colour (1 or 3)")
        self.data = data
        self.filter_type, self.wrap_mode = filter_type, wrap_mode
        self._max = float(data.max()) if max_value is None else float(max_value)

    def eval(self, p: np.ndarray) -> np.ndarray:
        value = grid_lookup(self.data, self.local(p), self.filter_type, self.wrap_mode)
        return np.broadcast_to(value, (len(p), 3)).copy() if value.shape[1] == 1 else value

    def max(self) -> float:
        return self._max

    def is_grey(self) -> bool:
        return self.data.shape[3] == 1 or bool(np.all(self.data == self.data[..., :1]))


@register("volume", "gridvolume")
def create(props: Props) -> GridVolume:
    """``filename`` (a ``.vol`` file), ``filter_type`` (``trilinear``), ``wrap_mode``
    (``clamp``), ``to_world``, ``use_grid_bbox`` (false: the grid fills the unit cube;
    true: the file's box, in ``to_world``'s space), ``max_value`` (the file's maximum),
    ``raw`` (no effect in RGB) and ``accel`` (CUDA texture hardware, no effect here)."""
    plugin = props.plugin
    children(plugin, {})
    path = find_file(plugin, props, "filename", props.folders)
    filter_type = props.string("filter_type", "trilinear")
    if filter_type not in FILTERS:
        raise plugin.error(f"filter_type must be one of {', '.join(FILTERS)}, got "
                           f"{filter_type!r}", props.line("filter_type"))
    wrap_mode = props.string("wrap_mode", "clamp")
    if wrap_mode not in WRAP_MODES:
        raise plugin.error(f"wrap_mode must be one of {', '.join(WRAP_MODES)}, got "
                           f"{wrap_mode!r}", props.line("wrap_mode"))
    to_world = props.transform("to_world")
    use_grid_bbox = props.bool("use_grid_bbox", False)
    max_value = props.float("max_value", None)
    if max_value is not None and not np.isfinite(max_value):
        raise plugin.error("max_value must be finite", props.line("max_value"))
    props.bool("raw", False)
    props.bool("accel", True)
    props.finish()
    try:
        grid = read_vol(path)
    except (OSError, VolFormatError) as exc:
        raise plugin.error(f"cannot read \"{path}\": {exc}", props.line("filename")) from None
    if grid.channels == 6:
        raise plugin.error(f"\"{path}\" has 6 channels (SGGX data): a medium's sigma_t or "
                           "albedo takes 1 or 3", props.line("filename"))
    to_local = invert(plugin, props, to_world)
    if use_grid_bbox:
        lo, hi = grid.bbox
        if not np.all(hi > lo):
            raise plugin.error(f"use_grid_bbox: the box stored in \"{path}\" is empty "
                               f"({lo} .. {hi})", props.line("use_grid_bbox"))
        box = np.diag(np.append(1.0 / (hi - lo), 1.0))
        box[:3, 3] = -lo / (hi - lo)
        to_local = box @ to_local
    return GridVolume(grid.data, to_local, filter_type, wrap_mode, max_value)

