"""Write ``textured-grid.png``, the 8-bit image of ``textured.xml``.

A 12 x 8 RGB image, small enough that its texels are visible in a 32 x 32
render: red rises to the right, green downwards, and blue marks a checker of
2 x 2 texel blocks; the top-left texel is black and the top row is darker
than the rest, so a flipped or transposed lookup changes the image. Integer
arithmetic only: the file is the same on every machine.

Usage: ``python make_texture.py [output.png]``.
"""

import sys
from pathlib import Path

import numpy as np
from PIL import Image

#: Where the built-in scenes live (the default output).
SCENES = Path(__file__).resolve().parents[2] / "pathtracer" / "data" / "scenes"

WIDTH, HEIGHT = 12, 8


def texels() -> np.ndarray:
    """The (HEIGHT, WIDTH, 3) uint8 image."""
    y, x = np.mgrid[0:HEIGHT, 0:WIDTH]
    red = 20 * x + 15
    green = 30 * y + 20
    blue = np.where((x // 2 + y // 2) % 2 == 0, 220, 40)
    image = np.stack([red, green, blue], axis=2)
    image[0] //= 3
    image[0, 0] = 0
    return image.astype(np.uint8)


def main(path: str) -> None:
    """Write the grid texture PNG to ``path``."""
    Image.fromarray(texels()).save(path, optimize=False)


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else str(SCENES / "textured-grid.png"))
