"""Volumes: values (extinction, albedo) that vary over space, for heterogeneous media.

Each plugin module registers the factory that builds it from a ``<volume>`` element when it
is imported here: ``constvolume`` (one value) and ``gridvolume`` (a ``.vol`` voxel grid,
trilinear or nearest).
"""
from . import const, grid  # noqa: F401  (imported so that each registers its plugin)
from .base import Volume, build_volume
from .const import ConstVolume
from .grid import GridVolume, grid_lookup

__all__ = ["ConstVolume", "GridVolume", "Volume", "build_volume", "grid_lookup"]
