"""Mitsuba 3 XML -> a generic tree of :class:`Plugin` objects.

This module knows the *syntax* of the format (elements, properties,
``<default>``/``$param`` substitution, ``<include>``, ``<path>``, ``<ref>``,
``<spectrum>``, transforms) but nothing about what a given plugin means;
:mod:`pathtracer.scene.build` interprets the tree. Every node remembers its
file and line so that errors can point at it, also inside included files.

Like Mitsuba's parser, a file is read top to bottom: a ``<default>`` (and an
``<include>``'s defaults) takes effect where it stands, and the first value
given for a name wins.
"""
from __future__ import annotations

import os
import re
import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from . import spectra, transform, upgrade
from .errors import SceneError
from .xml_files import Element, FileState, find_in, read_elements, resolve_folder

# Elements that instantiate a plugin (they carry a ``type`` attribute).
PLUGIN_TAGS = {"shape", "bsdf", "emitter", "sensor", "film", "sampler",
               "rfilter", "integrator", "texture", "medium", "phase", "volume"}
# Valid Mitsuba elements this tracer refuses, with the reason shown to the user.
REFUSED_TAGS = {
    "alias": "<alias> is not supported",
}
# Allowed attributes of each property element (besides ``name``).
PROPERTY_ATTRS = {
    "float": {"value"}, "integer": {"value"}, "boolean": {"value"},
    "string": {"value"}, "rgb": {"value"},
    "spectrum": {"value", "wavelengths", "values", "filename", "type"},
    "point": {"value", "x", "y", "z"}, "vector": {"value", "x", "y", "z"},
}
#: Largest finite float32: Mitsuba's numbers are float32.
FLOAT32_MAX = float(np.finfo(np.float32).max)
#: ``<scene version="...">``: three whole numbers, as Mitsuba 3 requires.
VERSION_RE = re.compile(r"\d+\.\d+\.\d+")
PARAM_RE = re.compile(r"(?<!\\)\$([A-Za-z_][A-Za-z0-9_]*)")
SPLIT_RE = re.compile(r"[,\s]+")


@dataclass
class Prop:
    """A typed property: ``tag`` is the XML element (rgb, float, transform...)."""

    tag: str
    name: str
    value: Any
    line: int
    #: For a ``<transform>`` whose normals Mitsuba does not transform by the
    #: true inverse transpose (a ``<rotate>`` about a non-unit axis), the 4x4
    #: matrix it uses instead; None otherwise.
    normal_matrix: Any = None


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
    ref_names : dict of int to str
        For children that came from ``<ref id=".." name="..">``: child
        position -> the ``name`` the reference gave (a texture's parameter).
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
    #: On the ``<scene>`` node only: the folders of the top-level file's
    #: ``<path>`` elements, the last one first (where Mitsuba looks first).
    search_paths: list[str] = field(default_factory=list)
    ref_names: dict[int, str] = field(default_factory=dict)

    def named_children(self) -> list[tuple[str | None, "Plugin"]]:
        """(name, child) pairs: the reference's ``name`` for referenced children, else the child's own."""
        return [(self.ref_names.get(i, child.name), child) for i, child in enumerate(self.children)]

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
    """One finite floating-point number within float32's range; ValueError naming ``what`` otherwise.

    ``nan`` and ``inf`` (which Python and Mitsuba parse) would make the image
    meaningless, and Mitsuba stores numbers as float32, so a larger magnitude is
    infinite there.
    """
    try:
        if "_" in text:  # Python accepts 1_000, Mitsuba does not
            raise ValueError
        value = float(text)
    except ValueError:
        raise ValueError(f"could not parse {what} value \"{text}\" as a number") from None
    if not abs(value) <= FLOAT32_MAX:
        raise ValueError(f"{what} value \"{text}\" is not a finite number (nan, inf and "
                         f"magnitudes above float32's {FLOAT32_MAX:.4g} are refused)")
    return value


class _Reader:
    """Turns the Element tree of a file (and the files it includes) into Plugin objects."""

    def __init__(self, file: str, params: dict[str, Any], top_dir: str):
        self.file = file
        self.top_dir = top_dir
        self.params = {k: _param_text(v) for k, v in params.items()}
        self.given = set(params)
        self.used: set[str] = set()
        self.declared: set[str] = set()
        self.ids: dict[str, Plugin] = {}
        self.search_paths: list[str] = []
        self.defaults_later: dict[str, int] = {}
        #: Files (display names) of Mitsuba 0.x whose elements are upgraded (:mod:`.upgrade`).
        self.legacy_files: set[str] = set()

    # -- substitution -----------------------------------------------------
    def substitute(self, el: Element, owner: str) -> dict[str, str]:
        out = {}
        for key, value in el.attrs.items():
            def repl(m):
                name = m.group(1)
                if name not in self.params:
                    later = self.defaults_later.get((el.file, name))
                    hint = (f"; its <default> on line {later} comes after this use, and Mitsuba "
                            "reads the file top to bottom" if later else
                            f"; pass it to load_scene or add <default name=\"{name}\" "
                            "value=\"...\"/> before this line")
                    raise SceneError(f"undefined parameter ${name} (attribute {key}=\"{value}\")"
                                     + hint, el.file, el.line, owner)
                self.used.add(name)
                return self.params[name]
            out[key] = PARAM_RE.sub(repl, value).replace("\\$", "$")
        return out

    # -- tree -------------------------------------------------------------
    def scene(self, root: Element, state: FileState) -> Plugin:
        self.check_root(root)
        plugin = Plugin("scene", "", None, None, root.file, root.line)
        self.fill_scene(plugin, root, state, top=True)
        plugin.search_paths = list(self.search_paths)
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

    def check_root(self, root: Element) -> None:
        if root.tag != "scene":
            raise SceneError(f"the root element must be <scene>, not <{root.tag}>",
                             root.file, root.line, f"<{root.tag}>")
        attrs = self.substitute(root, "<scene>")
        unknown = set(attrs) - {"version"}
        if unknown:
            raise SceneError(f"unknown attribute(s) {sorted(unknown)}", root.file, root.line,
                             "<scene>")
        if "version" not in attrs:
            raise SceneError("missing attribute version (Mitsuba 3 requires it), e.g. "
                             "<scene version=\"3.0.0\">", root.file, root.line, "<scene>")
        if not VERSION_RE.fullmatch(attrs["version"]):
            raise SceneError(f"invalid version \"{attrs['version']}\": Mitsuba 3 needs three "
                             "numbers, e.g. version=\"3.0.0\"", root.file, root.line, "<scene>")
        if upgrade.needs_upgrade(attrs["version"]):
            self.legacy_files.add(root.file)

    def fill_scene(self, plugin: Plugin, root: Element, state: FileState, top: bool) -> None:
        """The children of a ``<scene>`` (the top file's or an included one's)."""
        for el in root.children:
            if el.tag == "default":  # remembered only to explain a use before it
                self.defaults_later.setdefault((el.file, el.attrs.get("name")), el.line)
        for el in root.children:
            if el.tag == "default":
                a = self.substitute(el, "<default>")
                if set(a) != {"name", "value"}:
                    raise SceneError("<default> needs exactly the attributes name and value",
                                     el.file, el.line, "<default>")
                # The first value wins: load_scene's, then the earliest <default>.
                self.params.setdefault(a["name"], a["value"])
                self.declared.add(a["name"])
            elif el.tag == "path":
                self.add_path(el, state, top)
            elif el.tag == "include":
                self.include(plugin, el, state)
            else:
                self.child(plugin, el, state)

    def add_path(self, el: Element, state: FileState, top: bool) -> None:
        attrs = self.substitute(el, "<path>")
        if set(attrs) != {"value"}:
            raise SceneError("<path> needs exactly the attribute value", el.file, el.line, "<path>")
        folder, tried = resolve_folder(el, attrs["value"], state.lookup)
        if folder is None:
            raise SceneError(f"folder \"{attrs['value']}\" not found (looked for "
                             f"{', '.join(tried)})", el.file, el.line, "<path>")
        state.add_path(folder)
        if top:
            # Only the top-level file's <path>s reach mesh and texture
            # names: Mitsuba drops an included file's <path>s at its end,
            # and loads meshes after the whole file has been read.
            self.search_paths.insert(0, folder)

    def include(self, plugin: Plugin, el: Element, state: FileState) -> None:
        attrs = self.substitute(el, "<include>")
        if set(attrs) != {"filename"}:
            raise SceneError("<include> needs exactly the attribute filename",
                             el.file, el.line, "<include>")
        name = attrs["filename"]
        # Mitsuba tries the including file's folder before its file resolver.
        lookup = state.include_lookup(el)
        target = find_in(name, lookup)
        if target is None:
            raise SceneError(f"file \"{name}\" not found (looked in "
                             f"{', '.join(dict.fromkeys(lookup))})", el.file, el.line, "<include>")
        root, inner = state.enter(el, target, self.top_dir)
        self.check_root(root)
        self.fill_scene(plugin, root, inner, top=False)

    def fill(self, plugin: Plugin, el: Element, state: FileState) -> None:
        for child in el.children:
            self.child(plugin, child, state)

    def child(self, plugin: Plugin, child: Element, state: FileState) -> None:
        """One nested element of ``plugin``: a plugin, reference, property or
        ``<include>`` (whose file's elements then become ``plugin``'s, as in Mitsuba)."""
        tag = child.tag
        if tag == "include":
            self.include(plugin, child, state)
            return
        if tag in ("default", "path"):
            raise SceneError(f"<{tag}> must be a direct child of <scene>",
                             child.file, child.line, plugin.label)
        attrs = self.substitute(child, plugin.label)
        if tag in REFUSED_TAGS:
            what = f'<{tag} type="{attrs["type"]}">' if "type" in attrs else f"<{tag}>"
            raise SceneError(REFUSED_TAGS[tag], child.file, child.line, what)
        if tag in PLUGIN_TAGS:
            plugin.children.append(self.plugin(child, attrs, state))
        elif tag == "ref":
            if "id" not in attrs or set(attrs) - {"id", "name"}:
                raise SceneError("<ref> needs an id (and optionally a name)",
                                 child.file, child.line, plugin.label)
            plugin.children.append(_Ref(attrs["id"], attrs.get("name"), child.line))
        elif tag == "transform":
            matrix, normal_matrix = self.transform(child, plugin)
            self.add_prop(plugin, "transform", attrs, child, matrix)
            plugin.props[attrs["name"]].normal_matrix = normal_matrix
        elif tag in PROPERTY_ATTRS:
            self.add_prop(plugin, tag, attrs, child, self.prop_value(tag, attrs, child, plugin))
        else:
            raise SceneError(f"unknown element <{tag}>", child.file, child.line, plugin.label)

    def plugin(self, el: Element, attrs: dict[str, str], state: FileState) -> Plugin:
        if "type" not in attrs:
            raise SceneError("missing attribute type", el.file, el.line, f"<{el.tag}>")
        unknown = set(attrs) - {"type", "id", "name"}
        p = Plugin(el.tag, attrs["type"], attrs.get("id"), attrs.get("name"), el.file, el.line)
        if unknown:
            raise p.error(f"unknown attribute(s) {sorted(unknown)}")
        if p.id is not None:
            if p.id in self.ids:
                first = self.ids[p.id]
                raise p.error(f"duplicate id \"{p.id}\" (first defined in {first.file} "
                              f"on line {first.line})")
            self.ids[p.id] = p
        self.fill(p, el, state)
        if el.file in self.legacy_files:
            upgrade.upgrade_plugin(p, Prop)
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
            if tag == "spectrum":
                return self.spectrum(attrs)
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

    def spectrum(self, attrs: dict) -> spectra.Spectrum:
        """A ``<spectrum>`` given by value, by wavelengths + values, or by a file."""
        given = set(attrs) - {"name"}
        if "type" in given:
            raise ValueError(f"spectrum plugins (type=\"{attrs['type']}\") are not supported; "
                             "give value=\"wavelength:value, ...\" or one value")
        if given not in ({"value"}, {"wavelengths", "values"}, {"filename"}):
            raise ValueError("<spectrum> needs value=\"...\", or wavelengths and values, "
                             "or filename")
        if "value" in attrs:
            return spectra.parse_spectrum(attrs["value"])
        if "filename" in attrs:
            lookup = self.search_paths + [self.top_dir, os.getcwd()]
            path = find_in(attrs["filename"], lookup)
            if path is None:
                raise ValueError(f"spectrum file \"{attrs['filename']}\" not found "
                                 f"(looked in {', '.join(lookup)})")
            return spectra.read_spectrum_file(path)
        return spectra.spectrum_from_lists(attrs["wavelengths"], attrs["values"])

    def transform(self, el: Element, plugin: Plugin) -> tuple[np.ndarray, np.ndarray | None]:
        """The matrix of a ``<transform>`` and, when it differs from the true
        inverse transpose, the matrix Mitsuba transforms normals with."""
        m = np.eye(4)
        normal_m = np.eye(4)
        tracked = False
        for op in el.children:
            attrs = self.substitute(op, plugin.label)
            try:
                op_m = _transform_op(op.tag, attrs)
            except ValueError as e:
                raise plugin.error(f"<{op.tag}>: {e}", op.line) from None
            m = op_m @ m
            if op.tag == "rotate":
                # Mitsuba stores a rotation's inverse as its transpose, which
                # is wrong when the axis is not a unit vector; its normals
                # then use the rotation matrix itself.
                tracked |= not transform.is_orthonormal(op_m)
                normal_m = op_m @ normal_m
            elif np.all(np.isfinite(op_m)) and abs(np.linalg.det(op_m)) > 0:
                normal_m = np.linalg.inv(op_m).T @ normal_m
        try:
            transform.check_affine(m)
        except ValueError as e:
            raise plugin.error(str(e), el.line) from None
        return m, (normal_m if tracked else None)

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
                if child.name is not None:
                    plugin.ref_names[i] = child.name
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
    top_dir = os.path.dirname(os.path.abspath(path))
    return _Reader(name, params or {}, top_dir).scene(root, FileState.top(path))
