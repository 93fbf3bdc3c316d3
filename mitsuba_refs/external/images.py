"""Images written by other renderers, read into one contract: a mean, maybe a variance, a sample count.

:func:`read_image` reads one file into an :class:`ExternalImage`: an (H, W, 3) float64
``mean`` with row 0 at the top of the picture, an optional (H, W, 3) per-*sample*
``variance``, the sample count ``spp`` and ``seed`` when something says them, and the
header's str, int and float attributes. Anything it cannot read as such is an
:class:`ImageError` of one line that starts with the file's path; nothing is guessed.

What is read, in this order
---------------------------
1. **The format, from the first bytes** (the extension is not trusted): OpenEXR (magic
   number 0x762f3101), PFM (``PF`` or ``Pf`` and a white-space byte), Radiance HDR
   (``#?RADIANCE`` or ``#?RGBE``). Anything else is refused, naming the three.
2. **The pixels.**

   * *OpenEXR*, through :func:`pathtracer.io.exr.read_channels` (the OpenEXR package):
     half, float or uint channels, scanline or tiled, any compression OpenEXR decodes.
     The colour is the top-level ``R``, ``G``, ``B``; without them, the one layer
     ``<layer>.R``, ``.G``, ``.B`` (``var`` is not a layer); several such layers are
     refused, naming them, and so is a file without colour (luminance ``Y`` only, say),
     naming the channels it has. The variance is ``var.R``, ``var.G``, ``var.B``, all
     three or none. Other channels (alpha, depth, ...) are ignored. The pixels are those
     of the display window: a larger data window is cropped to it, a data window that
     does not cover it is refused. Deep files are refused. Of a multi-part file, part 0
     is read and ``attributes["note"]`` says so (after the file's own ``note``, if any);
     a warning OpenEXR prints about a damaged part it read past goes there too.
   * *PFM*: ``PF`` (RGB) or ``Pf`` (grey, given to R, G and B alike), width and height,
     the scale (negative: little-endian floats, positive: big-endian; the pixels are
     multiplied by its magnitude, as Mitsuba 3's reader does), then exactly width x
     height x channels float32 values, bottom row first. The scale is
     ``attributes["scale"]``.
   * *Radiance HDR*: header lines up to an empty line; ``FORMAT=32-bit_rle_rgbe`` or no
     ``FORMAT`` (``32-bit_rle_xyze`` and others are refused); the pixels are divided by
     the product of the ``EXPOSURE=`` values and, channel by channel, of the
     ``COLORCORR=`` values; then the resolution line, which must be ``-Y H +X W`` (rows
     from the top, columns from the left; other orientations are refused); then H
     scanlines, each either new-style run-length encoded or flat (4 bytes a pixel),
     ending exactly at the end of the file. Old-style run-length encoding is refused.
     A pixel (r, g, b, e) is (c + 0.5) / 256 * 2^(e - 128) per channel c, 0 when
     e = 0, as Radiance's ``colr_color`` decodes it: the middle of the interval the
     writer truncated into. Mitsuba 3's reader gives c / 256 * 2^(e - 128), half a unit
     of the mantissa less. The header's ``NAME=value`` lines are attributes (text;
     ``EXPOSURE`` is the product of its lines, a float).
3. **The sample count and the seed.** ``spp`` from the header attribute ``spp`` or
   ``sample_count`` (an int, or text of a whole number), from a JSON sidecar
   ``<image file name>.json`` (``{"spp": 64, "seed": 3}``; ``sample_count`` also
   accepted, other keys ignored) and from the ``spp=`` argument; ``seed`` from the
   header's and the sidecar's ``seed``. Sources that disagree are refused, naming both
   values; none gives None.

:func:`image_faults` then says, one line each, whether the mean has NaN, infinite or
negative values and the variance NaN, infinite or negative ones, with the first such pixel.
"""
from __future__ import annotations

import contextlib
import io
import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mitsuba_refs.errors import one_line
from pathtracer.core import interrupts
from pathtracer.io.exr import MEAN_CHANNELS, VARIANCE_CHANNELS, read_channels
from pathtracer.io.rgbe import RADIANCE_OFFSET, RGBEError, rgbe_pixels, rgbe_to_float

#: The formats read, as :attr:`ExternalImage.format` names them.
FORMATS = ("exr", "pfm", "hdr")
#: The first four bytes of every OpenEXR file (the int 20000630, 0x762f3101, little-endian).
EXR_MAGIC = bytes([0x76, 0x2F, 0x31, 0x01])
#: Bits of the EXR version field (bytes 4 to 7): deep data, several parts.
EXR_DEEP_FLAG = 0x800
EXR_MULTIPART_FLAG = 0x1000
#: The two programme lines that open a Radiance picture.
RADIANCE_MAGICS = (b"#?RADIANCE", b"#?RGBE")
#: Header attributes (and sidecar keys) that give the sample count and the seed.
SPP_NAMES = ("spp", "sample_count")
SEED_NAMES = ("seed",)
#: Bytes read to tell the format.
_HEAD_BYTES = 16
#: PFM's three header fields: identifier, width and height, scale, each ended by a white-space byte.
_PFM_HEADER = re.compile(rb"(PF|Pf)\s+(\S+)\s+(\S+)\s+(\S+)\s")
#: Bytes a PFM header may take (the longest sensible one is some 60).
_PFM_HEADER_BYTES = 256


class ImageError(ValueError):
    """An image that cannot be read as a render; the message is one line starting with its path."""


@dataclass(frozen=True)
class ExternalImage:
    """A render read from a file another renderer wrote.

    Attributes
    ----------
    path : Path
        The file, as given to :func:`read_image`.
    format : str
        ``"exr"``, ``"pfm"`` or ``"hdr"``.
    mean : (H, W, 3) ndarray of float64
        Per-pixel radiance, row 0 at the top, column 0 at the left.
    variance : (H, W, 3) ndarray of float64 or None
        Per-*sample* variance of each pixel (channels ``var.R``, ``var.G``, ``var.B``), or
        None when the file has none.
    spp : int or None
        Samples per pixel, when the header, a sidecar or the caller says it.
    seed : int or None
        The render's seed, when the header or a sidecar says it.
    attributes : dict
        The header's attributes that are str, int or float (and the reader's ``note``).
    """

    path: Path
    format: str
    mean: np.ndarray
    variance: np.ndarray | None
    spp: int | None
    seed: int | None
    attributes: dict = field(default_factory=dict)

    @property
    def size(self) -> tuple[int, int]:
        """``(width, height)`` in pixels."""
        return self.mean.shape[1], self.mean.shape[0]


def _error(path, message: str) -> ImageError:
    """An :class:`ImageError` ``"<path>: <message>"``, on one line."""
    return ImageError(one_line(f"{path}: {message}"))


def read_image(path, *, spp: int | None = None) -> ExternalImage:
    """Read a render written by another renderer (module docstring: what is read, what refused).

    Parameters
    ----------
    path : str or Path
        An OpenEXR, PFM or Radiance HDR file.
    spp : int, optional
        The sample count, when the caller knows it; it must agree with the file's.

    Returns
    -------
    ExternalImage

    Raises
    ------
    ImageError
        The file is missing, empty, truncated, in another format, or not an RGB render as
        the module docstring describes; or its sample counts or seeds disagree.
    KeyboardInterrupt
        A Ctrl-C during the read, also one that OpenEXR turned into an error of its own.
    """
    path = Path(path)
    head = _head(path)
    image_format = detect_format(head)
    if image_format is None:
        radiance = " (a Radiance picture starts with #?RADIANCE or #?RGBE)" if head.startswith(b"#?") else ""
        raise _error(path, f"not an image in a format read here (OpenEXR, PFM or Radiance HDR): "
                           f"it starts with {head[:10]!r}{radiance}")
    if image_format == "exr":
        mean, variance, attributes = _read_exr(path, head)
    else:
        data = _bytes(path)
        reader = _read_pfm if image_format == "pfm" else _read_radiance
        mean, variance, attributes = reader(path, data)
    sidecar = _read_sidecar(path)
    sample_count = _settled(path, "spp", _sources(attributes, sidecar, SPP_NAMES)
                            + ([("the spp= argument", spp)] if spp is not None else []))
    seed = _settled(path, "seed", _sources(attributes, sidecar, SEED_NAMES))
    return ExternalImage(path=path, format=image_format, mean=mean, variance=variance,
                         spp=sample_count, seed=seed, attributes=attributes)


def detect_format(head: bytes) -> str | None:
    """``"exr"``, ``"pfm"`` or ``"hdr"`` from a file's first bytes, None for anything else."""
    if head.startswith(EXR_MAGIC):
        return "exr"
    if head[:2] in (b"PF", b"Pf") and head[2:3].isspace():
        return "pfm"
    if head.startswith(RADIANCE_MAGICS):
        return "hdr"
    return None


def _head(path: Path) -> bytes:
    """The first bytes of ``path``; a missing, unreadable or empty file is an :class:`ImageError`."""
    try:
        with path.open("rb") as file:
            head = file.read(_HEAD_BYTES)
    except FileNotFoundError:
        raise _error(path, "no such file") from None
    except IsADirectoryError:
        raise _error(path, "is a folder, not an image file") from None
    except OSError as error:
        raise _error(path, f"cannot be read ({error.strerror or error})") from None
    if not head:
        raise _error(path, "empty file (0 bytes)")
    return head


def _bytes(path: Path) -> bytes:
    """The whole of ``path``."""
    try:
        return path.read_bytes()
    except OSError as error:
        raise _error(path, f"cannot be read ({error.strerror or error})") from None


# --- OpenEXR -----------------------------------------------------------------------------

def _read_exr(path: Path, head: bytes) -> tuple[np.ndarray, np.ndarray | None, dict]:
    """``(mean, variance, attributes)`` of an OpenEXR file (module docstring)."""
    if len(head) < 8:
        raise _error(path, f"truncated OpenEXR file ({len(head)} bytes, not even the version field)")
    version = int.from_bytes(head[4:8], "little")
    if version & EXR_DEEP_FLAG:
        raise _error(path, "deep OpenEXR data (several samples a pixel) is not read; write a flat image")
    printed = io.StringIO()
    before = interrupts.count()
    try:
        # OpenEXR prints what went wrong with a part's pixels and reads on: it goes into the message.
        with contextlib.redirect_stdout(printed):
            channels, header = read_channels(path)
    except MemoryError:
        raise
    except Exception as error:  # OpenEXR's errors on bad files are plain RuntimeErrors
        interrupts.reraise_if_interrupted(before, error)    # a Ctrl-C, not the file's fault
        said = "; ".join(text for text in (one_line(printed.getvalue()), str(error)) if text)
        raise _error(path, f"not a readable OpenEXR file, truncated or corrupt ({said})") from None
    names = sorted(channels)
    colour = _colour_channels(path, names)
    given = [name for name in VARIANCE_CHANNELS if name in channels]
    if given and len(given) < len(VARIANCE_CHANNELS):
        missing = [name for name in VARIANCE_CHANNELS if name not in channels]
        raise _error(path, f"has {', '.join(given)} but not {', '.join(missing)}: a variance needs all "
                           f"three of {', '.join(VARIANCE_CHANNELS)}")
    rows, columns = _display_crop(path, header)
    data_window = _window(header, "dataWindow")
    data_shape = (data_window[3] - data_window[1] + 1, data_window[2] - data_window[0] + 1)
    for name in colour + tuple(given):
        if channels[name].shape != data_shape:
            raise _error(path, f"channel {name} holds {channels[name].shape[1]}x{channels[name].shape[0]} "
                               f"values but the data window is {data_shape[1]}x{data_shape[0]} pixels "
                               "(subsampled channels are not read)")

    def image(names) -> np.ndarray:
        return np.stack([channels[name][rows, columns] for name in names], axis=-1).astype(np.float64)

    mean = image(colour)
    variance = image(VARIANCE_CHANNELS) if given else None
    attributes = {key: value for key, value in header.items()
                  if isinstance(value, (str, int, float)) and not isinstance(value, bool)}
    notes = [attributes["note"]] if isinstance(attributes.get("note"), str) else []
    if version & EXR_MULTIPART_FLAG:
        part = f" ({header['name']!r})" if isinstance(header.get("name"), str) else ""
        notes.append(f"multi-part file: part 0{part} read, the other parts ignored")
    if printed.getvalue().strip():
        notes.append(f"OpenEXR said: {one_line(printed.getvalue())}")
    if notes:
        attributes["note"] = "; ".join(notes)
    return mean, variance, attributes


def _colour_channels(path: Path, names: list[str]) -> tuple[str, str, str]:
    """The names of the red, green and blue channels among ``names`` (module docstring)."""
    if all(name in names for name in MEAN_CHANNELS):
        return MEAN_CHANNELS
    layers = sorted({name.rpartition(".")[0] for name in names if "." in name} - {"var"})
    candidates = [layer for layer in layers if all(f"{layer}.{c}" in names for c in MEAN_CHANNELS)]
    if len(candidates) == 1:
        layer = candidates[0]
        return tuple(f"{layer}.{c}" for c in MEAN_CHANNELS)
    if candidates:
        raise _error(path, f"no top-level R, G, B and several layers with R, G, B ({', '.join(candidates)}): "
                           "which one is the render is not known")
    luminance = " (luminance only)" if "Y" in names and not any(c in names for c in MEAN_CHANNELS) else ""
    raise _error(path, f"no R, G, B channels{luminance}: the file has {', '.join(names) or 'no channels'}")


def _window(header: dict, key: str) -> tuple[int, int, int, int]:
    """``(x_min, y_min, x_max, y_max)`` of the header's window ``key`` (inclusive corners)."""
    (x_min, y_min), (x_max, y_max) = header[key]
    return int(x_min), int(y_min), int(x_max), int(y_max)


def _display_crop(path: Path, header: dict) -> tuple[slice, slice]:
    """The rows and columns of the data window's arrays that are the display window."""
    data = _window(header, "dataWindow")
    display = _window(header, "displayWindow")
    if data[0] > display[0] or data[1] > display[1] or data[2] < display[2] or data[3] < display[3]:
        raise _error(path, f"the data window ({data[0]}, {data[1]})-({data[2]}, {data[3]}) does not cover "
                           f"the display window ({display[0]}, {display[1]})-({display[2]}, {display[3]}): "
                           "pixels of the picture are missing")
    return (slice(display[1] - data[1], display[3] - data[1] + 1),
            slice(display[0] - data[0], display[2] - data[0] + 1))


# --- PFM ---------------------------------------------------------------------------------

def _read_pfm(path: Path, data: bytes) -> tuple[np.ndarray, None, dict]:
    """``(mean, None, attributes)`` of a PFM file (module docstring)."""
    header = _PFM_HEADER.match(data[:_PFM_HEADER_BYTES])
    if header is None:
        raise _error(path, "truncated or malformed PFM header (expected 'PF' or 'Pf', width height, scale)")
    identifier, width_text, height_text, scale_text = header.groups()
    width, height = _dimension(path, width_text, "width"), _dimension(path, height_text, "height")
    try:
        scale = float(scale_text)
    except ValueError:
        scale = math.nan
    if scale == 0 or not math.isfinite(scale):
        raise _error(path, f"PFM scale {scale_text.decode('latin-1')!r} is not a non-zero number")
    channel_count = 3 if identifier == b"PF" else 1
    expected = width * height * channel_count * 4
    found = len(data) - header.end()
    if found != expected:
        what = "truncated" if found < expected else "too long"
        raise _error(path, f"{what}: {width}x{height} {'RGB' if channel_count == 3 else 'grey'} float32 pixels "
                           f"are {expected} bytes, the file has {found} after its header")
    floats = np.frombuffer(data, dtype="<f4" if scale < 0 else ">f4", count=expected // 4, offset=header.end())
    rows = floats.reshape(height, width, channel_count)[::-1]       # stored bottom row first
    mean = rows.astype(np.float64) * abs(scale)
    if channel_count == 1:
        mean = np.repeat(mean, 3, axis=2)
    return np.ascontiguousarray(mean), None, {"scale": scale}


def _dimension(path: Path, text: bytes, what: str) -> int:
    """A width or height of a header: a positive decimal integer."""
    if not text.isdigit() or int(text) == 0:
        raise _error(path, f"{what} {text.decode('latin-1')[:20]!r} is not a positive whole number")
    return int(text)


# --- Radiance HDR ------------------------------------------------------------------------

def _read_radiance(path: Path, data: bytes) -> tuple[np.ndarray, None, dict]:
    """``(mean, None, attributes)`` of a Radiance RGBE picture (module docstring)."""
    header_end = data.find(b"\n\n")
    if header_end < 0:
        raise _error(path, "truncated Radiance header (no empty line ends it)")
    factor, attributes = _radiance_header(path, data[:header_end].decode("latin-1").split("\n")[1:])
    line_start = header_end + 2
    line_end = data.find(b"\n", line_start)
    if line_end < 0:
        raise _error(path, "truncated Radiance file (no resolution line after the header)")
    resolution = data[line_start:line_end].decode("latin-1")
    tokens = resolution.split()
    if len(tokens) != 4 or tokens[0] != "-Y" or tokens[2] != "+X":
        raise _error(path, f"resolution line {resolution[:60]!r} is not the standard orientation "
                           "'-Y <height> +X <width>' (rows from the top, columns from the left): not read")
    height, width = _dimension(path, tokens[1].encode(), "height"), _dimension(path, tokens[3].encode(), "width")
    try:
        rgbe = rgbe_pixels(data, line_end + 1, width, height)
    except RGBEError as error:
        raise _error(path, str(error)) from None
    mean = rgbe_to_float(rgbe, RADIANCE_OFFSET) / factor
    return mean, None, attributes


def _radiance_header(path: Path, lines: list[str]) -> tuple[np.ndarray, dict]:
    """The factor the stored values are divided by, and the ``NAME=value`` lines as attributes."""
    exposure, colour_correction = 1.0, np.ones(3)
    attributes: dict = {}
    for line in lines:
        name, equals, value = line.partition("=")
        name, value = name.strip(), value.strip()
        if not equals or not name or name.startswith("#"):
            continue                              # comments and the command lines Radiance keeps
        if name == "FORMAT" and value != "32-bit_rle_rgbe":
            if value == "32-bit_rle_xyze":
                raise _error(path, "XYZ pixels (FORMAT=32-bit_rle_xyze) are not supported: only RGBE is read")
            raise _error(path, f"FORMAT={value[:40]} is not read (only 32-bit_rle_rgbe)")
        if name == "EXPOSURE":                    # repeated lines multiply
            exposure *= float(_positive_numbers(path, line, 1)[0])
            value = exposure
        elif name == "COLORCORR":
            colour_correction = colour_correction * _positive_numbers(path, line, 3)
            value = " ".join(f"{number:.9g}" for number in colour_correction)
        attributes[name] = value
    return exposure * colour_correction, attributes


def _positive_numbers(path: Path, line: str, count: int) -> np.ndarray:
    """The ``count`` positive numbers after the ``=`` of a header line."""
    try:
        numbers = np.array([float(text) for text in line.partition("=")[2].split()])
    except ValueError:
        numbers = np.array([])
    if numbers.shape != (count,) or not np.all(np.isfinite(numbers) & (numbers > 0)):
        raise _error(path, f"header line {line.strip()[:60]!r} does not hold {count} positive number(s)")
    return numbers


# --- sample count and seed ---------------------------------------------------------------

def _read_sidecar(path: Path) -> tuple[Path, dict] | None:
    """``(sidecar path, its object)`` of ``<path>.json`` beside the image, None when there is none."""
    sidecar = path.with_name(path.name + ".json")
    try:
        text = sidecar.read_text(encoding="utf-8")
    except FileNotFoundError:
        return None
    except (OSError, UnicodeDecodeError) as error:
        reason = error.strerror if isinstance(error, OSError) and error.strerror else error
        raise _error(path, f"sidecar {sidecar} cannot be read ({reason})") from None
    try:
        content = json.loads(text)
    except json.JSONDecodeError as error:
        raise _error(path, f"sidecar {sidecar}, line {error.lineno} column {error.colno}: {error.msg} "
                           "(not valid JSON)") from None
    if not isinstance(content, dict):
        raise _error(path, f"sidecar {sidecar} holds a JSON {type(content).__name__}, not an object "
                           'such as {"spp": 64, "seed": 3}')
    return sidecar, content


def _sources(attributes: dict, sidecar: tuple[Path, dict] | None, names: tuple[str, ...]) -> list[tuple[str, object]]:
    """``(where, value)`` of each header attribute and sidecar key among ``names``."""
    found = [(f"the header's {name}", attributes[name]) for name in names if name in attributes]
    if sidecar is not None:
        sidecar_path, content = sidecar
        found += [(f"{sidecar_path}'s {name}", content[name]) for name in names if name in content]
    return found


def _whole_number(value) -> int | None:
    """``value`` as an int when it is one: an int, an integral float, or text of either."""
    if isinstance(value, bool):
        return None
    if isinstance(value, int):
        return value
    if isinstance(value, str):
        try:
            return int(value.strip())
        except ValueError:
            try:
                value = float(value)
            except ValueError:
                return None
    if isinstance(value, float) and value.is_integer():
        return int(value)
    return None


def _settled(path: Path, quantity: str, found: list[tuple[str, object]]) -> int | None:
    """The one value of ``quantity`` (``"spp"``, ``"seed"``) the sources agree on, None without any."""
    settled = None
    for where, raw in found:
        number = _whole_number(raw)
        if number is None:
            raise _error(path, f"{quantity} {raw!r} in {where} is not a whole number")
        if quantity == "spp" and number < 1:
            raise _error(path, f"spp {number} in {where} is not a sample count (at least 1)")
        if settled is not None and number != settled[1]:
            raise _error(path, f"{quantity} disagrees: {settled[1]} in {settled[0]} but {number} in {where}")
        settled = settled or (where, number)
    return None if settled is None else settled[1]


# --- faults ------------------------------------------------------------------------------

def image_faults(image: ExternalImage) -> list[str]:
    """What is wrong with an image's values, one line each (empty when nothing is).

    The mean and the variance are each checked for NaN, infinite (either sign) and
    negative (finite, below zero) values; a line gives the count and the first such
    value, reading rows from the top and pixels from the left: pixel ``(x, y)`` and
    channel.

    Parameters
    ----------
    image : ExternalImage

    Returns
    -------
    list of str
        Lines such as ``"renders/a.exr: 3 NaN values in the mean, the first at pixel (4, 0) channel G"``.
    """
    faults = []
    images = [("mean", image.mean)] + ([("variance", image.variance)] if image.variance is not None else [])
    for which, values in images:
        finite = np.isfinite(values)
        for kind, wrong in (("NaN", np.isnan(values)), ("Inf", np.isinf(values)),
                            ("negative", finite & (values < 0))):
            count = int(np.count_nonzero(wrong))
            if count:
                y, x, channel = np.unravel_index(int(np.argmax(wrong)), wrong.shape)
                faults.append(f"{image.path}: {count} {kind} value{'s' if count > 1 else ''} in the {which}, the "
                              f"first at pixel ({x}, {y}) channel {MEAN_CHANNELS[channel]}")
    return faults
