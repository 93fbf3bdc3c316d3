"""Mesh attributes of a PLY file: the properties that are not positions, normals, texture
coordinates or face indices, grouped as Mitsuba 3.9.1's PLY reader groups them.

* A colour: properties ``r, g, b`` (or ``red, green, blue``), with ``a`` / ``alpha``,
  become ``<element>_color`` (3 or 4 channels).
* Other properties named ``<prefix>_<postfix>`` with a one-letter postfix: consecutive
  ones of the same prefix form one attribute when their postfixes run through one of the
  sequences ``x y z w``, ``r g b a``, ``0 1 2 3`` or ``1 2 3 4`` from its start, and count
  1 or 3 fields; it is named ``<element>_<prefix>`` (``<element>_<prefix>_color`` for the
  ``r g b`` sequence). Anything else is ignored, as Mitsuba ignores it (with a warning).
* Values are taken as stored, integers included: Mitsuba 3.9.1 keeps a ``uchar`` colour
  of 255 as 255 (it warns that colours are expected in [0, 1]; measured on a binary and an
  ASCII file), so a file should store its colours as floats.
"""
from __future__ import annotations

import numpy as np

#: Postfix sequences: column j is one sequence, row i its i-th letter.
POSTFIXES = ("xr01", "yg12", "zb23", "wa34")


def _as_float(column: np.ndarray) -> np.ndarray:
    """A property's values as float64, as stored (see the module docstring)."""
    return column.astype(np.float64)


def ply_attributes(element: str, records: np.ndarray, reserved: set) -> dict:
    """``{name: (count, C) float64}`` of the attributes of one element's records
    (``element`` is ``"vertex_"`` or ``"face_"``)."""
    names = [n for n in records.dtype.names if not n.endswith(".count")]
    rename = {}
    if not {"r", "g", "b"} <= set(names) and {"red", "green", "blue"} <= set(names):
        rename = {"red": "r", "green": "g", "blue": "b", "alpha": "a"}
    fields = [(rename.get(n, n), n) for n in names]
    present = {mitsuba_name for mitsuba_name, _ in fields}
    out = {}
    if {"r", "g", "b"} <= present:
        channels = ["r", "g", "b"] + (["a"] if "a" in present else [])
        source = {m: n for m, n in fields}
        out[element + "color"] = np.stack([_as_float(records[source[c]]) for c in channels], axis=1)
    reserved = set(reserved) | {"r", "g", "b", "a"}
    groups = []   # (prefix, [(postfix, file name)]) of consecutive fields
    for mitsuba_name, file_name in fields:
        if mitsuba_name in reserved or "_" not in mitsuba_name:
            groups.append(None)       # breaks a run of one prefix
            continue
        prefix, postfix = mitsuba_name.rsplit("_", 1)
        if groups and groups[-1] is not None and groups[-1][0] == prefix:
            groups[-1][1].append((postfix, file_name))
        else:
            groups.append((prefix, [(postfix, file_name)]))
    seen = set()
    for group in groups:
        if group is None:
            continue
        prefix, members = group
        if prefix in seen:
            continue
        seen.add(prefix)
        first = members[0][0]
        if len(first) != 1 or first not in POSTFIXES[0]:
            continue
        category = POSTFIXES[0].index(first)
        expected = [row[category] for row in POSTFIXES]
        if [p for p, _ in members] != expected[:len(members)] or len(members) not in (1, 3):
            continue
        suffix = "_color" if category == 1 else ""
        out[element + prefix + suffix] = np.stack([_as_float(records[n]) for _, n in members],
                                                  axis=1)
    return out
