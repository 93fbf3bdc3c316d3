"""Writing renders: EXR with mean and variance (:mod:`pathtracer.io.exr`), and a tonemapped
sRGB PNG preview.

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
from pathlib import Path

import numpy as np
from PIL import Image

from ..core.tonemap import to_8bit, tonemap
from ..render.driver import RenderResult
from .exr import read_mean_variance, warn_clamped, write_mean_variance


class OutputError(ValueError):
    """An output path that cannot be written (raised before rendering)."""


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


def write_exr(path, result: RenderResult, dtype=np.float32) -> Path:
    """Write R, G, B (mean) and var.R, var.G, var.B (per-sample variance), atomically.

    The header records ``spp``, ``seed`` (an int; text when above 2^31 - 1, which an EXR
    int cannot hold), ``integrator``, the integrator's options (JSON) and the scene, so
    that a file says how it was made. Values beyond ``dtype``'s range (a variance of
    radiance near 1e20 overflows float32) are stored as its largest value; the header's
    ``clamped_mean`` / ``clamped_variance`` then count them and a
    :class:`~pathtracer.io.exr.PrecisionWarning` says so. NaN stays NaN.
    """
    path = Path(path)
    attributes = {
        "spp": int(result.spp),
        "seed": int(result.seed),
        "integrator": result.integrator,
        "integrator_options": json.dumps(result.options, sort_keys=True),
        "scene": str(result.scene),
        "render_seconds": float(result.seconds),
    }
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as temporary:
        clamped = write_mean_variance(temporary, result.mean, result.variance, attributes, dtype)
    warn_clamped(path, clamped, dtype)
    return path


def read_exr(path) -> RenderResult:
    """Read a file written by :func:`write_exr` back into a :class:`RenderResult`."""
    mean, variance, header = read_mean_variance(path)
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
