"""Interpret the generic :class:`~pathtracer.scene.xml.Plugin` tree as a :class:`Scene`.

Every plugin is read through :class:`Props`, which remembers which properties
were consumed: a property the tracer does not know is an error rather than
being silently ignored, because it would make the two renderers disagree.
"""
from __future__ import annotations

import warnings

import numpy as np

from .. import (
    bsdfs,  # importing it registers the BSDF plugins and (through it) the textures
    integrators,  # noqa: F401  (imported to fill the integrator registry)
)
from ..bsdfs.parameters import build_bsdf
from ..core.rng import SEED_MAX
from ..sensors.film import FILTER_PARAMS, ReconstructionFilter
from ..shapes import instances  # the shapes package registers every shape kind
from ..shapes.accumulator import GeometryAccumulator, ShapeParams, shape_label
from . import transform
from .properties import (
    VARIANT_ONLY,
    Props,
    build_texture,
    children,
    find_file,
    search_folders,
    unsupported,
)
from .registry import factory
from .types import (
    AreaEmitter,
    Camera,
    ConstantEmitter,
    DirectionalEmitter,
    IntegratorSpec,
    PointEmitter,
    Scene,
    SpotEmitter,
)
from .xml import Plugin

# Integrator parameters we validate; the project's own integrators take any.
INTEGRATOR_PARAMS = {
    "path": {"max_depth", "rr_depth", "hide_emitters"},
    "volpath": {"max_depth", "rr_depth", "hide_emitters"},
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
    adds the primitives (:mod:`pathtracer.shapes.accumulator`). ``folders`` are where
    mesh files are looked up (:func:`search_folders`). ``parent`` is the ``to_world`` of
    the ``instance`` the shape is drawn by, applied after the shape's own
    (:mod:`pathtracer.shapes.instances`).
    """
    create = factory("shape", plugin.type)
    if create is None:
        raise unsupported(plugin, "shape")
    props = Props(plugin)
    kids = children(plugin, {"bsdf": 1, "emitter": 1, "medium": 2})
    m = props.transform("to_world")
    if parent is not None:
        m = parent @ m
    flip = props.bool("flip_normals", False)
    emitter = kids["emitter"][0] if kids["emitter"] else None
    create(ShapeParams(plugin, props, m, flip, emitter, shape_id, folders), geo)
    props.finish()
    geo.name.append(shape_label(plugin))
    return kids["bsdf"][0] if kids["bsdf"] else None, emitter


# -- emitters, sensor, integrator -----------------------------------------

def build_area(plugin: Plugin, shape_id: int) -> AreaEmitter:
    """The ``<emitter type="area">`` nested in a shape."""
    if plugin.type != "area":
        raise plugin.error("only an area emitter can be nested in a shape")
    props = Props(plugin)
    children(plugin, {})
    radiance = props.color("radiance", 1.0)
    props.finish()
    return AreaEmitter(shape=shape_id, radiance=radiance)


def build_emitter(plugin: Plugin, folders: list[str] = (".",)):
    """A top-level ``point``, ``spot``, ``directional``, ``constant`` or ``envmap`` emitter."""
    props = Props(plugin)
    builders = {"point": _build_point, "spot": _build_spot, "directional": _build_directional,
                "constant": _build_constant, "envmap": _build_envmap}
    if plugin.type not in builders:
        raise unsupported(plugin, "emitter")
    if plugin.type != "spot":
        children(plugin, {})
    result = builders[plugin.type](plugin, props, folders)
    props.finish()
    return result


def _build_point(plugin, props, folders):
    if props.has("position") and props.has("to_world"):
        raise plugin.error("give either position or to_world, not both")
    position = props.point("position", None)
    if position is None:
        position = props.transform("to_world")[:3, 3].copy()
    return PointEmitter(position=position, intensity=props.color("intensity", 1.0))


def _build_constant(plugin, props, folders):
    return ConstantEmitter(radiance=props.color("radiance", 1.0))


def _build_spot(plugin, props, folders):
    kids = children(plugin, {"texture": 1})
    if kids["texture"]:
        raise kids["texture"][0].error("a spot light's projected \"texture\" is not supported "
                                       "(only a uniform intensity)")
    m = props.transform("to_world")
    cutoff = props.float("cutoff_angle", 20.0)
    beam = props.float("beam_width", cutoff * 0.75)
    if not 0 < cutoff <= 180:
        raise plugin.error(f"cutoff_angle must lie in (0, 180] degrees, got {cutoff:g}",
                           props.line("cutoff_angle"))
    if not 0 <= beam <= cutoff:
        raise plugin.error(f"beam_width must lie in [0, cutoff_angle = {cutoff:g}] degrees, got {beam:g}",
                           props.line("beam_width") if props.has("beam_width") else None)
    return SpotEmitter(position=m[:3, 3].copy(), to_local=np.linalg.inv(m[:3, :3]),
                       intensity=props.color("intensity", 1.0),
                       cutoff_angle=np.radians(cutoff), beam_width=np.radians(beam))


def _build_directional(plugin, props, folders):
    if props.has("direction") and props.has("to_world"):
        raise plugin.error("give either direction or to_world, not both")
    direction = props.point("direction", None)
    if direction is None:
        m = _rotation_only(plugin, props)
        direction = m[:3, 2].copy()
    if not np.linalg.norm(direction) > 0:
        raise plugin.error("direction must not be zero", props.line("direction"))
    return DirectionalEmitter(direction=direction / np.linalg.norm(direction),
                              irradiance=props.color("irradiance", 1.0))


def _build_envmap(plugin, props, folders):
    from pathtracer.emitters.envmap import EnvironmentMap
    from pathtracer.io.bitmap import BitmapError, read_bitmap

    if props.has("bitmap"):
        raise plugin.error("\"bitmap\" (a Bitmap object) exists only in Python dictionaries; "
                           "give a filename", props.line("bitmap"))
    if not props.has("filename"):
        raise plugin.error("missing <string name=\"filename\"> (the latitude-longitude image)")
    filename = props.string("filename", None)
    path = find_file(plugin, props, "filename", folders)
    try:
        image = read_bitmap(path)
    except BitmapError as error:
        raise plugin.error(str(error), props.line("filename")) from None
    if image.shape[2] == 1:
        image = np.repeat(image, 3, axis=2)
    if image.shape[1] < 2 or image.shape[0] < 3:
        raise plugin.error(f"\"{filename}\": an environment map needs at least 2x3 pixels, "
                           f"got {image.shape[1]}x{image.shape[0]}", props.line("filename"))
    if not np.all(np.isfinite(image)) or np.any(image < 0):
        raise plugin.error(f"\"{filename}\": radiance must be finite and non-negative",
                           props.line("filename"))
    return EnvironmentMap(image, scale=props.float("scale", 1.0),
                          to_world=_rotation_only(plugin, props),
                          mis_compensation=props.bool("mis_compensation", False))


def _rotation_only(plugin, props) -> np.ndarray:
    """``to_world`` of a light at infinity, refused when it scales (Mitsuba would not renormalise)."""
    m = props.transform("to_world")
    if transform.has_scale(m):
        raise plugin.error("to_world must not scale or shear a light at infinity (Mitsuba "
                           "would use unnormalised directions); use rotate or lookat",
                           props.line("to_world"))
    return m


def x_fov_from(fov: float, axis: str, aspect: float) -> float:
    """Horizontal field of view in degrees, following Mitsuba's ``parse_fov``.

    Parameters
    ----------
    fov : float
        The field of view along ``axis``, in degrees.
    axis : {'x', 'y', 'diagonal', 'smaller', 'larger'}
    aspect : float
        Film width / height.
    """
    if axis == "smaller":
        axis = "y" if aspect > 1 else "x"
    elif axis == "larger":
        axis = "x" if aspect > 1 else "y"
    half_tan = np.tan(0.5 * np.deg2rad(fov))
    if axis == "x":
        return float(fov)
    if axis == "y":
        return float(np.rad2deg(2.0 * np.arctan(half_tan * aspect)))
    if axis == "diagonal":
        width = 2.0 * half_tan / np.sqrt(1.0 + 1.0 / (aspect * aspect))
        return float(np.rad2deg(2.0 * np.arctan(0.5 * width)))
    raise ValueError(f"fov_axis must be x, y, diagonal, smaller or larger, not \"{axis}\"")


def _rfilter(plugin: Plugin | None) -> ReconstructionFilter:
    """The film's ``<rfilter>``: box, tent or gaussian (Mitsuba's default when absent)."""
    if plugin is None:
        return ReconstructionFilter.make("gaussian")
    if plugin.type not in FILTER_PARAMS:
        raise plugin.error(f"unsupported reconstruction filter \"{plugin.type}\" (supported: "
                           "box, tent, gaussian; Mitsuba's lanczos and mitchell have negative "
                           "lobes, not implemented here)")
    props = Props(plugin)
    children(plugin, {})
    name, default = FILTER_PARAMS[plugin.type]
    value = props.float(name, default)
    if plugin.type == "box" and value != 0.5:
        raise plugin.error("box filter radius must be 0.5 (one pixel)", props.line(name))
    if not 0.0 < value <= 64.0:
        raise plugin.error(f"{plugin.type} filter {name} must lie in (0, 64] pixels",
                           props.line(name))
    props.finish()
    return ReconstructionFilter.make(plugin.type, value)


def _film(plugin: Plugin) -> tuple[int, int, ReconstructionFilter]:
    if plugin.type in VARIANT_ONLY:
        raise unsupported(plugin, "film")
    if plugin.type != "hdrfilm":
        raise plugin.error("unsupported film (supported: hdrfilm)")
    props = Props(plugin)
    filters = children(plugin, {"rfilter": 1})["rfilter"]
    rfilter = _rfilter(filters[0] if filters else None)
    width, height = props.int("width", 768), props.int("height", 576)
    if width <= 0 or height <= 0:
        raise plugin.error("film width and height must be positive")
    for name in ("crop_offset_x", "crop_offset_y", "crop_width", "crop_height"):
        if props.has(name):
            raise plugin.error(f"{name} is not supported: the tracer renders the whole film "
                               "(remove the crop, or render at the cropped size)",
                               props.line(name))
    # Mitsuba's sample border is ceil(radius - 0.5) pixels: empty for the box filter.
    if props.bool("sample_border", False) and not rfilter.is_box:
        raise plugin.error(f"sample_border = true is not supported with a {rfilter.kind} filter "
                           "(samples are drawn inside the image only, Mitsuba's default)",
                           props.line("sample_border"))
    # Formats change storage, not values; compensate only changes summation accuracy; a
    # banner is drawn on LDR output only.
    props.ignore("pixel_format", "component_format", "file_format", "compensate", "banner")
    props.finish()
    return width, height, rfilter


# Mitsuba's samplers and their parameters besides sample_count and seed. Every one draws
# uniform samples whose expectation is the same image; the tracer uses independent ones.
SAMPLER_PARAMS = {"independent": (), "stratified": ("jitter",), "multijitter": ("jitter",),
                  "orthogonal": ("jitter", "strength"), "ldsampler": ()}
_warned_samplers: set = set()


def _sampler(plugin: Plugin) -> tuple[int, int]:
    if plugin.type in VARIANT_ONLY:
        raise unsupported(plugin, "sampler")
    if plugin.type not in SAMPLER_PARAMS:
        raise plugin.error(f"unsupported sampler (supported: {', '.join(SAMPLER_PARAMS)})")
    props = Props(plugin)
    children(plugin, {})
    props.ignore(*SAMPLER_PARAMS[plugin.type])
    _warn_sampler(plugin)
    spp, seed = props.int("sample_count", 4), props.int("seed", 0)
    if spp <= 0:
        raise plugin.error("sample_count must be positive", props.line("sample_count"))
    if not 0 <= seed <= SEED_MAX:
        raise plugin.error(f"seed must lie in [0, {SEED_MAX}] (an unsigned 32-bit integer, as "
                           f"in Mitsuba), got {seed}", props.line("seed"))
    props.finish()
    return spp, seed


def _warn_sampler(plugin: Plugin) -> None:
    """Say once per sampler type that the tracer samples independently (and so does the
    reference): stratified patterns would lower Mitsuba's per-pixel variance."""
    if plugin.type == "independent" or plugin.type in _warned_samplers:
        return
    _warned_samplers.add(plugin.type)
    warnings.warn(f"{plugin.file}:{plugin.line}: <sampler type=\"{plugin.type}\">: rendered with "
                  "independent samples (same expected image); mitsuba-refs renders its reference "
                  f"with an independent sampler too, because {plugin.type} sampling has a lower "
                  "per-pixel variance than the comparison's independent-sample statistics assume",
                  stacklevel=4)


def build_sensor(plugin: Plugin, resolution: tuple[int, int] | None = None,
                 spp: int | None = None) -> tuple[Camera, int, int]:
    """The perspective camera, with the film resolution and sampler settings.

    ``resolution`` (width, height) and ``spp`` replace the file's film size and
    sample count whatever it says; the field of view is then converted with the new
    aspect, as Mitsuba does for a film of that size (``fov_axis`` keeps its meaning).
    """
    if plugin.type != "perspective":
        raise unsupported(plugin, "sensor")
    props = Props(plugin)
    kids = children(plugin, {"film": 1, "sampler": 1, "medium": 1})
    if kids["film"]:
        width, height, rfilter = _film(kids["film"][0])
    else:   # Mitsuba's default film
        width, height, rfilter = 768, 576, ReconstructionFilter.make("gaussian")
    spp_file, seed = _sampler(kids["sampler"][0]) if kids["sampler"] else (4, 0)
    if resolution is not None:
        width, height = (int(v) for v in resolution)
    spp = spp_file if spp is None else int(spp)
    aspect = width / height
    if props.has("fov") and props.has("focal_length"):
        raise plugin.error("give either fov or focal_length, not both")
    if props.has("fov"):
        fov, axis = props.float("fov", None), props.string("fov_axis", "x").strip().lower()
    else:
        text = props.string("focal_length", "50mm").strip()
        try:
            focal = float(text[:-2] if text.endswith("mm") else text)
        except ValueError:
            raise plugin.error(f"could not parse focal_length \"{text}\" (use e.g. 50mm)",
                               props.line("focal_length")) from None
        # 35 mm film: the focal length fixes the diagonal field of view.
        fov, axis = 2.0 * np.rad2deg(np.arctan(np.hypot(36.0, 24.0) / (2.0 * focal))), "diagonal"
    try:
        x_fov = x_fov_from(fov, axis, aspect)
    except ValueError as e:
        raise plugin.error(str(e), props.line("fov_axis")) from None
    if not 0.0 < x_fov < 180.0:
        raise plugin.error(f"horizontal field of view {x_fov} must lie in (0, 180) degrees")
    to_world = props.transform("to_world")
    if transform.has_scale(to_world):
        raise plugin.error("scale factors in the camera's to_world are not allowed (as in Mitsuba)")
    near, far = props.float("near_clip", 1e-2), props.float("far_clip", 1e4)
    if not 0 < near < far:
        raise plugin.error("need 0 < near_clip < far_clip")
    for name in ("principal_point_offset_x", "principal_point_offset_y"):
        if props.float(name, 0.0) != 0.0:
            raise plugin.error(f"{name} is not supported", props.line(name))
    # A pinhole ignores the focus distance; without motion the shutter is irrelevant.
    props.ignore("focus_distance", "shutter_open", "shutter_close")
    props.finish()
    camera = Camera(to_world=to_world, x_fov=x_fov, near_clip=near, far_clip=far,
                    width=width, height=height, rfilter=rfilter)
    return camera, spp, seed


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
    integrator = factory("integrator", plugin.type)
    if integrator is None:
        raise unsupported(plugin, "integrator")
    if plugin.type == "direct":
        _check_direct_samples(plugin)
    children(plugin, {})
    allowed = INTEGRATOR_PARAMS.get(plugin.type)
    params = {}
    for name, prop in plugin.props.items():
        if allowed is not None and name not in allowed:
            raise plugin.error(f"unsupported property \"{name}\" (this tracer understands: "
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
    from .build_media import MediaTable

    kids = children(root, {"shape": 10**9, "bsdf": 10**9, "emitter": 10**9,
                            "sensor": 1, "integrator": 1, "texture": 10**9, "medium": 10**9,
                            "sampler": 10**9})
    media = MediaTable()
    shape_media = []
    for plugin in kids["sampler"]:   # top-level samplers: referenced by a sensor, or unused
        _sampler(plugin)
    geo = GeometryAccumulator()
    bsdf_objects, bsdf_index, textures = [], {}, {}
    emitters, environment = [], None
    shape_bsdf, shape_emitter = [], []
    folders = search_folders(root, base_dir)
    attached: dict[int, Plugin] = {}  # area emitter plugin -> the shape it lights

    def bsdf_id(plugin: Plugin | None, emitter: bool = False) -> int:
        # Mitsuba's default BSDF: diffuse 0.5, but black on an emitting shape.
        key = ("default", emitter) if plugin is None else id(plugin)
        if key not in bsdf_index:
            if plugin is None:
                bsdf_objects.append(bsdfs.Diffuse(np.full(3, 0.0 if emitter else 0.5)))
            else:
                bsdf_objects.append(build_bsdf(plugin, folders, textures))
            bsdf_index[key] = len(bsdf_objects) - 1
        return bsdf_index[key]

    # Top-level BSDFs and textures are built even when unused so that their errors surface.
    for plugin in kids["texture"]:
        build_texture(plugin, folders, textures)
    for plugin in kids["bsdf"]:
        bsdf_id(plugin)
    for plugin in kids["medium"]:
        media.index(plugin)
    for plugin, parent in instances.flatten(kids["shape"]):
        shape_id = len(shape_bsdf)
        bsdf_plugin, emitter_plugin = build_shape(plugin, geo, shape_id, folders, parent)
        shape_media.append(media.shape_media(plugin))
        shape_bsdf.append(bsdf_id(bsdf_plugin, emitter=emitter_plugin is not None))
        if emitter_plugin is not None:
            _attach(emitter_plugin, plugin, attached)
            emitters.append(build_area(emitter_plugin, shape_id))
            shape_emitter.append(len(emitters) - 1)
        else:
            shape_emitter.append(-1)
    for plugin in kids["emitter"]:
        if plugin.type == "area":
            _unattached_area(plugin, attached)
            continue
        emitter = build_emitter(plugin, folders)
        if emitter.kind in ("constant", "envmap"):
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

    return Scene(
        **geo.scene_fields(),
        shape_bsdf=np.array(shape_bsdf, dtype=np.int32),
        shape_emitter=np.array(shape_emitter, dtype=np.int32),
        bsdfs=bsdf_objects, emitters=emitters, environment=environment,
        camera=camera, spp=spp, seed=seed, integrator=integrator,
        source=source, **_media_fields(media, shape_media, camera_medium))


def _media_fields(media, shape_media: list, camera_medium: int) -> dict:
    """The :class:`Scene` fields of participating media (none: the defaults)."""
    if not media.media:
        return {}
    sides = np.array(shape_media, dtype=np.int32).reshape(-1, 2)
    return dict(media=media.media, shape_interior=sides[:, 0].copy(),
                shape_exterior=sides[:, 1].copy(), camera_medium=camera_medium)
