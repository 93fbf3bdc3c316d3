"""Interpret the generic :class:`~pathtracer.scene.xml.Plugin` tree as a :class:`Scene`.

Every plugin is read through :class:`Props`, which remembers which properties
were consumed: a property the tracer does not know is an error rather than
being silently ignored, because it would make the two renderers disagree.
"""
from __future__ import annotations

import os

import numpy as np

from . import meshes, transform
from ..film import FILTER_PARAMS, ReconstructionFilter
from .types import (AreaEmitter, Camera, ConstantEmitter, IntegratorSpec,
                    PointEmitter, Scene)
from .xml import Plugin

# Mitsuba's table of named indices of refraction (Hecht, Optics; ~589 nm).
IOR_BY_NAME = {
    "vacuum": 1.0, "helium": 1.000036, "hydrogen": 1.000132, "air": 1.000277,
    "carbon dioxide": 1.00045, "water": 1.3330, "acetone": 1.36, "ethanol": 1.361,
    "carbon tetrachloride": 1.461, "glycerol": 1.4729, "benzene": 1.501,
    "silicone oil": 1.52045, "bromine": 1.661, "water ice": 1.31,
    "fused quartz": 1.458, "pyrex": 1.470, "acrylic glass": 1.49,
    "polypropylene": 1.49, "bk7": 1.5046, "sodium chloride": 1.544, "amber": 1.55,
    "pet": 1.5750, "diamond": 2.419,
}
SUPPORTED = {
    "shape": ("rectangle", "cube", "disk", "sphere", "obj", "ply"),
    "bsdf": ("diffuse", "twosided", "conductor", "dielectric", "roughconductor"),
    "emitter": ("area", "point", "constant"),
    "sensor": ("perspective",),
    "integrator": ("path", "direct", "recursive", "path_bsdf", "path_nee", "smallpt"),
}
# Integrator parameters we validate; the project's own integrators take any.
INTEGRATOR_PARAMS = {
    "path": {"max_depth", "rr_depth", "hide_emitters"},
    "direct": {"emitter_samples", "bsdf_samples", "shading_samples", "hide_emitters"},
}
# Types of the integrator parameters with a Mitsuba meaning (any integrator).
INTEGRATOR_PARAM_TAGS = {"max_depth": "integer", "rr_depth": "integer",
                         "hide_emitters": "boolean", "emitter_samples": "integer",
                         "bsdf_samples": "integer", "shading_samples": "integer"}
COLOR_TAGS = ("rgb", "float", "integer")
FLOAT_TAGS = ("float", "integer")


class Props:
    """Typed, checked access to a plugin's properties.

    Call :meth:`finish` after reading: any property not read is reported.
    """

    def __init__(self, plugin: Plugin):
        self.plugin = plugin
        self.used: set[str] = set()

    def _get(self, name: str, tags: tuple, what: str):
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

    def color(self, name: str, default: float) -> np.ndarray:
        v = self._get(name, COLOR_TAGS, "an <rgb> (or <float>) colour")
        return np.full(3, float(default)) if v is None else np.broadcast_to(
            np.asarray(v, dtype=float), (3,)).copy()

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

    def raw(self, name: str):
        """The value whatever its type (for pass-through parameters)."""
        self.used.add(name)
        p = self.plugin.props.get(name)
        return None if p is None else p.value

    def ignore(self, *names: str) -> None:
        """Accept properties that do not change the rendered values."""
        self.used.update(names)

    def finish(self) -> None:
        for name, prop in self.plugin.props.items():
            if name not in self.used:
                known = sorted(self.used)
                raise self.plugin.error(
                    f"unsupported property \"{name}\" (this tracer understands: "
                    f"{', '.join(known) or 'none'})", prop.line)


def _children(plugin: Plugin, allowed: dict[str, int]) -> dict[str, list[Plugin]]:
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


def _unsupported(plugin: Plugin, what: str) -> Exception:
    return plugin.error(f"unsupported {what} (supported: {', '.join(SUPPORTED[plugin.kind])})")


# -- BSDFs -------------------------------------------------------------------

def _ior(props: Props, name: str, default: str) -> float:
    p = props.plugin.props.get(name)
    props.used.add(name)
    if p is None:
        return IOR_BY_NAME[default]
    if p.tag in FLOAT_TAGS:
        value = float(p.value)
    elif p.tag == "string":
        key = p.value.strip().lower()
        if key not in IOR_BY_NAME:
            raise props.plugin.error(f"unknown IOR name \"{p.value}\" (known: "
                                     f"{', '.join(IOR_BY_NAME)})", p.line)
        value = IOR_BY_NAME[key]
    else:
        raise props.plugin.error(f"\"{name}\" must be a <float> or a <string> name", p.line)
    if value <= 0:
        raise props.plugin.error(f"\"{name}\" must be positive", p.line)
    return value


def _no_material(props: Props) -> None:
    """Only Mitsuba's ``material="none"`` (a perfect, colourless mirror) is supported."""
    material = props.string("material", "none")
    for name in ("eta", "k"):
        if props.has(name):
            raise props.plugin.error(f"\"{name}\" is not supported: only material \"none\" "
                                     "(a perfect mirror scaled by specular_reflectance)",
                                     props.line(name))
    if material.strip().lower() != "none":
        raise props.plugin.error(f"conductor material \"{material}\" is not supported: "
                                 "only material \"none\" (a perfect mirror scaled by "
                                 "specular_reflectance)", props.line("material"))


def build_bsdf(plugin: Plugin):
    """Construct the :mod:`pathtracer.bsdfs` object for a ``<bsdf>`` element."""
    from pathtracer import bsdfs  # imported lazily: written concurrently

    props = Props(plugin)
    kind = plugin.type
    if kind == "twosided":
        nested = _children(plugin, {"bsdf": 1})["bsdf"]
        if len(nested) != 1:
            raise plugin.error("twosided needs exactly one nested <bsdf> "
                               "(different front/back materials are not supported)")
        props.finish()
        return bsdfs.TwoSided(build_bsdf(nested[0]))
    _children(plugin, {})
    if kind == "diffuse":
        result = bsdfs.Diffuse(props.color("reflectance", 0.5))
    elif kind == "conductor":
        _no_material(props)
        result = bsdfs.Conductor(props.color("specular_reflectance", 1.0))
    elif kind == "dielectric":
        result = bsdfs.Dielectric(_ior(props, "int_ior", "bk7"), _ior(props, "ext_ior", "air"),
                                  props.color("specular_reflectance", 1.0),
                                  props.color("specular_transmittance", 1.0))
    elif kind == "roughconductor":
        _no_material(props)
        distribution = props.string("distribution", "beckmann").strip().lower()
        if distribution not in ("beckmann", "ggx"):
            raise plugin.error(f"unknown microfacet distribution \"{distribution}\" "
                               "(beckmann or ggx)", props.line("distribution"))
        if not props.bool("sample_visible", True):
            raise plugin.error("sample_visible=false is not supported (only visible-normal "
                               "sampling)", props.line("sample_visible"))
        if props.has("alpha") and (props.has("alpha_u") or props.has("alpha_v")):
            raise plugin.error("give either alpha or alpha_u/alpha_v, not both",
                               props.line("alpha"))
        alpha = props.float("alpha", 0.1)
        alpha_u, alpha_v = props.float("alpha_u", alpha), props.float("alpha_v", alpha)
        if props.has("alpha_u") != props.has("alpha_v"):
            raise plugin.error("give both alpha_u and alpha_v")
        result = bsdfs.RoughConductor(distribution, alpha_u, alpha_v,
                                      props.color("specular_reflectance", 1.0))
    else:
        raise _unsupported(plugin, "BSDF")
    props.finish()
    return result


# -- shapes ------------------------------------------------------------------

class _Geometry:
    """Accumulates primitives of all shapes before they become arrays."""

    def __init__(self):
        self.tri_p, self.tri_n, self.tri_shape = [], [], []
        self.ntri = 0
        self.spheres, self.disks = [], []
        self.kind, self.prim, self.area, self.cdf, self.name = [], [], [], [], []

    def add_mesh(self, shape_id: int, p: np.ndarray, n: np.ndarray) -> None:
        areas = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
        total = areas.sum()
        cdf = np.cumsum(areas) / total if total > 0 else np.arange(1, len(p) + 1) / len(p)
        cdf[-1] = 1.0
        self.tri_p.append(p)
        self.tri_n.append(n)
        self.tri_shape.append(np.full(len(p), shape_id, dtype=np.int32))
        self.kind.append("mesh")
        self.prim.append((self.ntri, self.ntri + len(p)))
        self.area.append(total)
        self.cdf.append(cdf)
        self.ntri += len(p)


def _shape_label(plugin: Plugin) -> str:
    ident = f' "{plugin.id}"' if plugin.id else ""
    return f"{plugin.type}{ident} ({plugin.file}:{plugin.line})"


def _flip(p: np.ndarray, n: np.ndarray):
    """Reverse the winding (flips the geometric normal) and negate the
    shading normals: Mitsuba's ``flip_normals`` on meshes."""
    return p[:, ::-1].copy(), -n[:, ::-1]


def _planar_mesh(corners_local, normal_local, m, flip):
    """Triangles of a flat shape whose normal is the transformed local normal
    (Mitsuba's rectangle: normal by the inverse transpose, even when ``m``
    mirrors; the winding follows it)."""
    p = transform.apply_points(m, corners_local.reshape(-1, 3)).reshape(-1, 3, 3)
    n = transform.apply_normals(m, normal_local[None])[0]
    geo = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    if np.dot(geo[0], n) < 0:
        p = p[:, ::-1].copy()
    nn = np.broadcast_to(n, p.shape).copy()
    return _flip(p, nn) if flip else (p, nn)


_RECT_LOCAL = np.array([[[-1, -1, 0], [1, -1, 0], [1, 1, 0]],
                        [[-1, -1, 0], [1, 1, 0], [-1, 1, 0]]], dtype=float)


def _cube_local():
    """12 triangles of [-1, 1]^3, counter-clockwise seen from outside, and
    the outward face normal of each corner."""
    tris, normals = [], []
    for axis in range(3):
        for sign in (1.0, -1.0):
            n = np.zeros(3)
            n[axis] = sign
            u = np.zeros(3)
            u[(axis + 1) % 3] = 1.0
            v = np.cross(n, u)  # (u, v, n) right-handed: u x v = n
            quad = [n - u - v, n + u - v, n + u + v, n - u + v]
            tris += [[quad[0], quad[1], quad[2]], [quad[0], quad[2], quad[3]]]
            normals += [[n, n, n]] * 2
    return np.array(tris), np.array(normals)


def _load_mesh(plugin: Plugin, props: Props, base_dir: str) -> meshes.MeshData:
    filename = props.string("filename", None)
    if filename is None:
        raise plugin.error("missing <string name=\"filename\">")
    path = filename if os.path.isabs(filename) else os.path.join(base_dir, filename)
    if not os.path.isfile(path):
        raise plugin.error(f"mesh file not found: \"{filename}\" (looked for {path})",
                           props.line("filename"))
    try:
        return meshes.read_obj(path) if plugin.type == "obj" else meshes.read_ply(path)
    except meshes.MeshFormatError as e:
        raise plugin.error(str(e), props.line("filename")) from None


def _mesh_triangles(plugin, props, base_dir, m):
    """World-space triangles and shading normals of an obj/ply shape."""
    data = _load_mesh(plugin, props, base_dir)
    face_normals = props.bool("face_normals", False)
    props.ignore("flip_tex_coords")  # no textures: uv orientation is irrelevant
    pos = transform.apply_points(m, data.positions)
    p = pos[data.faces]
    if face_normals:
        geo = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
        n = np.repeat(meshes._unit(geo)[:, None], 3, axis=1)
    elif data.normals is not None:
        n = transform.apply_normals(m, data.normals)[data.faces]
    else:
        # Mitsuba recomputes after applying to_world, so angles are world angles.
        n = meshes.smooth_vertex_normals(pos, data.faces)[data.faces]
    return p, n


def build_shape(plugin: Plugin, geo: _Geometry, shape_id: int, base_dir: str):
    """Add one shape's primitives to ``geo``; returns its nested bsdf and emitter plugins."""
    props = Props(plugin)
    kids = _children(plugin, {"bsdf": 1, "emitter": 1})
    m = props.transform("to_world")
    flip = props.bool("flip_normals", False)
    kind = plugin.type
    if kind in ("rectangle", "cube", "obj", "ply"):
        if kind == "rectangle":
            p, n = _planar_mesh(_RECT_LOCAL, np.array([0.0, 0.0, 1.0]), m, flip)
        else:
            if kind == "cube":
                local_p, local_n = _cube_local()
                p = transform.apply_points(m, local_p.reshape(-1, 3)).reshape(-1, 3, 3)
                if props.bool("face_normals", False):
                    geo_n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
                    n = np.repeat(meshes._unit(geo_n)[:, None], 3, axis=1)
                else:
                    n = transform.apply_normals(m, local_n.reshape(-1, 3)).reshape(-1, 3, 3)
            else:
                p, n = _mesh_triangles(plugin, props, base_dir, m)
            if flip:
                p, n = _flip(p, n)
        geo.add_mesh(shape_id, p, n)
    elif kind == "sphere":
        center = props.point("center", np.zeros(3))
        radius = props.float("radius", 1.0)
        full = m @ transform.translate(center) @ transform.scale([radius] * 3)
        lin = full[:3, :3]
        s2 = np.trace(lin.T @ lin) / 3.0
        if s2 == 0 or not np.allclose(lin.T @ lin, s2 * np.eye(3), rtol=0, atol=1e-6 * s2):
            raise plugin.error("a sphere's to_world may only translate, rotate and scale "
                               "uniformly (non-uniform scale or shear would make an ellipsoid)")
        if np.linalg.det(lin) < 0:
            flip = not flip  # Mitsuba: a mirroring transform turns the sphere inside out
        geo.spheres.append((full[:3, 3].copy(), float(np.sqrt(s2)), flip, shape_id))
        geo.kind.append("sphere")
        geo.prim.append((len(geo.spheres) - 1, len(geo.spheres)))
        geo.area.append(4.0 * np.pi * s2)
        geo.cdf.append(None)
    elif kind == "disk":
        transform.check_affine(m)
        geo.disks.append((m, flip, shape_id))
        geo.kind.append("disk")
        geo.prim.append((len(geo.disks) - 1, len(geo.disks)))
        # The unit disk maps to an ellipse of area pi |u x v| (u, v = images of x, y).
        geo.area.append(np.pi * np.linalg.norm(np.cross(m[:3, 0], m[:3, 1])))
        geo.cdf.append(None)
    else:
        raise _unsupported(plugin, "shape")
    props.finish()
    geo.name.append(_shape_label(plugin))
    return (kids["bsdf"][0] if kids["bsdf"] else None,
            kids["emitter"][0] if kids["emitter"] else None)


# -- emitters, sensor, integrator -----------------------------------------

def build_area(plugin: Plugin, shape_id: int) -> AreaEmitter:
    """The ``<emitter type="area">`` nested in a shape."""
    if plugin.type != "area":
        raise plugin.error("only an area emitter can be nested in a shape")
    props = Props(plugin)
    _children(plugin, {})
    radiance = props.color("radiance", 1.0)
    props.finish()
    return AreaEmitter(shape=shape_id, radiance=radiance)


def build_emitter(plugin: Plugin):
    """A top-level ``point`` or ``constant`` emitter."""
    props = Props(plugin)
    _children(plugin, {})
    if plugin.type == "point":
        if props.has("position") and props.has("to_world"):
            raise plugin.error("give either position or to_world, not both")
        position = props.point("position", None)
        if position is None:
            position = props.transform("to_world")[:3, 3].copy()
        result = PointEmitter(position=position, intensity=props.color("intensity", 1.0))
    elif plugin.type == "constant":
        result = ConstantEmitter(radiance=props.color("radiance", 1.0))
    elif plugin.type == "area":
        raise plugin.error("an area emitter must be nested inside a <shape>")
    else:
        raise _unsupported(plugin, "emitter")
    props.finish()
    return result


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
    _children(plugin, {})
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
    if plugin.type != "hdrfilm":
        raise plugin.error("unsupported film (supported: hdrfilm)")
    props = Props(plugin)
    filters = _children(plugin, {"rfilter": 1})["rfilter"]
    rfilter = _rfilter(filters[0] if filters else None)
    width, height = props.int("width", 768), props.int("height", 576)
    if width <= 0 or height <= 0:
        raise plugin.error("film width and height must be positive")
    if props.bool("sample_border", False):
        raise plugin.error("sample_border = true is not supported (samples are drawn inside "
                           "the image only, Mitsuba's default)", props.line("sample_border"))
    # Formats change storage, not values; compensate only changes summation accuracy.
    props.ignore("pixel_format", "component_format", "compensate")
    props.finish()
    return width, height, rfilter


def _sampler(plugin: Plugin) -> tuple[int, int]:
    if plugin.type != "independent":
        raise plugin.error("unsupported sampler: only \"independent\" gives the i.i.d. samples "
                           "the statistical comparison assumes")
    props = Props(plugin)
    _children(plugin, {})
    spp, seed = props.int("sample_count", 4), props.int("seed", 0)
    if spp <= 0:
        raise plugin.error("sample_count must be positive", props.line("sample_count"))
    props.finish()
    return spp, seed


def build_sensor(plugin: Plugin) -> tuple[Camera, int, int]:
    """The perspective camera, with the film resolution and sampler settings."""
    if plugin.type != "perspective":
        raise _unsupported(plugin, "sensor")
    props = Props(plugin)
    kids = _children(plugin, {"film": 1, "sampler": 1})
    if kids["film"]:
        width, height, rfilter = _film(kids["film"][0])
    else:   # Mitsuba's default film
        width, height, rfilter = 768, 576, ReconstructionFilter.make("gaussian")
    spp, seed = _sampler(kids["sampler"][0]) if kids["sampler"] else (4, 0)
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
    if plugin.type not in SUPPORTED["integrator"]:
        raise _unsupported(plugin, "integrator")
    _children(plugin, {})
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
        params[name] = prop.value
    return IntegratorSpec(plugin.type, params)


# -- the scene -----------------------------------------------------------------

def _bbox(geo: _Geometry, tri_p: np.ndarray) -> np.ndarray:
    lo, hi = [], []
    if len(tri_p):
        lo.append(tri_p.reshape(-1, 3).min(0))
        hi.append(tri_p.reshape(-1, 3).max(0))
    for c, r, _, _ in geo.spheres:
        lo.append(c - r)
        hi.append(c + r)
    for m, _, _ in geo.disks:
        extent = np.sqrt(m[:3, 0] ** 2 + m[:3, 1] ** 2)
        lo.append(m[:3, 3] - extent)
        hi.append(m[:3, 3] + extent)
    if not lo:
        return np.zeros((2, 3))
    return np.array([np.min(lo, axis=0), np.max(hi, axis=0)])


def build_scene(root: Plugin, source: str, base_dir: str) -> Scene:
    """Turn the parsed ``<scene>`` into a :class:`Scene`.

    Parameters
    ----------
    root : Plugin
        The ``<scene>`` node from :func:`pathtracer.scene.xml.parse_file`.
    source : str
        Path or built-in name, stored in ``Scene.source``.
    base_dir : str
        Directory against which relative mesh file names are resolved.
    """
    kids = _children(root, {"shape": 10**9, "bsdf": 10**9, "emitter": 10**9,
                            "sensor": 1, "integrator": 1})
    geo = _Geometry()
    bsdf_objects, bsdf_index = [], {}
    emitters, environment = [], None
    shape_bsdf, shape_emitter = [], []

    def bsdf_id(plugin: Plugin | None) -> int:
        key = id(plugin)
        if key not in bsdf_index:
            if plugin is None:
                from pathtracer import bsdfs
                bsdf_objects.append(bsdfs.Diffuse(np.full(3, 0.5)))
            else:
                bsdf_objects.append(build_bsdf(plugin))
            bsdf_index[key] = len(bsdf_objects) - 1
        return bsdf_index[key]

    # Top-level BSDFs are built even when unused so that their errors surface.
    for plugin in kids["bsdf"]:
        bsdf_id(plugin)
    for shape_id, plugin in enumerate(kids["shape"]):
        if plugin.type not in SUPPORTED["shape"]:
            raise _unsupported(plugin, "shape")
        bsdf_plugin, emitter_plugin = build_shape(plugin, geo, shape_id, base_dir)
        shape_bsdf.append(bsdf_id(bsdf_plugin))
        if emitter_plugin is not None:
            emitters.append(build_area(emitter_plugin, shape_id))
            shape_emitter.append(len(emitters) - 1)
        else:
            shape_emitter.append(-1)
    for plugin in kids["emitter"]:
        emitter = build_emitter(plugin)
        if isinstance(emitter, ConstantEmitter):
            if environment is not None:
                raise plugin.error("at most one constant emitter is supported")
            environment = emitter
        emitters.append(emitter)
    if not kids["sensor"]:
        raise root.error("no <sensor>: add <sensor type=\"perspective\"> with a film")
    camera, spp, seed = build_sensor(kids["sensor"][0])
    integrator = build_integrator(kids["integrator"][0] if kids["integrator"] else None)

    tri_p = np.concatenate(geo.tri_p) if geo.tri_p else np.zeros((0, 3, 3))
    tri_n = np.concatenate(geo.tri_n) if geo.tri_n else np.zeros((0, 3, 3))
    tri_shape = np.concatenate(geo.tri_shape) if geo.tri_shape else np.zeros(0, np.int32)
    sph = geo.spheres
    dsk = geo.disks
    return Scene(
        tri_p=tri_p, tri_n=tri_n, tri_shape=tri_shape,
        sphere_center=np.array([s[0] for s in sph]).reshape(-1, 3),
        sphere_radius=np.array([s[1] for s in sph], dtype=float),
        sphere_flip=np.array([s[2] for s in sph], dtype=bool),
        sphere_shape=np.array([s[3] for s in sph], dtype=np.int32),
        disk_to_world=np.array([d[0] for d in dsk]).reshape(-1, 4, 4),
        disk_to_local=np.array([np.linalg.inv(d[0]) for d in dsk]).reshape(-1, 4, 4),
        disk_flip=np.array([d[1] for d in dsk], dtype=bool),
        disk_shape=np.array([d[2] for d in dsk], dtype=np.int32),
        shape_kind=geo.kind,
        shape_prim=np.array(geo.prim, dtype=np.int64).reshape(-1, 2),
        shape_bsdf=np.array(shape_bsdf, dtype=np.int32),
        shape_emitter=np.array(shape_emitter, dtype=np.int32),
        shape_area=np.array(geo.area, dtype=float),
        shape_tri_cdf=geo.cdf, shape_name=geo.name,
        bsdfs=bsdf_objects, emitters=emitters, environment=environment,
        camera=camera, spp=spp, seed=seed, integrator=integrator,
        source=source, bbox=_bbox(geo, tri_p))
