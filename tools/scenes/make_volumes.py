"""Write ``smoke-density.vol`` and ``smoke-albedo.vol``, the grids of ``hetero-smoke.xml``.

``smoke-density.vol``: 8 x 6 x 5 cells (x, y, z: unequal, so that a transposed lookup
changes the image), 3 channels: a blob denser towards the bottom, red thinner than
blue, and one empty cell column (x = 1) through which light passes freely. Values are
multiples of 1/64 in [0, 1]. ``smoke-albedo.vol``: 3 x 4 x 2 cells, 1 channel, albedos
from 0.5 to 0.95. Integer arithmetic only: the files are the same on every machine.

Usage: ``python make_volumes.py [folder]``.
"""

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
from pathtracer.io.vol import write_vol

#: Where the built-in scenes live (the default output).
SCENES = Path(__file__).resolve().parents[2] / "pathtracer" / "data" / "scenes"


def density() -> np.ndarray:
    """The (z, y, x, 3) extinction grid (before the medium's scale)."""
    z, y, x = np.mgrid[0:5, 0:6, 0:8]
    blob = 64 - 3 * (x - 5) ** 2 - 2 * (y - 1) ** 2 - 4 * (z - 2) ** 2
    base = np.clip(blob, 0, 64)
    red, green, blue = base // 2, (3 * base) // 4, base
    grid = np.stack([red, green, blue], axis=3)
    grid[:, :, 1] = 0
    return grid / 64.0


def albedo() -> np.ndarray:
    """The (z, y, x) albedo grid."""
    z, y, x = np.mgrid[0:2, 0:4, 0:3]
    return (32 + (5 * x + 3 * y + 7 * z) % 30) / 64.0 + 0.0


def main(folder: Path) -> None:
    """Write both grids to ``folder``."""
    write_vol(str(folder / "smoke-density.vol"), density())
    write_vol(str(folder / "smoke-albedo.vol"), albedo())


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else SCENES)
