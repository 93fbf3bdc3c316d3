"""Mitsuba's binary ``.vol`` grid format (version 3, float32), read and written.

The layout (little endian), as Mitsuba 0.6 and 3 define it:

=========  ==============================================================
bytes      content
=========  ==============================================================
0-2        ASCII ``VOL``
3          version, 3
4-7        int32 encoding, 1 (float32 values)
8-19       int32 cells along x, y, z
20-23      int32 channels (1, 3 or 6)
24-47      float32 bounding box: xmin, ymin, zmin, xmax, ymax, zmax
48-        float32 values, ``data[((z * yres + y) * xres + x) * channels + c]``
=========  ==============================================================

The reader returns the values as a ``(z, y, x, channels)`` array, so that
``grid.data[z, y, x, c]`` is the value Mitsuba indexes by the formula above.
"""
from __future__ import annotations

import struct
from dataclasses import dataclass

import numpy as np

HEADER = struct.Struct("<3sBiiiii6f")


class VolFormatError(ValueError):
    """A ``.vol`` file that cannot be read; the loader adds the scene location."""


@dataclass
class VolumeGrid:
    """The contents of a ``.vol`` file.

    Attributes
    ----------
    data : (z, y, x, channels) float64 array
    bbox : (2, 3) float64, the box stored in the file (min, max); Mitsuba uses it
        only with ``use_grid_bbox``.
    """

    data: np.ndarray
    bbox: np.ndarray

    @property
    def resolution(self) -> tuple[int, int, int]:
        """Cells along x, y, z."""
        return self.data.shape[2], self.data.shape[1], self.data.shape[0]

    @property
    def channels(self) -> int:
        return self.data.shape[3]


def read_vol(path: str) -> VolumeGrid:
    """Read a ``.vol`` file.

    Raises
    ------
    VolFormatError
        A wrong magic, version or encoding, bad sizes, a file shorter than its header
        says, or non-finite values; the message says which.
    """
    with open(path, "rb") as f:
        raw = f.read()
    if len(raw) < HEADER.size:
        raise VolFormatError(f"{len(raw)} bytes: shorter than the 48-byte header of a .vol file")
    magic, version, encoding, nx, ny, nz, channels, *box = HEADER.unpack_from(raw)
    if magic != b"VOL":
        raise VolFormatError("not a .vol file (it does not start with 'VOL')")
    if version != 3:
        raise VolFormatError(f"version {version}: only version 3 is supported (as in Mitsuba 3)")
    if encoding != 1:
        raise VolFormatError(f"encoding {encoding}: only 1 (float32) is supported (as in Mitsuba 3)")
    if min(nx, ny, nz) < 1:
        raise VolFormatError(f"resolution {nx} x {ny} x {nz}: every size must be >= 1")
    if channels not in (1, 3, 6):
        raise VolFormatError(f"{channels} channels: Mitsuba's grids have 1, 3 or 6")
    count = nx * ny * nz * channels
    if len(raw) < HEADER.size + 4 * count:
        raise VolFormatError(f"{len(raw)} bytes, but a {nx} x {ny} x {nz} grid of {channels} "
                             f"channel(s) needs {HEADER.size + 4 * count}")
    values = np.frombuffer(raw, dtype="<f4", count=count, offset=HEADER.size)
    if not np.all(np.isfinite(values)):
        raise VolFormatError("the grid holds non-finite values (NaN or infinity)")
    data = values.astype(np.float64).reshape(nz, ny, nx, channels)
    return VolumeGrid(data, np.array(box, dtype=np.float64).reshape(2, 3))


def write_vol(path: str, data: np.ndarray, bbox=((0.0, 0.0, 0.0), (1.0, 1.0, 1.0))) -> None:
    """Write ``data`` ((z, y, x) or (z, y, x, channels)) as a version-3 float32 ``.vol`` file."""
    data = np.asarray(data, dtype="<f4")
    if data.ndim == 3:
        data = data[..., None]
    nz, ny, nx, channels = data.shape
    box = np.asarray(bbox, dtype=np.float64).reshape(6)
    with open(path, "wb") as f:
        f.write(HEADER.pack(b"VOL", 3, 1, nx, ny, nz, channels, *box))
        f.write(np.ascontiguousarray(data).tobytes())
