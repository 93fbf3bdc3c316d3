r"""Mitsuba's ``mesh_attribute`` texture: a mesh's own per-vertex or per-face data.

``name`` names the attribute (``vertex_color``, ``face_id``, ...: it must contain
``vertex_`` or ``face_``) that the mesh under the hit carries (PLY properties, read by
:mod:`pathtracer.io.ply_attributes`). At a hit on triangle :math:`(v_0, v_1, v_2)` with
barycentrics :math:`(b_1, b_2)` the value is

.. math:: s\,\bigl((1 - b_1 - b_2)\,a(v_0) + b_1\,a(v_1) + b_2\,a(v_2)\bigr)
          \quad\text{(vertex)}, \qquad s\,a(f) \quad\text{(face)},

``s`` being ``scale`` (1). A one-channel attribute is grey (``eval`` repeats it on the
three channels); ``eval_1`` (a roughness, a weight) needs one channel, as in Mitsuba.
Mitsuba 3.9.1 gives the texture no mean (a plastic's lobe weight) and calls it constant
over the surface (an area light with it samples its shape by area).
"""
from __future__ import annotations

import numpy as np

from ..core.surface_uv import SurfaceUV
from ..scene.properties import Props, children
from ..scene.registry import register
from ..scene.xml import Plugin
from .base import Texture


class MeshAttribute(Texture):
    """A mesh attribute looked up at hits.

    Parameters
    ----------
    name : str
        The attribute (``vertex_*`` or ``face_*``).
    scale : float
    plugin : Plugin, optional
        The ``<texture>`` element, for errors located in the file.
    """

    def __init__(self, name: str, scale: float = 1.0, plugin: Plugin | None = None):
        super().__init__()
        self.name, self.scale, self.plugin = name, float(scale), plugin
        self.per_vertex = name.startswith("vertex_")
        #: shape index -> its attribute table (k, 3, C) or (k, C), and each shape's first
        #: triangle; set by :func:`bind_mesh_attributes` once the scene's shapes are known.
        self.tables: dict[int, np.ndarray] = {}
        self.first_triangle: dict[int, int] = {}
        self.channels = 0
        self.maximum = np.zeros(3)

    def _error(self, message: str) -> Exception:
        if self.plugin is not None:
            return self.plugin.error(message)
        return ValueError(f"mesh_attribute \"{self.name}\": {message}")

    def bind(self, shape: int, table: np.ndarray, first_triangle: int) -> None:
        """Attach the attribute of mesh ``shape`` (triangles from ``first_triangle``)."""
        channels = table.shape[-1]
        if channels not in (1, 3):
            raise self._error(f"attribute \"{self.name}\" has {channels} channels (Mitsuba "
                              "evaluates attributes of 1 or 3)")
        if self.channels and channels != self.channels:
            raise self._error(f"attribute \"{self.name}\" has {channels} channels on one "
                              f"mesh and {self.channels} on another")
        self.channels = channels
        self.tables[shape], self.first_triangle[shape] = table, first_triangle
        top = np.broadcast_to(table.reshape(-1, channels).max(axis=0) * self.scale, (3,))
        self.maximum = np.maximum(self.maximum, top)

    def _values(self, uv) -> np.ndarray:
        """(n, C) attribute values at the hits that ``uv`` carries."""
        if not isinstance(uv, SurfaceUV) or not uv.located:
            raise self._error("a mesh_attribute texture is evaluated at mesh hits only "
                              "(not through another texture or a projector)")
        out = np.zeros((len(uv), max(self.channels, 1)))
        for shape in np.unique(uv.shape_index):
            rows = np.flatnonzero(uv.shape_index == shape)
            table = self.tables.get(int(shape))
            if table is None:
                continue   # checked at load: only shapes without this BSDF/emitter
            local = uv.prim[rows] - self.first_triangle[int(shape)]
            if self.per_vertex:
                b1, b2 = uv.bary[rows, 0:1], uv.bary[rows, 1:2]
                corner = table[local]
                out[rows] = (1.0 - b1 - b2) * corner[:, 0] + b1 * corner[:, 1] + b2 * corner[:, 2]
            else:
                out[rows] = table[local]
        return out * self.scale

    def eval(self, uv) -> np.ndarray:
        """RGB (n, 3) at the hits (grey for a one-channel attribute)."""
        values = self._values(uv)
        return np.repeat(values, 3, axis=1) if values.shape[1] == 1 else values

    def eval_1(self, uv) -> np.ndarray:
        """One value per hit; a three-channel attribute is refused, as Mitsuba refuses it."""
        if self.channels == 3:
            raise self._error(f"attribute \"{self.name}\" has 3 channels where one value "
                              "is needed (a roughness, weight or opacity)")
        return self._values(uv)[:, 0]

    def max_value(self) -> np.ndarray:
        """Channel-wise maximum over every mesh the texture is bound to."""
        return self.maximum.copy()

    def mean(self) -> float:
        """Mitsuba 3.9.1's ``mesh_attribute`` has no mean: refused."""
        raise self._error("a mesh_attribute texture has no mean (Mitsuba 3.9.1 cannot use "
                          "it here, e.g. as a plastic's diffuse_reflectance)")


@register("texture", "mesh_attribute")
def create(props: Props) -> MeshAttribute:
    """``name`` (required, containing ``vertex_`` or ``face_``), ``scale`` (1)."""
    plugin = props.plugin
    children(plugin, {})
    if not props.has("name"):
        raise plugin.error("a mesh_attribute texture needs a \"name\" (e.g. vertex_color)")
    name = props.string("name", None)
    if "vertex_" not in name and "face_" not in name:
        raise plugin.error(f"invalid mesh attribute name \"{name}\": it must start with "
                           "\"vertex_\" or \"face_\"", props.line("name"))
    scale = props.float("scale", 1.0)
    props.finish()
    return MeshAttribute(name, scale, plugin)


#: Attributes that read their texture as one number per hit (``eval_1``) besides a BSDF's
#: ``scalar_texture_params``: a blend's weight and a mask's opacity.
SCALAR_NAMES = ("weight", "opacity")


def textures_in(obj, seen=None):
    """``(texture, as_scalar)`` for every :class:`MeshAttribute` reachable from a BSDF,
    texture or emitter (its attributes, nested BSDFs and textures, tuples of them);
    ``as_scalar`` where its owner reads one number per hit from it."""
    seen = set() if seen is None else seen
    if id(obj) in seen:
        return
    seen.add(id(obj))
    items = enumerate(obj) if isinstance(obj, (list, tuple)) else vars(obj).items()
    scalar = set(getattr(obj, "scalar_texture_params", ())) | set(SCALAR_NAMES)
    for name, value in items:
        if isinstance(value, MeshAttribute):
            yield value, name in scalar
        elif isinstance(value, (list, tuple)) or _is_plugin_object(value):
            yield from textures_in(value, seen)


def _is_plugin_object(value) -> bool:
    """An instance of one of the tracer's classes (a BSDF, texture, distribution), not an
    array, a plugin element or a function."""
    cls = type(value)
    return (cls.__module__.startswith("pathtracer.") and hasattr(value, "__dict__")
            and not cls.__module__.startswith("pathtracer.scene."))


def bind_mesh_attributes(users, shape_attributes: dict, shape_prim, shape_name) -> None:
    """Give every ``mesh_attribute`` texture the tables of the shapes it is used on.

    ``users`` is ``[(shape index, object)]``: each shape with its BSDF and, where it emits,
    its area emitter. A shape without the attribute is refused (Mitsuba fails when it
    renders: "Invalid attribute requested"), and so is a three-channel attribute where one
    number is read (Mitsuba's ``eval_attribute_1`` throws).
    """
    for shape, obj in users:
        for texture, as_scalar in textures_in(obj):
            table = shape_attributes.get(shape, {}).get(texture.name)
            if table is None:
                have = sorted(shape_attributes.get(shape, {}))
                raise texture._error(f"the shape {shape_name[shape]} has no attribute "
                                     f"\"{texture.name}\" (it has: {', '.join(have) or 'none'})")
            if as_scalar and table.shape[-1] != 1:
                raise texture._error(f"attribute \"{texture.name}\" has {table.shape[-1]} "
                                     "channels where one value is needed (a roughness, weight "
                                     "or opacity)")
            texture.bind(shape, table, int(shape_prim[shape][0]))
