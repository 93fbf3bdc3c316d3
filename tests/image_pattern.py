"""The pixel values of the image fixtures in ``tests/data/images``.

``tools/images/make_fixtures.py`` writes them with other programs (Mitsuba 3, the OpenEXR
package, Pillow); ``tests/test_external_images.py`` recomputes them here and compares.
Every channel tells a flip apart: red grows to the right, green towards the bottom, and
blue doubles every two pixels to the right and halves every pixel down, so it also spans
exponents from 2^-5 to 2^3 (the RGBE and half-float cases). No value is zero or negative.
"""
from __future__ import annotations

import numpy as np

#: The fixtures' size: odd and unequal, so that a transpose or a flip shows.
WIDTH, HEIGHT = 7, 5
#: The run-length-encoded RGBE fixture is wider: Radiance encodes scanlines of 8 to 32767 pixels.
WIDE_WIDTH = 40


def pattern(width: int = WIDTH, height: int = HEIGHT) -> np.ndarray:
    """(height, width, 3) float64 radiance, row 0 at the top of the picture."""
    y, x = np.mgrid[0:height, 0:width].astype(np.float64)
    red = 0.05 + 0.9 * x / max(width - 1, 1) + 0.01 * y
    green = 0.02 + 3.0 * (y / max(height - 1, 1)) ** 2 + 0.005 * x
    blue = 0.5 * 2.0 ** ((x % 8) / 2.0 - y)
    return np.stack([red, green, blue], axis=-1)


def variance_pattern(width: int = WIDTH, height: int = HEIGHT) -> np.ndarray:
    """A per-sample variance for the variance fixtures: (0.3 * mean)^2 plus an offset per channel."""
    return (0.3 * pattern(width, height)) ** 2 + np.array([0.01, 0.02, 0.03])


def grey_pattern(width: int = WIDTH, height: int = HEIGHT) -> np.ndarray:
    """(height, width) float64: the grey fixtures' values, the mean of the pattern's channels."""
    return pattern(width, height).mean(axis=-1)
