"""Textures: RGB values that vary over a surface, looked up by texture coordinates.

Each plugin module registers the factory that builds it from a ``<texture>`` element when
it is imported here (in this order: the loader's "supported" list names them so).
"""
from . import bitmap, checkerboard, constant, mesh_attribute  # noqa: F401  (imported so that each registers its plugin)
from .base import ConstantTexture, Texture
from .bitmap import BitmapTexture, wrap_index
from .checkerboard import Checkerboard
from .mesh_attribute import MeshAttribute

__all__ = ["BitmapTexture", "Checkerboard", "ConstantTexture", "MeshAttribute", "Texture", "wrap_index"]
