"""Files of Mitsuba 0.x (``<scene version="0.5.0">``, ``"0.6.0"``): the renames Mitsuba 3 applies on load.

Mitsuba 3.9.1 upgrades every element written in a file whose version is below 2.0.0
(``transform_upgrade`` in its ``src/core/parser.cpp``), element by element, by the version
of the file the element is written in (an included file keeps its own version). On each
plugin, in the order its properties and nested plugins were written:

1. every name (properties, nested plugins' ``name=``, ``<ref name=>``) goes from camelCase
   to underscore_case (:func:`camel_to_underscore`): ``toWorld`` -> ``to_world``,
   ``intIOR`` -> ``int_ior``, ``maxDepth`` -> ``max_depth``; a rename whose new name is
   already taken is skipped, and the old name stays (and is then refused as unknown);
2. on a ``diffuse`` BSDF, ``diffuse_reflectance`` becomes ``reflectance`` (skipped as well
   when ``reflectance`` is given);
3. ``uoffset``, ``voffset``, ``uscale``, ``vscale`` (numbers; defaults 0, 0, 1, 1) are replaced
   by ``to_uv = scale(uscale, vscale, 1) @ translate(uoffset, voffset, 0)``:
   ``uv' = (uscale (u + uoffset), vscale (v + voffset))``. With a ``to_uv`` already given,
   Mitsuba refuses the file ("specified multiple times"), and so does the tracer.

Nothing else changes: plugin types, element names and values are read as Mitsuba 3
reads them, so a 0.x plugin or element Mitsuba 3 no longer has (``ldrfilm``, ``<srgb>``,
``<lookAt>``) is refused, as Mitsuba refuses it.
"""
from __future__ import annotations

import numpy as np

from . import transform

#: Files below this version are upgraded (Mitsuba's ``Version(2, 0, 0)``).
UPGRADE_BELOW = (2, 0, 0)
#: The uv properties of 0.x, in Mitsuba's order, with their defaults.
UV_PARAMS = {"uoffset": 0.0, "voffset": 0.0, "uscale": 1.0, "vscale": 1.0}


def needs_upgrade(version: str) -> bool:
    """Whether a file of ``version`` (three numbers, ``"0.6.0"``) is upgraded on load."""
    parts = tuple(int(p) for p in version.replace(" ", ".").split(".") if p)
    return parts < UPGRADE_BELOW


def camel_to_underscore(name: str) -> str:
    """Mitsuba's ``camel_to_underscore_case``.

    An upper-case letter that follows a lower-case one starts a new word: it becomes ``_``
    and its lower case, and so do the upper-case letters right after it (``intIOR`` ->
    ``int_ior``, ``diffuseReflectance`` -> ``diffuse_reflectance``). Everything else is kept
    (``HDRFilm``, ``uscale``, ``alpha_u``, digits). Only ASCII letters count, as in C's
    ``islower``/``isupper``.
    """
    out = []
    i, n = 0, len(name)
    while i < n:
        c = name[i]
        if i > 0 and _lower(name[i - 1]) and _upper(c):
            out.append("_" + c.lower())
            while i + 1 < n and _upper(name[i + 1]):
                i += 1
                out.append(name[i].lower())
        else:
            out.append(c)
        i += 1
    return "".join(out)


def _lower(c: str) -> bool:
    return "a" <= c <= "z"


def _upper(c: str) -> bool:
    return "A" <= c <= "Z"


def upgrade_plugin(plugin, make_prop) -> None:
    """Apply the 0.x upgrade to one parsed plugin (a :class:`~pathtracer.scene.xml.Plugin`
    whose children may still be unresolved ``<ref>`` placeholders with a ``name``);
    ``make_prop(tag, name, value, line)`` makes the ``to_uv`` property.

    Raises
    ------
    SceneError
        A uv property that is not a number, or ``uoffset``... together with ``to_uv``.
    """
    # Every name the plugin holds, in the order it was written: (line, kind, key).
    entries = [(prop.line, 0, key) for key, prop in plugin.props.items()]
    entries += [(getattr(child, "line", 0), 1, i) for i, child in enumerate(plugin.children)
                if child.name is not None]
    taken = set(plugin.props) | {child.name for child in plugin.children if child.name}
    for _, kind, key in sorted(entries, key=lambda e: (e[0], e[1])):
        old = key if kind == 0 else plugin.children[key].name
        new = camel_to_underscore(old)
        if new == old or new in taken:
            continue
        taken.discard(old)
        taken.add(new)
        if kind == 0:
            _rename_prop(plugin, old, new)
        else:
            plugin.children[key].name = new
    if plugin.kind == "bsdf" and plugin.type == "diffuse" and "diffuse_reflectance" in taken \
            and "reflectance" not in taken:
        if "diffuse_reflectance" in plugin.props:
            _rename_prop(plugin, "diffuse_reflectance", "reflectance")
        for child in plugin.children:
            if child.name == "diffuse_reflectance":
                child.name = "reflectance"
    _uv_to_transform(plugin, make_prop)


def _rename_prop(plugin, old: str, new: str) -> None:
    """Rename a property, keeping the order of the others."""
    props = {}
    for key, prop in plugin.props.items():
        if key == old:
            prop.name = new
            key = new
        props[key] = prop
    plugin.props.clear()
    plugin.props.update(props)


def _uv_to_transform(plugin, make_prop) -> None:
    """``uoffset``/``voffset``/``uscale``/``vscale`` -> a ``to_uv`` transform."""
    given = [name for name in UV_PARAMS if name in plugin.props]
    if not given:
        return
    values = dict(UV_PARAMS)
    for name in given:
        prop = plugin.props[name]
        if prop.tag not in ("float", "integer"):
            raise plugin.error(f"\"{name}\" of a Mitsuba 0.x file must be a number (<float>), "
                               f"not <{prop.tag}>", prop.line)
        values[name] = float(prop.value)
    line = min(plugin.props[name].line for name in given)
    if "to_uv" in plugin.props:
        raise plugin.error(f"{', '.join(given)} (Mitsuba 0.x) and to_uv given together: Mitsuba "
                           "turns the former into to_uv and refuses the file (\"Property "
                           "\\\"to_uv\\\" was specified multiple times\")", plugin.props["to_uv"].line)
    for name in given:
        del plugin.props[name]
    matrix = (transform.scale(np.array([values["uscale"], values["vscale"], 1.0]))
              @ transform.translate(np.array([values["uoffset"], values["voffset"], 0.0])))
    plugin.props["to_uv"] = make_prop("transform", "to_uv", matrix, line)
