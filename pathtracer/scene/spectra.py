"""``<spectrum>`` values and their conversion to linear sRGB, as Mitsuba's RGB variants do it.

A spectrum is either uniform (``value="0.5"``) or a list of
``wavelength:value`` pairs (``"400:0.1, 500:0.5, 600:0.9"``, nanometres),
linear in between and zero outside the listed range.

Mitsuba 3.9.1 (``Properties::get_texture_impl`` and
``spectrum_list_to_srgb``) converts them in RGB mode as follows, and so do we:

- A **list** is integrated against the CIE 1931 curves with a 1000-point
  rule on [360, 830] nm (equally spaced points, both ends included, step
  470/1000 nm; points outside the list's range contribute nothing)::

      XYZ = sum_i s(l_i) w(l_i) xyz(l_i) * 0.47 / CIE_Y_INTEGRAL

  then ``RGB = M_xyz_to_srgb XYZ``. For **reflectances** ``w`` is the D65
  illuminant scaled to luminance 1 (so a flat spectrum gives a grey) and
  the result is clamped to [0, 1]; for **emitters** ``w = 1`` (an
  equal-energy illuminant looks slightly purple in sRGB) and only negative
  values are clamped. Values that are not reflectances but may exceed 1
  (``unbounded``, e.g. an index of refraction) use D65 without the upper clamp.
- A **uniform** value ``v`` is the grey ``(v, v, v)``, except for emitters:
  ``v * M_xyz_to_srgb (1, 1, 1)`` = ``v * (1.2048, 0.9483, 0.9089)``,
  the colour of a flat emission spectrum.
"""
from __future__ import annotations

import re
import warnings
from dataclasses import dataclass

import numpy as np

from . import cie

#: XYZ -> linear sRGB (Rec. 709 primaries, D65 white), the matrix Mitsuba uses.
XYZ_TO_SRGB = np.array([[3.240479, -1.537150, -0.498535],
                        [-0.969256, 1.875991, 0.041556],
                        [0.055648, -0.204043, 1.057311]])
#: Number of points of the integration rule.
STEPS = 1000
KINDS = ("reflectance", "emission", "unbounded")
_SPLIT = re.compile(r"[,\s]+")


@dataclass(frozen=True)
class Spectrum:
    """A parsed ``<spectrum>``.

    Attributes
    ----------
    wavelengths : tuple of float or None
        Increasing wavelengths in nm; None for a uniform spectrum.
    values : tuple of float
        The value at each wavelength, or the one uniform value.
    """

    wavelengths: tuple | None
    values: tuple

    @property
    def uniform(self) -> bool:
        """True for a single value at every wavelength."""
        return self.wavelengths is None


def _number(text: str, what: str) -> float:
    try:
        if "_" in text:
            raise ValueError
        return float(text)
    except ValueError:
        raise ValueError(f"could not parse {what} \"{text}\" as a number") from None


def _checked(wavelengths: list, values: list) -> Spectrum:
    if len(wavelengths) != len(values):
        raise ValueError(f"spectrum has {len(wavelengths)} wavelengths but {len(values)} values")
    if len(wavelengths) < 2:
        raise ValueError("a spectrum needs at least two wavelength:value pairs")
    if any(b <= a for a, b in zip(wavelengths, wavelengths[1:])):
        raise ValueError("spectrum wavelengths must increase strictly")
    return Spectrum(tuple(wavelengths), tuple(values))


def parse_spectrum(text: str) -> Spectrum:
    """``"0.5"`` (uniform) or ``"400:0.1, 500:0.5"`` (pairs).

    Raises
    ------
    ValueError
        On a malformed number or pair, fewer than two pairs, or wavelengths
        that do not increase.
    """
    tokens = [t for t in _SPLIT.split(text.strip()) if t]
    if len(tokens) == 1 and ":" not in tokens[0]:
        return Spectrum(None, (_number(tokens[0], "spectrum value"),))
    wavelengths, values = [], []
    for token in tokens:
        parts = token.split(":")
        if len(parts) != 2:
            raise ValueError(f"invalid spectrum entry \"{token}\" (expected wavelength:value)")
        wavelengths.append(_number(parts[0], "wavelength"))
        values.append(_number(parts[1], "spectrum value"))
    return _checked(wavelengths, values)


def spectrum_from_lists(wavelengths: str, values: str) -> Spectrum:
    """The ``wavelengths="..." values="..."`` form of ``<spectrum>``."""
    wl = [_number(t, "wavelength") for t in _SPLIT.split(wavelengths.strip()) if t]
    vals = [_number(t, "spectrum value") for t in _SPLIT.split(values.strip()) if t]
    return _checked(wl, vals)


def read_spectrum_file(path: str) -> Spectrum:
    """A text file of ``wavelength value`` lines (``#`` starts a comment line)."""
    wavelengths, values = [], []
    with open(path, "r", encoding="utf-8", errors="replace") as f:
        for lineno, line in enumerate(f, 1):
            if not line.strip() or line.lstrip().startswith("#"):
                continue
            tokens = line.split()
            if len(tokens) != 2:
                raise ValueError(f"{path}:{lineno}: expected \"wavelength value\", got "
                                 f"\"{line.strip()}\"")
            wavelengths.append(_number(tokens[0], "wavelength"))
            values.append(_number(tokens[1], "spectrum value"))
    return _checked(wavelengths, values)


def _table(table: np.ndarray, wavelength: np.ndarray) -> np.ndarray:
    """Linear interpolation of a 5 nm table on [360, 830]."""
    grid = np.linspace(cie.WAVELENGTH_MIN, cie.WAVELENGTH_MAX, len(table))
    return np.interp(wavelength, grid, table)


def list_to_srgb(wavelengths, values, bounded: bool, d65: bool) -> np.ndarray:
    """Linear sRGB of a piecewise-linear spectrum (Mitsuba's ``spectrum_list_to_srgb``).

    Parameters
    ----------
    wavelengths, values : sequences of float
        The spectrum's samples, wavelengths increasing (nm).
    bounded : bool
        Clamp the result to [0, 1] (reflectances); otherwise only at 0.
    d65 : bool
        Weight by the D65 illuminant (reflectances and unbounded values).

    Returns
    -------
    (3,) ndarray
    """
    wl = np.asarray(wavelengths, dtype=float)
    x = cie.WAVELENGTH_MIN + np.arange(STEPS) / (STEPS - 1) * (
        cie.WAVELENGTH_MAX - cie.WAVELENGTH_MIN)
    x = x[(x >= wl[0]) & (x <= wl[-1])]
    weight = np.interp(x, wl, np.asarray(values, dtype=float))
    if d65:
        weight = weight * _table(cie.D65, x) / cie.D65_Y_INTEGRAL
    xyz = np.stack([_table(t, x) for t in (cie.CIE_X, cie.CIE_Y, cie.CIE_Z)], axis=1)
    step = (cie.WAVELENGTH_MAX - cie.WAVELENGTH_MIN) / STEPS
    rgb = XYZ_TO_SRGB @ (weight @ xyz * step / cie.CIE_Y_INTEGRAL)
    clamped = np.clip(rgb, 0.0, 1.0) if bounded else np.maximum(rgb, 0.0)
    if np.any(clamped != rgb):
        # Mitsuba logs the same warning.
        warnings.warn(f"spectrum: clamping out-of-gamut colour {np.round(rgb, 6).tolist()} "
                      f"to {np.round(clamped, 6).tolist()}", stacklevel=3)
    return clamped


def to_rgb(spectrum: Spectrum, kind: str) -> np.ndarray:
    """The RGB value Mitsuba's RGB variants use for ``spectrum``.

    Parameters
    ----------
    spectrum : Spectrum
    kind : {'reflectance', 'emission', 'unbounded'}
        What the property is: a reflectance (bounded, D65-weighted), an
        emitter's radiance or intensity, or a non-emissive value that may
        exceed 1 (an index of refraction).
    """
    if kind not in KINDS:
        raise ValueError(f"kind must be one of {KINDS}, got {kind!r}")
    if spectrum.uniform:
        value = spectrum.values[0]
        if kind == "emission":
            return value * XYZ_TO_SRGB.sum(axis=1)
        return np.full(3, value)
    return list_to_srgb(spectrum.wavelengths, spectrum.values,
                        bounded=(kind == "reflectance"), d65=(kind != "emission"))
