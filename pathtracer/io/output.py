"""Writing renders: EXR with mean and variance, and a tonemapped sRGB PNG preview.

Outputs are checked before a render starts (:func:`output_paths`) and written to a unique
temporary name in the same directory, then renamed over the output path
(:func:`atomic_path`): an interrupted or failed write never leaves a partial file there,
and an older file at that path stays intact until the new one is complete.
"""
from __future__ import annotations

import contextlib
import json
import os
import secrets
import warnings
from pathlib import Path

import numpy as np
from PIL import Image

from ..core.tonemap import to_8bit, tonemap
from ..render.driver import RenderResult

#: Largest seed an EXR ``int`` attribute (signed 32-bit) holds; larger ones are stored as text.
EXR_INT_MAX = 2 ** 31 - 1


class OutputError(ValueError):
    """An output path that cannot be written (raised before rendering)."""


class PrecisionWarning(UserWarning):
    """Values that do not fit the EXR's float type were clamped to its largest value."""


def output_paths(path) -> tuple[Path, Path]:
    """Check an EXR output path before rendering; return it and its PNG preview's path.

    Creates the missing parent directories and proves that the directory is writable by
    creating and removing a temporary file there.

    Raises
    ------
    OutputError
        When the name does not end in ``.exr`` (the preview would otherwise replace the
        EXR, or be the only file written), when the EXR or PNG path is a directory, when a
        parent is a file, or when the directory cannot be created or written.
    """
    exr = Path(path)
    if exr.suffix.lower() != ".exr":
        raise OutputError(f"output \"{exr}\" must end in .exr (it holds mean and variance; "
                          f"a PNG preview is written beside it), e.g. "
                          f"\"{exr.with_suffix('.exr')}\"")
    png = exr.with_suffix(".png")
    for target in (exr, png):
        if target.is_dir():
            raise OutputError(f"output \"{target}\" is a directory; give a file name")
    directory = exr.parent
    try:
        directory.mkdir(parents=True, exist_ok=True)
        probe = _temporary_name(exr)
        probe.touch(exist_ok=False)
        probe.unlink()
    except FileExistsError:
        raise OutputError(f"cannot write \"{exr}\": \"{_first_file(directory)}\" is a file, "
                          "not a directory") from None
    except OSError as error:
        reason = error.strerror or str(error)
        if isinstance(error, NotADirectoryError):
            reason = f"\"{_first_file(directory)}\" is a file, not a directory"
        raise OutputError(f"cannot write \"{exr}\": {reason}") from None
    return exr, png


def _first_file(directory: Path) -> Path:
    """The first component of ``directory`` that exists and is not a directory."""
    for parent in reversed((directory, *directory.parents)):
        if parent.exists() and not parent.is_dir():
            return parent
    return directory


def _temporary_name(path: Path) -> Path:
    """A hidden, unique name beside ``path`` (same file system, so a rename is atomic)."""
    return path.with_name(f".{path.name}.{os.getpid()}.{secrets.token_hex(4)}.tmp")


@contextlib.contextmanager
def atomic_path(path):
    """Yield a temporary path beside ``path``; rename it to ``path`` if the block succeeds.

    On any exception (KeyboardInterrupt included) the temporary file is removed and
    ``path`` is left as it was.
    """
    path = Path(path)
    temporary = _temporary_name(path)
    try:
        yield temporary
        os.replace(temporary, path)
    except BaseException:
        with contextlib.suppress(OSError):
            temporary.unlink()
        raise


def _channel(values: np.ndarray, dtype, what: str, clamped: dict) -> np.ndarray:
    """``values`` as ``dtype``, magnitudes beyond its range clamped to its largest value."""
    largest = float(np.finfo(dtype).max)
    too_large = int(np.count_nonzero(np.abs(values) > largest))
    if too_large:
        clamped[what] = clamped.get(what, 0) + too_large
        values = np.clip(values, -largest, largest)
    return np.ascontiguousarray(values, dtype=dtype)


def write_exr(path, result: RenderResult, dtype=np.float32) -> Path:
    """Write R, G, B (mean) and var.R, var.G, var.B (per-sample variance), atomically.

    The header records ``spp``, ``seed`` (an int; text when above 2^31 - 1, which an EXR
    int cannot hold), ``integrator``, the integrator's options (JSON) and the scene, so
    that a file says how it was made. Values beyond ``dtype``'s range (a variance of
    radiance near 1e20 overflows float32) are stored as its largest value; the header's
    ``clamped_mean`` / ``clamped_variance`` then count them and a :class:`PrecisionWarning`
    says so. NaN stays NaN.
    """
    import OpenEXR

    path = Path(path)
    channels, clamped = {}, {}
    for c, name in enumerate("RGB"):
        channels[name] = _channel(result.mean[:, :, c], dtype, "mean", clamped)
        channels[f"var.{name}"] = _channel(result.variance[:, :, c], dtype, "variance", clamped)
    seed = int(result.seed)
    header = {
        "compression": OpenEXR.ZIP_COMPRESSION,
        "type": OpenEXR.scanlineimage,
        "spp": int(result.spp),
        "seed": seed if -EXR_INT_MAX - 1 <= seed <= EXR_INT_MAX else str(seed),
        "integrator": result.integrator,
        "integrator_options": json.dumps(result.options, sort_keys=True),
        "scene": str(result.scene),
        "render_seconds": float(result.seconds),
    }
    header.update({f"clamped_{what}": count for what, count in clamped.items()})
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as temporary, OpenEXR.File(header, channels) as exr:
        exr.write(str(temporary))
    for what, count in clamped.items():
        warnings.warn(PrecisionWarning(
            f"{path}: {count} {what} values exceed the EXR's {np.dtype(dtype).name} range and "
            f"were stored as its largest value, {np.finfo(dtype).max:.3g} (header clamped_{what})"), stacklevel=2)
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


def write_png(path, rgb: np.ndarray, exposure: float = 0.0) -> Path:
    """Write a tonemapped sRGB preview of a linear (H, W, 3) image, atomically (``exposure`` in stops)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    image = Image.fromarray(to_8bit(tonemap(rgb, 2.0 ** exposure)))
    with atomic_path(path) as temporary:
        image.save(temporary, format="PNG")
    return path
