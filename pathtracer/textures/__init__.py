"""Textures: RGB values that vary over a surface, looked up by texture coordinates."""
from .base import ConstantTexture, Texture
from .bitmap import BitmapTexture, wrap_index
from .checkerboard import Checkerboard

__all__ = ["BitmapTexture", "Checkerboard", "ConstantTexture", "Texture", "wrap_index"]
