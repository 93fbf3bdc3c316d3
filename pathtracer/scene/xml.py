"""Mitsuba 3 XML -> a generic tree of :class:`Plugin` objects.

This module knows the *syntax* of the format (elements, properties,
``<default>``/``$param`` substitution, ``<ref>``, transforms) but nothing about
what a given plugin means; :mod:`pathtracer.scene.build` interprets the tree.
Every node remembers its file and line so that errors can point at it.
"""
from __future__ import annotations

import os
import re
import warnings
from dataclasses import dataclass, field
from typing import Any
from xml.parsers import expat

import numpy as np

from . import transform
from .errors import SceneError

# Elements that instantiate a plugin (they carry a ``type`` attribute).
PLUGIN_TAGS = {"shape", "bsdf", "emitter", "sensor", "film", "sampler",
               "rfilter", "integrator"}
# Valid Mitsuba elements this tracer refuses, with the reason shown to the user.
REFUSED_TAGS = {
    "texture": "textures are not supported by this tracer; use an <rgb> value instead",
    "spectrum": "<spectrum> is not supported by this tracer (it renders in RGB); "
                "use <rgb> instead",
    "medium": "participating media are not supported",
    "phase": "participating media are not supported",
    "volume": "participating media are not supported",
    "include": "<include> is not supported; put everything in one file",
    "alias": "<alias> is not supported",
    "path": "<path> is not supported; give file names relative to the scene file",
}
# Allowed attributes of each property element (besides ``name``).
PROPERTY_ATTRS = {
    "float": {"value"}, "integer": {"value"}, "boolean": {"value"},
    "string": {"value"}, "rgb": {"value"},
    "point": {"value", "x", "y", "z"}, "vector": {"value", "x", "y", "z"},
}
PARAM_RE = re.compile(r"(?<!\\)\$([A-Za-z_][A-Za-z0-9_]*)")
SPLIT_RE = re.compile(r"[,\s]+")


@dataclass
class Element:
    """A raw XML element with the line it starts on."""

    tag: str
    attrs: dict[str, str]
    line: int
    children: list["Element"] = field(default_factory=list)


@dataclass
class Prop:
    """A typed property: ``tag`` is the XML element (rgb, float, transform...)."""

    tag: str
    name: str
    value: Any
    line: int


@dataclass(eq=False)
class Plugin:
    """One ``<shape>``, ``<bsdf>``, ... element after parsing.

    Attributes
    ----------
    kind : str
        The element name: ``'scene'``, ``'shape'``, ``'bsdf'``, ...
    type : str
        The ``type`` attribute (empty for ``<scene>``).
    id : str or None
        The ``id`` attribute.
    name : str or None
        The ``name`` attribute of a nested plugin (e.g. ``name="bsdf"``).
    props : dict of str to Prop
    children : list of Plugin
        Nested plugins in document order; ``<ref>`` are already resolved, so
        one referenced Plugin can appear as the child of several others.
    file, line : where the element starts.
    """

    kind: str
    type: str
    id: str | None
    name: str | None
    file: str
    line: int
    props: dict[str, Prop] = field(default_factory=dict)
    children: list["Plugin"] = field(default_factory=list)

    @property
    def label(self) -> str:
        """The element as the user wrote it, e.g. ``<bsdf type="diffuse">``."""
        return f'<{self.kind} type="{self.type}">' if self.type else f"<{self.kind}>"

    def error(self, message: str, line: int | None = None) -> SceneError:
        """A :class:`SceneError` located at this plugin (or at ``line`` inside it)."""
        return SceneError(message, self.file, self.line if line is None else line, self.label)


@dataclass
class _Ref:
    id: str
    name: str | None
    line: int


def read_elements(path: str, display: str) -> Element:
    """Parse an XML file into :class:`Element` objects with line numbers.

    ``display`` is the file name shown in error messages.

    Raises
    ------
    SceneError
        On an XML syntax error, with the line reported by expat.
    """
    with open(path, "rb") as f:
        data = f.read()
    parser = expat.ParserCreate()
    stack: list[Element] = []
    roots: list[Element] = []

    def start(tag, attrs):
        el = Element(tag, dict(attrs), parser.CurrentLineNumber)
        (stack[-1].children if stack else roots).append(el)
        stack.append(el)

    def end(tag):
        stack.pop()

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    try:
        parser.Parse(data, True)
    except expat.ExpatError as e:
        raise SceneError(f"XML syntax error: {expat.ErrorString(e.code)} (column {e.offset + 1})",
                         display, e.lineno) from None
    return roots[0]


def parse_floats(text: str, count: tuple[int, ...], what: str) -> np.ndarray:
    """Numbers separated by commas and/or whitespace.

    Raises ValueError (the caller adds the location) on a malformed number or a
    wrong count.
    """
    tokens = [t for t in SPLIT_RE.split(text.strip()) if t]
    if len(tokens) not in count:
        want = " or ".join(str(c) for c in count)
        raise ValueError(f"{what} needs {want} number(s), got {len(tokens)} in \"{text}\"")
    return np.array([parse_float(t, what) for t in tokens])


def parse_float(text: str, what: str) -> float:
    """One floating-point number; ValueError naming ``what`` otherwise."""
    try:
        if "_" in text:  # Python accepts 1_000, Mitsuba does not
            raise ValueError
        return float(text)
    except ValueError:
        raise ValueError(f"could not parse {what} value \"{text}\" as a number") from None


class _Reader:
    """Turns the Element tree of one file into Plugin objects."""

    def __init__(self, file: str, params: dict[str, Any]):
        self.file = file
        self.params = {k: _param_text(v) for k, v in params.items()}
        self.given = set(params)
        self.used: set[str] = set()
        self.declared: set[str] = set()
        self.ids: dict[str, Plugin] = {}

    # -- substitution -----------------------------------------------------
    def substitute(self, el: Element, owner: str) -> dict[str, str]:
        out = {}
        for key, value in el.attrs.items():
            def repl(m):
                name = m.group(1)
                if name not in self.params:
                    raise SceneError(f"undefined parameter ${name} (attribute {key}=\"{value}\"); "
                                     f"pass it to load_scene or add <default name=\"{name}\" value=\"...\"/>",
                                     self.file, el.line, owner)
                self.used.add(name)
                return self.params[name]
            out[key] = PARAM_RE.sub(repl, value).replace("\\$", "$")
        return out

    # -- tree -------------------------------------------------------------
    def scene(self, root: Element) -> Plugin:
        if root.tag != "scene":
            raise SceneError(f"the root element must be <scene>, not <{root.tag}>",
                             self.file, root.line)
        attrs = self.substitute(root, "<scene>")
        unknown = set(attrs) - {"version"}
        if unknown:
            raise SceneError(f"unknown attribute(s) {sorted(unknown)}", self.file, root.line, "<scene>")
        # Defaults first (params given to load_scene win), so that a
        # parameter can be used anywhere in the file.
        for el in root.children:
            if el.tag == "default":
                a = self.substitute(el, "<default>")
                if set(a) != {"name", "value"}:
                    raise SceneError("<default> needs exactly the attributes name and value",
                                     self.file, el.line, "<default>")
                self.params.setdefault(a["name"], a["value"])
                self.declared.add(a["name"])
        plugin = Plugin("scene", "", None, None, self.file, root.line)
        self.fill(plugin, root, top_level=True)
        self.resolve(plugin, set())
        undeclared = sorted(self.given - self.used - self.declared)
        if undeclared:
            # Mitsuba would only log this; an error keeps a value that reaches neither
            # renderer (or only one of them) from passing unnoticed.
            raise SceneError(f"parameter(s) {', '.join(undeclared)} not declared by the file (no "
                             "<default> and no $name use them; declared: "
                             f"{', '.join(sorted(self.declared | self.used)) or 'none'}); a literal "
                             "film size, sample count or path length is overridden with "
                             "--resolution, --spp or --max-depth", self.file, root.line, "<scene>")
        unused = sorted(self.given - self.used)
        if unused:
            # Declared but never used: harmless on both sides (Mitsuba accepts it too).
            warnings.warn(f"{self.file}: parameters not used by the scene: {', '.join(unused)}",
                          stacklevel=4)
        return plugin

    def fill(self, plugin: Plugin, el: Element, top_level: bool = False) -> None:
        for child in el.children:
            tag = child.tag
            if tag == "default":
                if not top_level:
                    raise SceneError("<default> must be a direct child of <scene>",
                                     self.file, child.line, plugin.label)
                continue
            attrs = self.substitute(child, plugin.label)
            if tag in REFUSED_TAGS:
                what = f'<{tag} type="{attrs["type"]}">' if "type" in attrs else f"<{tag}>"
                raise SceneError(REFUSED_TAGS[tag], self.file, child.line, what)
            if tag in PLUGIN_TAGS:
                plugin.children.append(self.plugin(child, attrs))
            elif tag == "ref":
                if "id" not in attrs or set(attrs) - {"id", "name"}:
                    raise SceneError("<ref> needs an id (and optionally a name)",
                                     self.file, child.line, plugin.label)
                plugin.children.append(_Ref(attrs["id"], attrs.get("name"), child.line))
            elif tag == "transform":
                self.add_prop(plugin, "transform", attrs, child, self.transform(child, plugin))
            elif tag in PROPERTY_ATTRS:
                self.add_prop(plugin, tag, attrs, child, self.prop_value(tag, attrs, child, plugin))
            else:
                raise SceneError(f"unknown element <{tag}>", self.file, child.line, plugin.label)

    def plugin(self, el: Element, attrs: dict[str, str]) -> Plugin:
        if "type" not in attrs:
            raise SceneError("missing attribute type", self.file, el.line, f"<{el.tag}>")
        unknown = set(attrs) - {"type", "id", "name"}
        p = Plugin(el.tag, attrs["type"], attrs.get("id"), attrs.get("name"), self.file, el.line)
        if unknown:
            raise p.error(f"unknown attribute(s) {sorted(unknown)}")
        if p.id is not None:
            if p.id in self.ids:
                raise p.error(f"duplicate id \"{p.id}\" (first defined on line {self.ids[p.id].line})")
            self.ids[p.id] = p
        self.fill(p, el)
        return p

    def add_prop(self, plugin: Plugin, tag: str, attrs: dict, el: Element, value: Any) -> None:
        name = attrs.get("name")
        if not name:
            raise plugin.error(f"<{tag}> needs a name attribute", el.line)
        if name in plugin.props:
            raise plugin.error(f"property \"{name}\" given twice (also on line "
                               f"{plugin.props[name].line})", el.line)
        plugin.props[name] = Prop(tag, name, value, el.line)

    def prop_value(self, tag: str, attrs: dict, el: Element, plugin: Plugin) -> Any:
        unknown = set(attrs) - PROPERTY_ATTRS[tag] - {"name"}
        if unknown:
            raise plugin.error(f"<{tag}> has unknown attribute(s) {sorted(unknown)}", el.line)
        try:
            if tag in ("point", "vector"):
                return _xyz(attrs, 0.0, f"<{tag} name=\"{attrs.get('name')}\">")
            if "value" not in attrs:
                raise ValueError(f"<{tag}> needs a value attribute")
            text = attrs["value"]
            if tag == "float":
                return parse_float(text.strip(), f"<float name=\"{attrs.get('name')}\">")
            if tag == "integer":
                try:
                    return int(text.strip())
                except ValueError:
                    raise ValueError(f"could not parse integer value \"{text}\"") from None
            if tag == "boolean":
                if text.strip().lower() not in ("true", "false"):
                    raise ValueError(f"boolean value must be true or false, got \"{text}\"")
                return text.strip().lower() == "true"
            if tag == "rgb":
                rgb = parse_floats(text, (1, 3), f"<rgb name=\"{attrs.get('name')}\">")
                return np.broadcast_to(rgb, (3,)).astype(float)
            return text  # string
        except ValueError as e:
            raise plugin.error(str(e), el.line) from None

    def transform(self, el: Element, plugin: Plugin) -> np.ndarray:
        m = np.eye(4)
        for op in el.children:
            attrs = self.substitute(op, plugin.label)
            try:
                m = _transform_op(op.tag, attrs) @ m
            except ValueError as e:
                raise plugin.error(f"<{op.tag}>: {e}", op.line) from None
        try:
            transform.check_affine(m)
        except ValueError as e:
            raise plugin.error(str(e), el.line) from None
        return m

    def resolve(self, plugin: Plugin, active: set) -> None:
        """Replace _Ref placeholders by the Plugin they name."""
        active = active | {id(plugin)}
        for i, child in enumerate(plugin.children):
            if isinstance(child, _Ref):
                target = self.ids.get(child.id)
                if target is None:
                    known = ", ".join(sorted(self.ids)) or "none"
                    raise plugin.error(f"<ref id=\"{child.id}\">: no element with this id "
                                       f"(ids defined: {known})", child.line)
                plugin.children[i] = target
            elif id(child) not in active:
                self.resolve(child, active)


def _param_text(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float, str, np.integer, np.floating)):
        return str(value)
    raise TypeError(f"scene parameter values must be str, int or float, not {type(value).__name__}")


def _xyz(attrs: dict, default: float, what: str) -> np.ndarray:
    """A 3-vector from ``value="x,y,z"`` / ``value="s"`` or ``x= y= z=``."""
    if "value" in attrs:
        if set(attrs) & {"x", "y", "z"}:
            raise ValueError("cannot mix value with x/y/z attributes")
        v = parse_floats(attrs["value"], (1, 3), what)
        return np.broadcast_to(v, (3,)).astype(float)
    return np.array([parse_float(attrs[k].strip(), what) if k in attrs else default
                     for k in "xyz"])


def _check_attrs(tag: str, attrs: dict, allowed: set, required: set = frozenset()) -> None:
    unknown = set(attrs) - allowed
    if unknown:
        raise ValueError(f"unknown attribute(s) {sorted(unknown)}")
    missing = set(required) - set(attrs)
    if missing:
        raise ValueError(f"missing attribute(s) {sorted(missing)}")


def _transform_op(tag: str, attrs: dict) -> np.ndarray:
    """The matrix of one element inside ``<transform>``."""
    if tag == "translate":
        _check_attrs(tag, attrs, {"value", "x", "y", "z"})
        return transform.translate(_xyz(attrs, 0.0, "<translate>"))
    if tag == "scale":
        _check_attrs(tag, attrs, {"value", "x", "y", "z"})
        return transform.scale(_xyz(attrs, 1.0, "<scale>"))
    if tag == "rotate":
        _check_attrs(tag, attrs, {"value", "x", "y", "z", "angle"}, {"angle"})
        axis = _xyz({k: v for k, v in attrs.items() if k != "angle"}, 0.0, "<rotate>")
        return transform.rotate(axis, parse_float(attrs["angle"].strip(), "angle"))
    if tag == "matrix":
        _check_attrs(tag, attrs, {"value"}, {"value"})
        return transform.from_values(parse_floats(attrs["value"], (9, 16), "<matrix>"))
    if tag == "lookat":
        _check_attrs(tag, attrs, {"origin", "target", "up"}, {"origin", "target"})
        up = parse_floats(attrs["up"], (3,), "up") if "up" in attrs else None
        return transform.look_at(parse_floats(attrs["origin"], (3,), "origin"),
                                 parse_floats(attrs["target"], (3,), "target"), up)
    raise ValueError("unknown transform element (expected translate, rotate, scale, "
                     "matrix or lookat)")


def parse_file(path: str, params: dict[str, Any] | None = None,
               display_name: str | None = None) -> Plugin:
    """Read a Mitsuba 3 scene file into a :class:`Plugin` tree.

    Parameters
    ----------
    path : str
        The XML file.
    params : dict, optional
        Values for ``$name`` substitution; they override ``<default>`` values.
    display_name : str, optional
        Name used in error messages (default: the file's base name).

    Returns
    -------
    Plugin
        The ``<scene>`` node, with references resolved.

    Raises
    ------
    SceneError
        For any syntax problem, located by file, line and element.
    """
    name = display_name or os.path.basename(path)
    root = read_elements(path, name)
    return _Reader(name, params or {}).scene(root)
