"""Write the image fixtures of ``tests/test_external_images.py`` into ``tests/data/images``.

Each file is written by a program other than ours, from the pattern of
``tests/image_pattern.py`` (the test recomputes it), so that the readers of
``mitsuba_refs/external/images.py`` are checked against other writers, not against themselves:

=============================  ============  =================================================
file                           written by    what it is
=============================  ============  =================================================
mitsuba_float32.exr            Mitsuba 3     RGB float32, PIZ; metadata spp = 16, seed = 3
mitsuba_float16.exr            Mitsuba 3     RGB half
mitsuba_rgba.exr               Mitsuba 3     RGBA float32 (alpha grows to the right)
mitsuba.pfm                    Mitsuba 3     colour PFM (``PF``, little-endian)
mitsuba_flat.hdr               Mitsuba 3     RGBE, 7 pixels wide: flat scanlines
mitsuba_rle.hdr                Mitsuba 3     RGBE, 40 pixels wide: run-length-encoded scanlines
openexr_tiled.exr              OpenEXR       tiled (4x4 tiles), float32, PIZ
openexr_half.exr               OpenEXR       scanline half, ZIP
openexr_extra_channels.exr     OpenEXR       R, G, B with A, Z (half), N.X/N.Y/N.Z, an ID (uint)
openexr_variance.exr           OpenEXR       R, G, B and var.R, var.G, var.B; spp = 64, seed = 7
openexr_layer.exr              OpenEXR       Beauty.R/G/B/A, depth.Z, var.R/G/B; spp = "32" (text)
openexr_luminance.exr          OpenEXR       Y only
openexr_multipart.exr          OpenEXR       part 0 "beauty" (R, G, B), part 1 "depth" (Z)
openexr_data_window.exr        OpenEXR       data window one pixel larger than the display
                                             window on every side, the border -1
pillow_grey.pfm                Pillow        grey PFM (``Pf``) of the pattern's channel mean
=============================  ============  =================================================

The files are 7x5 pixels (one 40x5), a few hundred bytes to 2 KB each. Running the script
again rewrites the same bytes (no time stamps are written). It needs NumPy, the OpenEXR
package and Pillow; the Mitsuba files also need Mitsuba 3 (variant ``scalar_rgb``), and are
skipped with a message where it cannot be imported. Run from the repository root:

    /work/venv-mi/bin/python -m tools.images.make_fixtures [output folder]

(``-m``, so that ``tests.image_pattern`` is found.)
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import OpenEXR
from PIL import Image

from tests.image_pattern import HEIGHT, WIDE_WIDTH, WIDTH, grey_pattern, pattern, variance_pattern

#: Where the test reads the fixtures (the default output).
FIXTURES = Path(__file__).resolve().parents[2] / "tests" / "data" / "images"


def write_mitsuba(folder: Path) -> list[str]:
    """The Mitsuba 3 files; returns their names (none where Mitsuba cannot be imported)."""
    try:
        import mitsuba
        mitsuba.set_variant("scalar_rgb")
    except (ImportError, AttributeError) as error:
        print(f"Mitsuba 3 files skipped: {type(error).__name__}: {error}", file=sys.stderr)
        return []
    colour = pattern().astype(np.float32)
    bitmap = mitsuba.Bitmap(colour)
    metadata = bitmap.metadata()
    metadata["spp"] = 16
    metadata["seed"] = 3
    bitmap.write(str(folder / "mitsuba_float32.exr"))
    mitsuba.Bitmap(colour).convert(component_format=mitsuba.Struct.Type.Float16).write(
        str(folder / "mitsuba_float16.exr"))
    alpha = np.broadcast_to(np.linspace(0.0, 1.0, WIDTH, dtype=np.float32), (HEIGHT, WIDTH))[..., None]
    mitsuba.Bitmap(np.concatenate([colour, alpha], axis=-1), mitsuba.Bitmap.PixelFormat.RGBA).write(
        str(folder / "mitsuba_rgba.exr"))
    mitsuba.Bitmap(colour).write(str(folder / "mitsuba.pfm"))
    mitsuba.Bitmap(colour).write(str(folder / "mitsuba_flat.hdr"))
    mitsuba.Bitmap(pattern(WIDE_WIDTH, HEIGHT).astype(np.float32)).write(str(folder / "mitsuba_rle.hdr"))
    return ["mitsuba_float32.exr", "mitsuba_float16.exr", "mitsuba_rgba.exr", "mitsuba.pfm",
            "mitsuba_flat.hdr", "mitsuba_rle.hdr"]


def _rgb(image: np.ndarray, dtype, prefix: str = "") -> dict:
    """Channels ``<prefix>R``, ``G``, ``B`` of an (H, W, 3) image as ``dtype``."""
    return {f"{prefix}{name}": np.ascontiguousarray(image[:, :, c], dtype=dtype) for c, name in enumerate("RGB")}


def _write_exr(path: Path, channels: dict, compression=None, **attributes) -> None:
    header = {"compression": compression or OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    header.update(attributes)
    with OpenEXR.File(header, channels) as exr:
        exr.write(str(path))


def write_openexr(folder: Path) -> list[str]:
    """The files written with the OpenEXR package; returns their names."""
    colour, variance = pattern(), variance_pattern()
    tiles = OpenEXR.TileDescription()
    tiles.xSize = tiles.ySize = 4
    tiled = {"compression": OpenEXR.PIZ_COMPRESSION, "type": OpenEXR.tiledimage, "tiles": tiles}
    with OpenEXR.File(tiled, _rgb(colour, np.float32)) as exr:
        exr.write(str(folder / "openexr_tiled.exr"))
    _write_exr(folder / "openexr_half.exr", _rgb(colour, np.float16))
    extra = _rgb(colour, np.float32)
    extra["A"] = np.full((HEIGHT, WIDTH), 0.5, dtype=np.float32)
    extra["Z"] = np.arange(HEIGHT * WIDTH, dtype=np.float16).reshape(HEIGHT, WIDTH)
    extra.update({f"N.{axis}": np.full((HEIGHT, WIDTH), 1.0 / 3 ** 0.5, np.float32) for axis in "XYZ"})
    extra["id"] = np.arange(HEIGHT * WIDTH, dtype=np.uint32).reshape(HEIGHT, WIDTH)
    _write_exr(folder / "openexr_extra_channels.exr", extra)
    _write_exr(folder / "openexr_variance.exr", _rgb(colour, np.float32) | _rgb(variance, np.float32, "var."),
               spp=64, seed=7)
    layer = _rgb(colour, np.float32, "Beauty.") | _rgb(variance, np.float32, "var.")
    layer["Beauty.A"] = np.ones((HEIGHT, WIDTH), np.float32)
    layer["depth.Z"] = np.full((HEIGHT, WIDTH), 2.0, np.float32)
    _write_exr(folder / "openexr_layer.exr", layer, spp="32")
    _write_exr(folder / "openexr_luminance.exr", {"Y": grey_pattern().astype(np.float32)})
    scanline = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    parts = [OpenEXR.Part(dict(scanline), _rgb(colour, np.float32), name="beauty"),
             OpenEXR.Part(dict(scanline), {"Z": np.full((HEIGHT, WIDTH), 2.0, np.float32)}, name="depth")]
    with OpenEXR.File(parts) as exr:
        exr.write(str(folder / "openexr_multipart.exr"))
    bordered = np.full((HEIGHT + 2, WIDTH + 2, 3), -1.0)
    bordered[1:-1, 1:-1] = colour
    corners = (np.array([-1, -1], np.int32), np.array([WIDTH, HEIGHT], np.int32))
    display = (np.array([0, 0], np.int32), np.array([WIDTH - 1, HEIGHT - 1], np.int32))
    _write_exr(folder / "openexr_data_window.exr", _rgb(bordered, np.float32), dataWindow=corners,
               displayWindow=display)
    return ["openexr_tiled.exr", "openexr_half.exr", "openexr_extra_channels.exr", "openexr_variance.exr",
            "openexr_layer.exr", "openexr_luminance.exr", "openexr_multipart.exr", "openexr_data_window.exr"]


def write_pillow(folder: Path) -> list[str]:
    """The grey PFM Pillow writes (Pillow 10.3 and later); returns its name."""
    Image.fromarray(grey_pattern().astype(np.float32)).save(folder / "pillow_grey.pfm")
    return ["pillow_grey.pfm"]


def main(argv: list[str]) -> int:
    """Write every fixture into ``argv[0]`` (default: :data:`FIXTURES`) and list them with their sizes."""
    folder = Path(argv[0]) if argv else FIXTURES
    folder.mkdir(parents=True, exist_ok=True)
    written = write_mitsuba(folder) + write_openexr(folder) + write_pillow(folder)
    for name in written:
        print(f"{folder / name}  {(folder / name).stat().st_size} bytes")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
