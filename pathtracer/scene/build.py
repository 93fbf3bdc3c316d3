"""The loader: the generic :class:`~pathtracer.scene.xml.Plugin` tree assembled into a :class:`Scene`.

It imports every plugin package, so that each plugin has registered its factory
(:mod:`pathtracer.scene.registry`), then builds each element with the factory of its kind
and type (:func:`~pathtracer.scene.properties.registered`). Every factory is called as
``create(props)``: the element's :class:`~pathtracer.scene.properties.Props`, through
which it reads its properties (a property nobody read is an error), and on which the
builder of its kind sets what else the factory needs (where files are looked up, the
textures built so far, the shape it belongs to, ...). What is left here is what no single
plugin owns: the order in which elements are built, default BSDFs, area lights attached to
their shapes, the media table, the ``<integrator>`` element (whose class is the integrator
registry's), and the arrays of the assembled scene.
"""
from __future__ import annotations

import warnings

import numpy as np

# Importing a plugin package registers every plugin of its kind (pathtracer.scene.registry).
from .. import bsdfs as _bsdf_plugins  # noqa: F401
from .. import emitters as _emitter_plugins  # noqa: F401
from .. import integrators as _integrator_plugins  # noqa: F401
from .. import media as _medium_plugins  # noqa: F401
from .. import sensors as _sensor_plugins  # noqa: F401
from .. import shapes as _shape_plugins  # noqa: F401
from .. import textures as _texture_plugins  # noqa: F401
from .. import volumes as _volume_plugins  # noqa: F401
from ..bsdfs.diffuse import Diffuse
from ..bsdfs.parameters import build_bsdf
from ..core.names import suggestion
from ..emitters.base import Emitter
from ..sensors.perspective_sensor import Camera
from ..sensors.sampler import build_sampler
from ..shapes import instances
from ..shapes.accumulator import GeometryAccumulator, ShapeParams, shape_label
from ..textures.mesh_attribute import bind_mesh_attributes
from ..volumes import build_volume
from .properties import (
    Props,
    build_texture,
    children,
    registered,
    search_folders,
)
from .types import IntegratorSpec, Scene
from .xml import Plugin

# Integrator parameters we validate; the project's own integrators take any.
INTEGRATOR_PARAMS = {
    "path": {"max_depth", "rr_depth", "hide_emitters"},
    "volpath": {"max_depth", "rr_depth", "hide_emitters"},
    "volpathmis": {"max_depth", "rr_depth", "hide_emitters"},
    "direct": {"emitter_samples", "bsdf_samples", "shading_samples", "hide_emitters"},
    "ptracer": {"max_depth", "rr_depth", "hide_emitters"},
}
# Types of the integrator parameters with a Mitsuba meaning (any integrator).
INTEGRATOR_PARAM_TAGS = {"max_depth": "integer", "rr_depth": "integer",
                         "hide_emitters": "boolean", "emitter_samples": "integer",
                         "bsdf_samples": "integer", "shading_samples": "integer"}

# -- shapes ------------------------------------------------------------------


def build_shape(plugin: Plugin, geo: GeometryAccumulator, shape_id: int, folders: list[str],
                parent: np.ndarray | None = None):
    """Add one shape's primitives to ``geo``; returns its nested bsdf and emitter plugins.

    The shape kind's factory, from the registry, reads the kind's own properties and
    adds the primitives (:mod:`pathtracer.shapes.accumulator`); its :class:`Props` carry
    ``folders`` (where mesh files are looked up, :func:`search_folders`), ``shape_id`` and,
    as ``shape``, a :class:`ShapeParams`. ``parent`` is the ``to_world`` of the
    ``instance`` the shape is drawn by, applied after the shape's own
    (:mod:`pathtracer.shapes.instances`).
    """
    create = registered(plugin, "shape")
    props = Props(plugin, folders=folders, shape_id=shape_id)
    kids = children(plugin, {"bsdf": 1, "emitter": 1, "medium": 2})
    m = props.transform("to_world")
    if parent is not None:
        m = parent @ m
    flip = props.bool("flip_normals", False)
    emitter = kids["emitter"][0] if kids["emitter"] else None
    props.shape = ShapeParams(m, flip, emitter, geo)
    create(props)
    props.finish()
    geo.name.append(shape_label(plugin))
    return kids["bsdf"][0] if kids["bsdf"] else None, emitter


# -- emitters, sensor, integrator -----------------------------------------

def build_emitter(plugin: Plugin, folders: list[str] = (".",), shape: int | None = None) -> Emitter:
    """The emitter of an ``<emitter>`` element: a top-level one, or (``shape`` given) the area
    emitter of the shape of that index.

    The factory's :class:`Props` (checked here when it returns) carry ``folders``, where
    files are looked up, and ``shape_id``, the shape index (None at the top level).
    """
    if shape is not None and plugin.type != "area":
        raise plugin.error("only an area emitter can be nested in a shape")
    props = Props(plugin, folders=list(folders), shape_id=shape)
    create = registered(plugin, "emitter")
    result = create(props)
    props.finish()
    return result


def build_sensor(plugin: Plugin, resolution: tuple[int, int] | None = None,
                 spp: int | None = None) -> tuple[Camera, int, int]:
    """The camera of the ``<sensor>``, with the film resolution and the sampler's sample count
    and seed: its factory's :class:`Props` carry ``resolution`` (width, height) and ``spp``,
    which replace the file's when given."""
    create = registered(plugin, "sensor")
    return create(Props(plugin, resolution=resolution, spp=spp))


def build_integrator(plugin: Plugin | None) -> IntegratorSpec:
    """Name and parameters of the ``<integrator>`` (``path`` when absent)."""
    if plugin is None:
        return IntegratorSpec("path", {})
    if plugin.type == "moment":
        # Mitsuba's moment integrator renders its nested integrator and adds the second
        # moment as an AOV (which the statistics here compute anyway): the nested one renders.
        kids = children(plugin, {"integrator": 1})
        if not kids["integrator"] or plugin.props:
            raise plugin.error("a moment integrator takes exactly one nested <integrator> "
                               "and no properties")
        return build_integrator(kids["integrator"][0])
    if plugin.type == "aov":
        return build_integrator(_aov_image(plugin))
    integrator = registered(plugin, "integrator")
    if plugin.type == "direct":
        _check_direct_samples(plugin)
    children(plugin, {})
    allowed = INTEGRATOR_PARAMS.get(plugin.type)
    params = {}
    for name, prop in plugin.props.items():
        if allowed is not None and name not in allowed:
            raise plugin.error(f"unsupported property \"{name}\" ({suggestion(name, allowed)}"
                               f"this tracer understands: "
                               f"{', '.join(sorted(allowed))})", prop.line)
        want = INTEGRATOR_PARAM_TAGS.get(name)
        if want is not None and prop.tag != want:
            raise plugin.error(f"integrator parameter \"{name}\" must be an <{want}>", prop.line)
        if prop.tag not in ("integer", "boolean", "float", "string"):
            raise plugin.error(f"integrator parameter \"{name}\" must be an integer, boolean, "
                               "float or string", prop.line)
        if name == "max_depth" and prop.value < -1:
            raise plugin.error(f"max_depth must be -1 (unlimited) or >= 0, as in Mitsuba, got "
                               f"{prop.value}", prop.line)
        params[name] = prop.value
    # A Mitsuba name (ptracer) is rendered by the integrator registered under it (light).
    return IntegratorSpec(integrator.name, params)


#: The AOV types of Mitsuba's ``aov`` integrator (``name:type`` in its ``aovs`` string).
AOV_TYPES = ("albedo", "depth", "position", "uv", "geo_normal", "sh_normal", "dp_du", "dp_dv",
             "duv_dx", "duv_dy", "prim_index", "shape_index")


def _aov_image(plugin: Plugin) -> Plugin:
    """The integrator whose radiance an ``aov`` integrator's film carries in its RGB channels.

    Mitsuba's ``aov`` renders each nested integrator and the AOVs its ``aovs`` string names
    into extra channels; the image proper (R, G, B) is its first nested integrator's. The
    tracer renders that one; the AOV channels are not written (they are not radiance, and
    nothing is compared on them). The ``aovs`` string is checked as Mitsuba reads it.
    """
    kids = children(plugin, {"integrator": 8})
    unknown = set(plugin.props) - {"aovs"}
    if unknown:
        raise plugin.error(f"unsupported property \"{sorted(unknown)[0]}\" (an aov integrator "
                           "takes only \"aovs\" and nested integrators)",
                           plugin.props[sorted(unknown)[0]].line)
    aovs = plugin.props.get("aovs")
    if aovs is None:
        raise plugin.error("an aov integrator needs its \"aovs\" string (Mitsuba requires it)")
    for pair in str(aovs.value).replace(" ", ",").split(","):
        name, _, kind = pair.partition(":")
        if pair and (not name or kind not in AOV_TYPES):
            raise plugin.error(f"aovs: \"{pair}\" is not <name>:<type> with a type of "
                               f"{', '.join(AOV_TYPES)}", aovs.line)
    if not kids["integrator"]:
        raise plugin.error("an aov integrator without a nested <integrator> renders no radiance "
                           "(only AOVs): nothing to render or compare")
    return kids["integrator"][0]


def _check_direct_samples(plugin: Plugin) -> None:
    """Mitsuba's rules for ``direct``'s sample counts, located in the file."""
    props = plugin.props
    if "shading_samples" in props and ("emitter_samples" in props or "bsdf_samples" in props):
        raise plugin.error("give either shading_samples or emitter_samples/bsdf_samples, "
                           "not both (as in Mitsuba)", props["shading_samples"].line)
    counts = {}
    for name in ("shading_samples", "emitter_samples", "bsdf_samples"):
        prop = props.get(name)
        if prop is not None and prop.tag == "integer":
            if prop.value < 0:
                raise plugin.error(f"{name} must be >= 0", prop.line)
            counts[name] = prop.value
    both = counts.get("shading_samples", 1)
    if counts.get("emitter_samples", both) + counts.get("bsdf_samples", both) == 0:
        raise plugin.error("direct needs at least one emitter or BSDF sample")


# -- the scene -----------------------------------------------------------------


def _attach(emitter: Plugin, shape: Plugin, attached: dict) -> None:
    """Record that ``shape`` carries ``emitter`` (nested or by ``<ref>``); an
    emitter on two shapes is refused, as Mitsuba refuses it."""
    first = attached.setdefault(id(emitter), shape)
    if first is not shape:
        raise shape.error(f"area emitter{_id_text(emitter)} is already attached to the shape "
                          f"at {first.file}:{first.line}; Mitsuba allows an emitter on one "
                          "shape only (give each shape its own <emitter>)")


def _id_text(plugin: Plugin) -> str:
    return f' "{plugin.id}"' if plugin.id else ""


def _unattached_area(plugin: Plugin, attached: dict) -> None:
    """A top-level area emitter: fine when a shape references it; otherwise
    Mitsuba drops it silently, and we say so."""
    if id(plugin) not in attached:
        warnings.warn(f"{plugin.file}:{plugin.line}: area emitter{_id_text(plugin)} is not "
                      "attached to any shape and emits nothing (as in Mitsuba); reference it "
                      "with <ref id=\"...\"/> inside a <shape>", stacklevel=4)


def build_scene(root: Plugin, source: str, base_dir: str,
                resolution: tuple[int, int] | None = None, spp: int | None = None) -> Scene:
    """Turn the parsed ``<scene>`` into a :class:`Scene`.

    Parameters
    ----------
    root : Plugin
        The ``<scene>`` node from :func:`pathtracer.scene.xml.parse_file`.
    source : str
        Path or built-in name, stored in ``Scene.source``.
    base_dir : str
        The scene file's folder: relative mesh file names are looked up in
        the file's ``<path>`` folders, then here, then in the working
        directory (:func:`search_folders`).
    resolution, spp : optional
        Film (width, height) and sample count replacing the file's (:func:`build_sensor`).
    """
    kids = children(root, {"shape": 10**9, "bsdf": 10**9, "emitter": 10**9,
                            "sensor": 1, "integrator": 1, "texture": 10**9, "medium": 10**9,
                            "sampler": 10**9, "volume": 10**9})
    shape_media = []
    for plugin in kids["sampler"]:   # top-level samplers: referenced by a sensor, or unused
        build_sampler(plugin)
    geo = GeometryAccumulator()
    bsdf_objects, bsdf_index, textures = [], {}, {}
    emitters, environment = [], None
    shape_bsdf, shape_emitter = [], []
    folders = search_folders(root, base_dir)
    media = MediaTable(folders)
    attached: dict[int, Plugin] = {}  # area emitter plugin -> the shape it lights
    volume_elements: dict[str, tuple] = {}   # first null BSDF (the media table has its own)

    def bsdf_id(plugin: Plugin | None, emitter: bool = False) -> int:
        # Mitsuba's default BSDF: diffuse 0.5, but black on an emitting shape.
        key = ("default", emitter) if plugin is None else id(plugin)
        if key not in bsdf_index:
            if plugin is None:
                bsdf_objects.append(Diffuse(np.full(3, 0.0 if emitter else 0.5)))
            else:
                bsdf_objects.append(build_bsdf(plugin, folders, textures))
                if getattr(bsdf_objects[-1], "is_null", False):
                    volume_elements.setdefault("null", _where(plugin))
            bsdf_index[key] = len(bsdf_objects) - 1
        return bsdf_index[key]

    # Top-level BSDFs and textures are built even when unused so that their errors surface.
    for plugin in kids["texture"]:
        build_texture(plugin, folders, textures)
    for plugin in kids["bsdf"]:
        bsdf_id(plugin)
    for plugin in kids["medium"]:
        media.index(plugin)
    for plugin in kids["volume"]:   # top-level volumes: referenced by a medium, or unused
        build_volume(plugin, folders)
    for plugin, parent in instances.flatten(kids["shape"]):
        shape_id = len(shape_bsdf)
        bsdf_plugin, emitter_plugin = build_shape(plugin, geo, shape_id, folders, parent)
        shape_media.append(media.shape_media(plugin))
        shape_bsdf.append(bsdf_id(bsdf_plugin, emitter=emitter_plugin is not None))
        if emitter_plugin is not None:
            _attach(emitter_plugin, plugin, attached)
            emitters.append(build_emitter(emitter_plugin, folders, shape_id))
            if getattr(emitters[-1], "by_texture", False) and geo.kind[shape_id] != "mesh":
                raise emitter_plugin.error(
                    f"a textured radiance on a {geo.kind[shape_id]} is not supported (only on "
                    "meshes: rectangle, cube, obj, ply, serialized)")
            shape_emitter.append(len(emitters) - 1)
        else:
            shape_emitter.append(-1)
    for plugin in kids["emitter"]:
        if plugin.type == "area":
            _unattached_area(plugin, attached)
            continue
        emitter = build_emitter(plugin, folders)
        if emitter.environment:
            if environment is not None:
                raise plugin.error("at most one environment emitter (constant or envmap) "
                                   "is allowed, as in Mitsuba")
            environment = emitter
        emitters.append(emitter)
    if not kids["sensor"]:
        raise root.error("no <sensor>: add <sensor type=\"perspective\"> with a film")
    camera, spp, seed = build_sensor(kids["sensor"][0], resolution, spp)
    camera_medium = media.sensor_medium(kids["sensor"][0])
    integrator = build_integrator(kids["integrator"][0] if kids["integrator"] else None)
    fields = geo.scene_fields()
    users = [(s, bsdf_objects[b]) for s, b in enumerate(shape_bsdf)]
    users += [(s, emitters[e]) for s, e in enumerate(shape_emitter) if e >= 0]
    bind_mesh_attributes(users, fields["shape_attributes"], fields["shape_prim"],
                         fields["shape_name"])

    return Scene(
        **fields,
        shape_bsdf=np.array(shape_bsdf, dtype=np.int32),
        shape_emitter=np.array(shape_emitter, dtype=np.int32),
        bsdfs=bsdf_objects, emitters=emitters, environment=environment,
        camera=camera, spp=spp, seed=seed, integrator=integrator,
        source=source, volume_elements={**media.elements, **volume_elements},
        **_media_fields(media, shape_media, camera_medium))


def _where(plugin: Plugin) -> tuple[str, int, str]:
    """``(file, line, element)`` of a plugin, for messages given after loading."""
    return plugin.file, plugin.line, plugin.label


SHAPE_MEDIUM_NAMES = ("interior", "exterior")


class MediaTable:
    """The scene's media, each built once per ``<medium>`` element (shared by ``<ref>``).

    A shape takes the media on its two sides as ``<medium name="interior">`` /
    ``name="exterior"`` (nested or ``<ref id=".." name=".."/>``); the sensor takes one
    medium, the one the camera sits in. A medium's factory reads ``props.folders``: where
    the files of its volumes are looked up.
    """

    def __init__(self, folders: list[str]):
        self.folders = folders
        self.media: list = []
        self._index: dict[int, int] = {}
        #: ``{"medium": (file, line, element)}`` of the first medium built.
        self.elements: dict[str, tuple] = {}

    def index(self, plugin: Plugin) -> int:
        """Index of the medium of ``plugin`` in :attr:`media` (building it the first time)."""
        key = id(plugin)
        if key not in self._index:
            self.media.append(build_medium(plugin, self.folders))
            self._index[key] = len(self.media) - 1
            self.elements.setdefault("medium", _where(plugin))
        return self._index[key]

    def shape_media(self, shape: Plugin) -> tuple[int, int]:
        """(interior, exterior) medium indices of a shape, -1 where none is given."""
        sides = {}
        for name, child in shape.named_children():
            if child.kind != "medium":
                continue
            if name not in SHAPE_MEDIUM_NAMES:
                raise child.error(f"a <medium> inside {shape.label} needs name=\"interior\" or "
                                  f"name=\"exterior\" (got {name!r})")
            if name in sides:
                raise child.error(f"{shape.label} has two {name} media")
            sides[name] = self.index(child)
        return sides.get("interior", -1), sides.get("exterior", -1)

    def sensor_medium(self, sensor: Plugin) -> int:
        """The medium the camera is in, -1 for vacuum."""
        media = [c for c in sensor.children if c.kind == "medium"]
        return self.index(media[0]) if media else -1


def build_medium(plugin: Plugin, folders: list[str]):
    """The participating medium of a ``<medium>`` element (its volumes' files looked up in
    ``folders``)."""
    create = registered(plugin, "medium")
    return create(Props(plugin, folders=folders))


def _media_fields(media, shape_media: list, camera_medium: int) -> dict:
    """The :class:`Scene` fields of participating media (none: the defaults)."""
    if not media.media:
        return {}
    sides = np.array(shape_media, dtype=np.int32).reshape(-1, 2)
    return dict(media=media.media, shape_interior=sides[:, 0].copy(),
                shape_exterior=sides[:, 1].copy(), camera_medium=camera_medium)
