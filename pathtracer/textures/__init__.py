"""Textures: RGB values that vary over a surface, looked up by texture coordinates."""
from .base import BitmapTexture, Checkerboard, ConstantTexture, Texture, wrap_index

__all__ = ["BitmapTexture", "Checkerboard", "ConstantTexture", "Texture", "wrap_index"]
