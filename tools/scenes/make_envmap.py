"""Write ``envmap-sky.exr``, the 32x16 latitude-longitude map of ``envmap.xml``.

A deterministic, recognisable sky (no random numbers), float32 RGB:

* a sky gradient: blue near the zenith (top row), pale at the horizon,
  and a dark brown ground below it (bottom half of the image);
* an orange "sun" (a Gaussian blob, peak ~ 6) at u = 0.25, v = 0.3: with
  Mitsuba's mapping that is towards +x, 54 degrees from the zenith;
* a small green patch at u = 0.75, v = 0.45 (towards -x, near the horizon),
  so that a left-right mirror or a shift of the map shows in a render.

Usage: ``python make_envmap.py [output.exr]``.
"""

import sys
from pathlib import Path

import numpy as np

#: Where the built-in scenes live (the default output).
SCENES = Path(__file__).resolve().parents[2] / "pathtracer" / "data" / "scenes"

WIDTH, HEIGHT = 32, 16


def sky(width: int = WIDTH, height: int = HEIGHT) -> np.ndarray:
    """The (height, width, 3) float32 radiance image."""
    u = (np.arange(width) + 0.5) / width
    v = np.arange(height) / (height - 1)
    uu, vv = np.meshgrid(u, v)
    up = np.clip(1.0 - 2.0 * vv, 0.0, 1.0)[..., None]               # 1 at the zenith, 0 at the horizon
    image = np.where(vv[..., None] < 0.5,
                     (1 - up) * np.array([0.9, 0.95, 1.0]) + up * np.array([0.25, 0.45, 1.0]),
                     np.array([0.18, 0.12, 0.08]))
    du = np.minimum(np.abs(uu - 0.25), 1 - np.abs(uu - 0.25))
    sun = np.exp(-((du / 0.05) ** 2 + ((vv - 0.3) / 0.09) ** 2))
    image = image + 6.0 * sun[..., None] * np.array([1.0, 0.7, 0.35])
    dg = np.minimum(np.abs(uu - 0.75), 1 - np.abs(uu - 0.75))
    green = (dg < 0.07) & (np.abs(vv - 0.45) < 0.05)
    image = image + 1.5 * green[..., None] * np.array([0.1, 1.0, 0.2])
    return image.astype(np.float32)


def write(path) -> None:
    """Write the sky environment map to ``path`` as an RGB EXR."""
    import OpenEXR

    image = sky()
    channels = {c: np.ascontiguousarray(image[:, :, k]) for k, c in enumerate("RGB")}
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, channels) as exr:
        exr.write(str(path))


if __name__ == "__main__":
    write(sys.argv[1] if len(sys.argv) > 1 else SCENES / "envmap-sky.exr")
