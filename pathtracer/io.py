"""Writing renders: EXR with mean and variance, and a tonemapped sRGB PNG preview."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from .render import RenderResult


def write_exr(path, result: RenderResult, dtype=np.float32) -> Path:
    """Write R, G, B (mean) and var.R, var.G, var.B (per-sample variance).

    The header records ``spp``, ``seed``, ``integrator``, the integrator's
    options (JSON) and the scene, so that a file says how it was made.
    """
    import OpenEXR

    path = Path(path)
    channels = {}
    for c, name in enumerate("RGB"):
        channels[name] = np.ascontiguousarray(result.mean[:, :, c], dtype=dtype)
        channels[f"var.{name}"] = np.ascontiguousarray(result.variance[:, :, c], dtype=dtype)
    header = {
        "compression": OpenEXR.ZIP_COMPRESSION,
        "type": OpenEXR.scanlineimage,
        "spp": int(result.spp),
        "seed": int(result.seed),
        "integrator": result.integrator,
        "integrator_options": json.dumps(result.options, sort_keys=True),
        "scene": str(result.scene),
        "render_seconds": float(result.seconds),
    }
    path.parent.mkdir(parents=True, exist_ok=True)
    with OpenEXR.File(header, channels) as exr:
        exr.write(str(path))
    return path


def read_exr(path) -> RenderResult:
    """Read a file written by :func:`write_exr` back into a :class:`RenderResult`."""
    import OpenEXR

    # separate_channels: OpenEXR would otherwise group R, G, B (and var.*) into one array.
    with OpenEXR.File(str(path), separate_channels=True) as exr:
        header, channels = dict(exr.header()), exr.channels()   # the file's dict is cleared on close
        mean = np.stack([channels[c].pixels for c in "RGB"], axis=2).astype(np.float64)
        variance = np.stack([channels[f"var.{c}"].pixels for c in "RGB"], axis=2).astype(np.float64)
    options = json.loads(header.get("integrator_options", "{}"))
    return RenderResult(mean, variance, int(header.get("spp", 0)), int(header.get("seed", 0)),
                        str(header.get("integrator", "")), options,
                        float(header.get("render_seconds", 0.0)), str(header.get("scene", "")))


def tonemap(rgb: np.ndarray, exposure: float = 0.0) -> np.ndarray:
    """Linear radiance to 8-bit sRGB: scale by 2^exposure, clamp, sRGB transfer curve."""
    x = np.clip(np.nan_to_num(rgb * 2.0 ** exposure), 0.0, 1.0)
    srgb = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)
    return (srgb * 255 + 0.5).astype(np.uint8)


def write_png(path, rgb: np.ndarray, exposure: float = 0.0) -> Path:
    """Write a tonemapped sRGB preview of a linear (H, W, 3) image."""
    from PIL import Image

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(tonemap(rgb, exposure)).save(path)
    return path
