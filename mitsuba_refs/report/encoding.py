"""Values as strict JSON (RFC 8259: no NaN or infinity), and back.

A finite float stays a number, NaN becomes ``null`` and an infinity the string ``"inf"``
or ``"-inf"`` (a deterministic difference has |z| = inf, an image black where the
reference is not a relative bias of inf). NumPy scalars and arrays become numbers and
nested lists, tuples lists, paths strings.
"""
from __future__ import annotations

import math
import os

import numpy as np

__all__ = ["plain", "number", "to_float", "to_array"]

#: How an infinity is written.
INFINITIES = {"inf": math.inf, "-inf": -math.inf}


def number(value: float):
    """A float as JSON: itself when finite, None for NaN, ``"inf"`` / ``"-inf"``."""
    value = float(value)
    if math.isfinite(value):
        return value
    if math.isnan(value):
        return None
    return "inf" if value > 0 else "-inf"


def plain(value):
    """``value`` as JSON data (dicts with str keys, lists, str, int, float, bool, None).

    Floats go through :func:`number`; anything else that JSON lacks becomes its ``str``.
    """
    if isinstance(value, dict):
        return {str(key): plain(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(item) for item in value]
    if isinstance(value, np.ndarray):
        return plain(value.tolist())
    if value is None or isinstance(value, str):
        return value
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return number(value)
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    return str(value)


def to_float(value) -> float:
    """The float a JSON value written by :func:`number` stands for (None: NaN)."""
    if value is None:
        return math.nan
    if isinstance(value, str):
        return INFINITIES.get(value, math.nan)
    return float(value)


def to_array(nested) -> np.ndarray:
    """Nested lists written by :func:`plain` as a float64 array (None: NaN, "inf": inf)."""
    values = np.asarray(nested if nested is not None else [], dtype=object)
    if values.size == 0:
        return values.astype(np.float64)
    return np.frompyfunc(to_float, 1, 1)(values).astype(np.float64)
