"""Mitsuba's ``shapegroup`` and ``instance`` shapes, flattened into ordinary shapes.

A ``shapegroup`` holds shapes that are not drawn themselves; each ``instance`` that
references it (``<ref id="..."/>``) draws every one of them with the instance's
``to_world`` applied after the shape's own. Mitsuba intersects an instance by moving the
ray into the group's space; the tracer instead builds the transformed shapes, which gives
the same surfaces, normals (inverse transpose of the composed map) and texture
coordinates. A BSDF inside the group is shared by all its instances.
"""
from __future__ import annotations

import numpy as np

from ..scene.properties import Props
from ..scene.registry import register
from ..scene.xml import Plugin


def flatten(shapes: list[Plugin]):
    """Yield ``(shape plugin, parent to_world or None)`` for every shape to draw: the
    top-level shapes except groups, and each group's shapes once per instance."""
    for plugin in shapes:
        if plugin.type == "shapegroup":
            _check_group(plugin)
        elif plugin.type == "instance":
            group, to_world = _instance(plugin)
            for child in group.children:
                if child.kind == "shape":
                    yield child, to_world
        else:
            yield plugin, None


@register("shape", "shapegroup", "instance")
def create(props: Props) -> None:
    """Groups and instances have no primitives of their own: :func:`flatten` replaces them
    by the shapes they draw before any shape is built, so none should reach here."""
    raise props.plugin.error(f"a {props.plugin.type} is allowed only at the top level of the "
                             "scene, where it is expanded into the shapes it draws")


def _check_group(group: Plugin) -> None:
    """A group holds shapes only (Mitsuba: no emitters, no nested groups or instances)."""
    if group.props:
        name = next(iter(group.props))
        raise group.error(f"unsupported property \"{name}\" (a shapegroup takes only shapes)",
                          group.props[name].line)
    for child in group.children:
        if child.kind != "shape":
            raise child.error(f"<{child.kind}> is not allowed inside a shapegroup (only shapes)")
        if child.type in ("shapegroup", "instance"):
            raise child.error("a shapegroup cannot hold another shapegroup or an instance "
                              "(as in Mitsuba)")
        if any(grandchild.kind == "emitter" for grandchild in child.children):
            raise child.error("an emitter cannot be instanced (Mitsuba refuses emitters inside "
                              "a shapegroup)")


def _instance(plugin: Plugin) -> tuple[Plugin, np.ndarray]:
    """The referenced group and the instance's ``to_world``."""
    groups = [c for c in plugin.children if c.kind == "shape" and c.type == "shapegroup"]
    others = [c for c in plugin.children if not (c.kind == "shape" and c.type == "shapegroup")]
    if others:
        raise others[0].error("an instance holds only a reference to a shapegroup "
                              "(<ref id=\"...\"/>) and its to_world")
    if len(groups) != 1:
        raise plugin.error("an instance needs exactly one shapegroup (<ref id=\"...\"/>)")
    for name, prop in plugin.props.items():
        if name != "to_world":
            raise plugin.error(f"unsupported property \"{name}\" (an instance takes to_world)",
                               prop.line)
    prop = plugin.props.get("to_world")
    if prop is not None and prop.tag != "transform":
        raise plugin.error("property \"to_world\" must be a <transform>", prop.line)
    if prop is not None and prop.normal_matrix is not None:
        raise plugin.error("an instance rotated about a non-unit axis is not supported",
                           prop.line)
    to_world = np.eye(4) if prop is None else np.asarray(prop.value, dtype=np.float64)
    return groups[0], to_world
