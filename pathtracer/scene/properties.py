"""Typed, checked access to a plugin's properties, and the refusals every plugin kind shares.

Every plugin is read through :class:`Props`, which remembers which properties were
consumed: a property the tracer does not know is an error rather than being silently
ignored, because it would make the two renderers disagree. :func:`children` checks the
nested elements a plugin may have, :func:`unsupported` says why a plugin type is refused.
"""
from __future__ import annotations

import os

import numpy as np

from ..core.names import suggestion
from . import spectra
from .registry import factory, names
from .upgrade import camel_to_underscore
from .xml import Plugin

# Media and phase functions of Mitsuba 3 refused, with the reason.
NOT_IMPLEMENTED_MEDIA = {
    "rayleigh": "the Rayleigh phase function exists only in Mitsuba's spectral variants",
    "sggx": "the SGGX microflake phase function is not implemented (isotropic and hg are)",
    "blendphase": "blended phase functions are not implemented (isotropic and hg are)",
    "tabphase": "tabulated phase functions are not implemented (isotropic and hg are)",
}
# BSDF parameters that take a <texture> (and the checkerboard's colours).
TEXTURED_PARAMS = ("reflectance", "specular_reflectance", "specular_transmittance",
                   "diffuse_reflectance", "alpha", "alpha_u", "alpha_v", "color0", "color1",
                   "radiance", "irradiance")
COLOR_TAGS = ("rgb", "float", "integer", "spectrum")
# Plugins that exist in Mitsuba 3 but only make sense in other variants or
# renderers, with the reason shown to the user (merged into the errors of
# every plugin kind).
VARIANT_ONLY = {
    "polarizer": "a polarization filter: only meaningful in Mitsuba's *_polarized variants",
    "retarder": "a polarization retarder: only meaningful in Mitsuba's *_polarized variants",
    "measured_polarized": "measured polarized BSDF data: only meaningful in Mitsuba's "
                          "*_polarized variants",
    "pplastic": "a polarized plastic: only meaningful in Mitsuba's *_polarized variants",
    "stokes": "an integrator of Stokes vectors: only meaningful in Mitsuba's *_polarized variants",
    "specfilm": "a film of spectral sensitivity bands: only meaningful in Mitsuba's spectral "
                "variants",
    "prb": "a differentiable (path replay backpropagation) integrator: it renders what path "
           "renders, but only for gradients in Mitsuba's *_ad variants; use path",
    "prb_basic": "a differentiable integrator for Mitsuba's *_ad variants; use path",
    "prbvolpath": "a differentiable volumetric integrator for Mitsuba's *_ad variants",
    "direct_projective": "a projective-sampling differentiable integrator for Mitsuba's "
                         "*_ad variants; use direct",
    "prb_projective": "a projective-sampling differentiable integrator for Mitsuba's *_ad "
                      "variants; use path",
}
# Shapes that are valid in RGB variants but not implemented here (like Nori's
# stubs, the message says so rather than pretending the type is unknown).
NOT_IMPLEMENTED_SHAPES = {
    "ellipsoids": "ellipsoid point clouds",
    "ellipsoidsmesh": "ellipsoid point clouds",
    "merge": "shape merging",
}
FLOAT_TAGS = ("float", "integer")


class Props:
    """Typed, checked access to a plugin's properties, and what its factory needs besides.

    Every factory is called as ``create(props)``: the element is ``props.plugin``, and what
    the loader knows of where it stands travels here too (each kind's builder in
    :mod:`pathtracer.scene.build` and beside its plugins sets what that kind reads). Call
    :meth:`finish` after reading: any property not read is reported.

    Parameters
    ----------
    plugin : Plugin
        The element.
    folders : list of str, optional
        Where the files it names are looked up (:func:`search_folders`; default: the
        working directory).
    texture_cache : dict, optional
        Textures built so far, by ``id`` of their element, so that a texture shared by
        ``<ref>`` is built once (default: a new, empty one).
    shape_id : int, optional
        A shape's index in the scene's per-shape tables; for an area emitter, the index of
        the shape it lights (None at the top level).
    shape : ShapeParams, optional
        For a shape: what the loader reads of every shape (its ``to_world`` after an
        instance's, ``flip_normals``, the nested emitter) and the accumulator it adds its
        primitives to (:class:`pathtracer.shapes.accumulator.ShapeParams`).
    resolution : (int, int), optional
        For a sensor: the film's (width, height) replacing the file's.
    spp : int, optional
        For a sensor: the sample count replacing the file's.
    """

    def __init__(self, plugin: Plugin, *, folders: list[str] | None = None,
                 texture_cache: dict | None = None, shape_id: int | None = None, shape=None,
                 resolution: tuple[int, int] | None = None, spp: int | None = None):
        self.plugin = plugin
        self.used: set[str] = set()
        self.folders: list[str] = ["."] if folders is None else folders
        self.texture_cache: dict = {} if texture_cache is None else texture_cache
        self.shape_id = shape_id
        self.shape = shape
        self.resolution = resolution
        self.spp = spp
        # Nested <texture> children by parameter name (read by reflectance_or_texture).
        self.textures: dict[str, Plugin] = {}
        for name, child in plugin.named_children():
            if child.kind != "texture":
                continue
            if not name:
                raise child.error(f"a <texture> inside {plugin.label} needs a name "
                                  "(the parameter it gives, e.g. name=\"reflectance\")")
            if name in plugin.props or name in self.textures:
                raise child.error(f"parameter \"{name}\" given twice")
            self.textures[name] = child

    def _get(self, name: str, tags: tuple, what: str):
        if name in self.textures:
            self._no_texture(name)
        prop = self.plugin.props.get(name)
        self.used.add(name)
        if prop is None:
            return None
        if prop.tag not in tags:
            raise self.plugin.error(f"property \"{name}\" must be {what}, not <{prop.tag}>",
                                    prop.line)
        return prop.value

    def has(self, name: str) -> bool:
        return name in self.plugin.props

    def line(self, name: str) -> int:
        return self.plugin.props[name].line

    def line_of(self, name: str) -> int:
        """The line of a property or of the nested texture that gives it."""
        if name in self.textures:
            return self.textures[name].line
        return self.line(name)

    def color(self, name: str, default: float, kind: str | None = None) -> np.ndarray:
        """An RGB colour from ``<rgb>``, ``<float>`` or ``<spectrum>``.

        ``kind`` says how a ``<spectrum>`` becomes RGB (see
        :func:`pathtracer.scene.spectra.to_rgb`): by default ``'emission'``
        inside an ``<emitter>`` and ``'reflectance'`` elsewhere, as Mitsuba's
        emitters and BSDFs read their colours; pass ``'unbounded'`` for
        values that may exceed 1 but are not emitted (indices of refraction).
        """
        v = self._get(name, COLOR_TAGS, "an <rgb> (or <float>, <spectrum>) colour")
        if isinstance(v, spectra.Spectrum):
            if kind is None:
                kind = "emission" if self.plugin.kind == "emitter" else "reflectance"
            return spectra.to_rgb(v, kind)
        return np.full(3, float(default)) if v is None else np.broadcast_to(
            np.asarray(v, dtype=float), (3,)).copy()

    def reflectance(self, name: str, default: float) -> np.ndarray:
        """A colour that scales reflected or transmitted light: each channel in [0, 1].

        Mitsuba refuses an ``<rgb>`` outside [0, 1] here; a ``<float>`` it does not check,
        but above 1 a surface creates energy, so both are refused.
        """
        value = self.color(name, default)
        if not np.all((value >= 0.0) & (value <= 1.0)):
            raise self.plugin.error(f"\"{name}\" must lie in [0, 1] (as Mitsuba requires of a "
                                    f"reflectance), got {', '.join(f'{v:g}' for v in value)}",
                                    self.line(name))
        return value

    def reflectance_or_texture(self, name: str, default: float):
        """A :meth:`reflectance` that may also be a nested ``<texture>``.

        Returns a (3,) array for an ``<rgb>``/``<float>`` value (or the
        default), else the built :class:`~pathtracer.textures.Texture`
        (whose values are not range-checked: Mitsuba only warns about them).
        """
        child = self.textures.get(name)
        self.used.add(name)
        if child is None:
            return self.reflectance(name, default)
        return build_texture(child, self.folders, self.texture_cache)

    def texture_value(self, name: str, default: float):
        """A colour a texture yields (a checkerboard's), or a nested ``<texture>``.

        A texture's values are checked by what reads them, not here: Mitsuba refuses an
        ``<rgb>`` outside [0, 1] (it builds a reflectance spectrum of it) but takes a
        ``<float>`` as it is (principledthin's ``diff_trans`` reaches 2), and so does this.
        """
        if name in self.textures or self.plugin.props.get(name) is None or \
                self.plugin.props[name].tag == "rgb":
            return self.reflectance_or_texture(name, default)
        return self.color(name, default)

    def emission_or_texture(self, name: str, default: float):
        """An emitted colour (:meth:`color`, not range-checked) that may also be a nested
        ``<texture>`` (Mitsuba's ``get_emissive_texture``): a (3,) array or the built
        :class:`~pathtracer.textures.Texture`."""
        child = self.textures.get(name)
        self.used.add(name)
        if child is None:
            return self.color(name, default, "emission")
        return build_texture(child, self.folders, self.texture_cache)

    def float(self, name: str, default):
        v = self._get(name, FLOAT_TAGS, "a <float>")
        return default if v is None else float(v)

    def int(self, name: str, default):
        v = self._get(name, ("integer",), "an <integer>")
        return default if v is None else int(v)

    def bool(self, name: str, default: bool) -> bool:
        v = self._get(name, ("boolean",), "a <boolean>")
        return default if v is None else bool(v)

    def string(self, name: str, default):
        return self._get(name, ("string",), "a <string>") or default

    def point(self, name: str, default):
        v = self._get(name, ("point", "vector"), "a <point>")
        return default if v is None else np.asarray(v, dtype=float)

    def transform(self, name: str = "to_world") -> np.ndarray:
        v = self._get(name, ("transform",), "a <transform>")
        return np.eye(4) if v is None else v

    def normal_matrix(self, name: str = "to_world"):
        """The matrix Mitsuba transforms this transform's normals with when it
        is not the true inverse transpose (a ``<rotate>`` about a non-unit
        axis), else None."""
        p = self.plugin.props.get(name)
        return None if p is None else p.normal_matrix

    def raw(self, name: str):
        """The value whatever its type (for pass-through parameters)."""
        if name in self.textures:
            self._no_texture(name)
        self.used.add(name)
        p = self.plugin.props.get(name)
        return None if p is None else p.value

    def ignore(self, *names: str) -> None:
        """Accept properties that do not change the rendered values."""
        self.used.update(names)

    def _no_texture(self, name: str):
        if self.plugin.type == "roughplastic" and name == "alpha":
            raise self.textures[name].error(
                "roughplastic takes a number for \"alpha\", not a texture (its coating "
                "tables depend on it; Mitsuba refuses a texture too)")
        raise self.textures[name].error(
            f"a texture for \"{name}\" is not supported (this tracer takes textures for: "
            f"{', '.join(TEXTURED_PARAMS)})")

    def finish(self) -> None:
        for name in self.textures:
            if name not in self.used:
                self._no_texture(name)
        for name, prop in self.plugin.props.items():
            if name not in self.used:
                known = sorted(self.used)
                raise self.plugin.error(
                    f"unsupported property \"{name}\" (this tracer understands: "
                    f"{', '.join(known) or 'none'}){_legacy_hint(name)}", prop.line)


def _legacy_hint(name: str) -> str:
    """For a camelCase name: that Mitsuba 3 renames it only in files of Mitsuba 0.x."""
    new = camel_to_underscore(name)
    if new == name:
        return ""
    return (f"; \"{name}\" is a Mitsuba 0.x name: Mitsuba 3 renames it to \"{new}\" in files of "
            f"version below 2.0.0, unless \"{new}\" is given too (docs/scene-format.md, \"Files "
            "of Mitsuba 0.x\")")


def children(plugin: Plugin, allowed: dict[str, int]) -> dict[str, list[Plugin]]:
    """Nested plugins grouped by kind; ``allowed`` maps kind -> max count."""
    out: dict[str, list[Plugin]] = {k: [] for k in allowed}
    for child in plugin.children:
        if child.kind not in allowed:
            raise child.error(f"<{child.kind}> is not allowed inside {plugin.label}")
        out[child.kind].append(child)
        if len(out[child.kind]) > allowed[child.kind]:
            raise child.error(f"{plugin.label} accepts at most {allowed[child.kind]} "
                              f"<{child.kind}>")
    return out


def unsupported(plugin: Plugin, what: str) -> Exception:
    """The error for a plugin type this tracer refuses: why, where it is known, else what is supported."""
    if plugin.type in NOT_IMPLEMENTED_MEDIA:
        return plugin.error(f"{what} \"{plugin.type}\" is not supported: "
                            f"{NOT_IMPLEMENTED_MEDIA[plugin.type]}")
    if plugin.type in VARIANT_ONLY:
        return plugin.error(f"{what} \"{plugin.type}\" is not supported: it is "
                            f"{VARIANT_ONLY[plugin.type]}")
    if plugin.kind == "shape" and plugin.type in NOT_IMPLEMENTED_SHAPES:
        return plugin.error(f"shape \"{plugin.type}\" is not implemented in this tracer "
                            f"({NOT_IMPLEMENTED_SHAPES[plugin.type]}); it is valid in Mitsuba's "
                            "RGB variants, so the scene cannot be compared")
    supported = names(plugin.kind)
    return plugin.error(f"unsupported {what} ({suggestion(plugin.type, supported)}supported: "
                        f"{', '.join(supported)})")


def registered(plugin: Plugin, what: str):
    """The factory registered for ``plugin``'s kind and type, or the error (:func:`unsupported`)
    that says why there is none; ``what`` names the kind in that error."""
    create = factory(plugin.kind, plugin.type)
    if create is None:
        raise unsupported(plugin, what)
    return create


def build_texture(plugin: Plugin, folders: list[str], cache: dict):
    """The :mod:`pathtracer.textures` object of a ``<texture>`` (built once per plugin)."""
    key = id(plugin)
    if key not in cache:
        create = registered(plugin, "texture")
        cache[key] = create(Props(plugin, folders=folders, texture_cache=cache))
    return cache[key]


def search_folders(root: Plugin, base_dir: str) -> list[str]:
    """Where relative file names (meshes, spectra, textures) are looked up,
    first match wins, as Mitsuba's file resolver: the top-level file's
    ``<path>`` folders (the last one first), the scene file's folder, then
    the current working directory."""
    return list(root.search_paths) + [base_dir, os.getcwd()]


def find_file(plugin: Plugin, props: Props, name: str, folders: list[str]) -> str:
    """The file ``props`` names in its string property ``name``, looked up in ``folders``."""
    filename = props.string(name, None)
    if filename is None:
        raise plugin.error(f"missing <string name=\"{name}\">")
    candidates = [filename] if os.path.isabs(filename) else [
        os.path.join(folder, filename) for folder in folders]
    for path in candidates:
        if os.path.isfile(path):
            return path
    raise plugin.error(f"file not found: \"{filename}\" (looked for {', '.join(candidates)})",
                       props.line(name))
