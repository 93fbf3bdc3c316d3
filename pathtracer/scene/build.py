"""Interpret the generic :class:`~pathtracer.scene.xml.Plugin` tree as a :class:`Scene`.

Every plugin is read through :class:`Props`, which remembers which properties
were consumed: a property the tracer does not know is an error rather than
being silently ignored, because it would make the two renderers disagree.
"""
from __future__ import annotations

import os
import warnings

import numpy as np

# A plugin package registers its plugins when imported (pathtracer.scene.registry).
from .. import emitters as _emitter_plugins  # noqa: F401
from .. import media as _medium_plugins  # noqa: F401
from .. import sensors as _sensor_plugins  # noqa: F401
from ..emitters.base import Emitter
from ..io import meshes
from ..media.homogeneous import HomogeneousMedium
from ..sensors.perspective_sensor import Camera
from ..sensors.sampler import build_sampler
from ..shapes import instances
from . import transform
from .properties import (
    FLOAT_TAGS,
    SUPPORTED,
    Props,
    build_texture,
    children,
    find_file,
    search_folders,
    unsupported,
)
from .registry import factory, register
from .types import IntegratorSpec, Scene
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
# BSDFs that only make sense in Mitsuba's polarised variants: refused with the reason.
VARIANT_ONLY_BSDFS = {
    "polarizer": "is a polarisation filter (only meaningful in Mitsuba's *_polarized variants)",
    "retarder": "is a polarisation retarder (only meaningful in Mitsuba's *_polarized variants)",
    "circular": "is a circular polariser (only meaningful in Mitsuba's *_polarized variants)",
    "pplastic": "is the polarised plastic model (only meaningful in Mitsuba's *_polarized variants)",
    "measured_polarized": "is a measured polarised BSDF (only meaningful in Mitsuba's "
                          "*_polarized variants)",
}
# Integrator parameters we validate; the project's own integrators take any.
INTEGRATOR_PARAMS = {
    "path": {"max_depth", "rr_depth", "hide_emitters"},
    "volpath": {"max_depth", "rr_depth", "hide_emitters"},
    "direct": {"emitter_samples", "bsdf_samples", "shading_samples", "hide_emitters"},
    "ptracer": {"max_depth", "rr_depth", "hide_emitters"},
}
#: Mitsuba integrators rendered by this tracer's integrator of another name.
INTEGRATOR_ALIASES = {"ptracer": "light"}
# Types of the integrator parameters with a Mitsuba meaning (any integrator).
INTEGRATOR_PARAM_TAGS = {"max_depth": "integer", "rr_depth": "integer",
                         "hide_emitters": "boolean", "emitter_samples": "integer",
                         "bsdf_samples": "integer", "shading_samples": "integer"}
# -- BSDFs -------------------------------------------------------------------

def _ior(props: Props, name: str, default: str) -> float:
    if name in props.textures:
        props._no_texture(name)
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


def _conductor_ior(props: Props) -> tuple[np.ndarray, np.ndarray]:
    """Complex IOR ``(eta, k)`` of a conductor: Mitsuba's ``material`` preset or explicit values.

    As Mitsuba: ``material="none"`` (the default) is ``0 + 1i``, a perfect
    mirror; explicit ``eta`` / ``k`` default to 0 / 1 and cannot be combined
    with another material.
    """
    from pathtracer.bsdfs.conductor_presets import CONDUCTOR_PRESETS

    material = props.string("material", "none").strip()
    if material == "none" or props.has("eta"):
        if material != "none":
            raise props.plugin.error(f"give either eta/k or material=\"{material}\", not both",
                                     props.line("material"))
        return props.color("eta", 0.0, kind="unbounded"), props.color("k", 1.0, kind="unbounded")
    if material not in CONDUCTOR_PRESETS:
        raise props.plugin.error(f"unknown conductor material \"{material}\" (known: none, "
                                 f"{', '.join(CONDUCTOR_PRESETS)})", props.line("material"))
    if props.has("k"):
        raise props.plugin.error(f"\"k\" without \"eta\" cannot be combined with material="
                                 f"\"{material}\" (give both eta and k, or only the material)",
                                 props.line("k"))
    eta, k = CONDUCTOR_PRESETS[material]
    return np.array(eta), np.array(k)


def _microfacet(props: Props, anisotropic: bool = True) -> tuple[str, float, float, bool]:
    """``distribution``, ``alpha_u``, ``alpha_v``, ``sample_visible`` of a microfacet BSDF
    (Mitsuba's rules and defaults)."""
    plugin = props.plugin
    distribution = props.string("distribution", "beckmann").strip().lower()
    if distribution not in ("beckmann", "ggx"):
        raise plugin.error(f"unknown microfacet distribution \"{distribution}\" "
                           "(beckmann or ggx)", props.line("distribution"))
    sample_visible = props.bool("sample_visible", True)
    if not sample_visible and plugin.type == "roughdielectric":
        # Measured: at 80 degrees (GGX, alpha 0.3, eta 1.5) its mean sample weight is
        # 0.931 +- 0.005 where the integral of its own eval is 0.875.
        raise plugin.error("sample_visible=false is refused for roughdielectric: Mitsuba 3.9.1 "
                           "then widens the sampled roughness but leaves D/D_widened out of the "
                           "sample weight, a biased estimator this tracer does not reproduce",
                           props.line("sample_visible"))
    given = {name for name in ("alpha", "alpha_u", "alpha_v")
             if props.has(name) or name in props.textures}
    if "alpha" in given and given & {"alpha_u", "alpha_v"}:
        raise plugin.error("give either alpha or alpha_u/alpha_v, not both",
                           props.line_of("alpha"))
    if ("alpha_u" in given) != ("alpha_v" in given):
        name = "alpha_u" if "alpha_u" in given else "alpha_v"
        raise plugin.error("give both alpha_u and alpha_v", props.line_of(name))
    if "alpha_u" in given and not anisotropic:
        raise plugin.error(f"{plugin.type} supports only isotropic roughness (alpha), as in "
                           "Mitsuba", props.line_of("alpha_u"))
    alpha = _roughness(props, "alpha", 0.1, anisotropic)
    alpha_u = _roughness(props, "alpha_u", alpha, anisotropic)
    alpha_v = _roughness(props, "alpha_v", alpha, anisotropic)
    return distribution, alpha_u, alpha_v, sample_visible


def _roughness(props: Props, name: str, default, textured: bool):
    """A roughness: a number (>= 0), or, where Mitsuba takes one (``roughconductor``,
    ``roughdielectric``), a nested texture read per hit with ``eval_1``."""
    if textured and name in props.textures:
        props.used.add(name)
        return build_texture(props.textures[name], props.folders, props.texture_cache)
    value = props.float(name, default)
    if props.has(name) and not value >= 0.0:
        raise props.plugin.error(f"\"{name}\" must be >= 0", props.line(name))
    return value


def _distinct_iors(props: Props, default_int: str) -> tuple[float, float]:
    """``int_ior`` and ``ext_ior``, which the rough interfaces need to differ (Mitsuba's check)."""
    int_ior, ext_ior = _ior(props, "int_ior", default_int), _ior(props, "ext_ior", "air")
    if int_ior == ext_ior:
        raise props.plugin.error(f"{props.plugin.type} needs int_ior != ext_ior (both {int_ior:g})",
                                 props.line("int_ior") if props.has("int_ior") else None)
    return int_ior, ext_ior


def _build_plastic(props: Props, bsdfs, colour):
    """``plastic`` / ``roughplastic``: shared parameters, then the smooth or rough model."""
    rough = props.plugin.type == "roughplastic"
    if rough:
        int_ior, ext_ior = _distinct_iors(props, "polypropylene")
    else:
        int_ior, ext_ior = _ior(props, "int_ior", "polypropylene"), _ior(props, "ext_ior", "air")
    # A texture's mean (Texture.mean) sets the lobe-selection weight, as in Mitsuba.
    common = dict(diffuse_reflectance=colour("diffuse_reflectance", 0.5),
                  specular_reflectance=colour("specular_reflectance", 1.0),
                  int_ior=int_ior, ext_ior=ext_ior, nonlinear=props.bool("nonlinear", False))
    if not rough:
        return bsdfs.Plastic(**common)
    distribution, alpha, _, sample_visible = _microfacet(props, anisotropic=False)
    return bsdfs.RoughPlastic(distribution, alpha, **common, sample_visible=sample_visible)


def build_bsdf(plugin: Plugin, folders: list[str] = (".",), textures: dict | None = None):
    """Construct the :mod:`pathtracer.bsdfs` object for a ``<bsdf>`` element.

    Parameters
    ----------
    plugin : Plugin
    folders : list of str
        Where texture files are looked up (:func:`search_folders`).
    textures : dict, optional
        Textures already built, by ``id`` of their plugin (textures shared by ``<ref>``
        read the image once).
    """
    from pathtracer import bsdfs  # imported lazily: written concurrently

    textures = {} if textures is None else textures
    props = Props(plugin)
    props.folders, props.texture_cache = folders, textures
    kind = plugin.type
    if kind in COMPOSITE_BSDFS:
        result = _build_composite(props, bsdfs)
        props.finish()
        return result
    if kind in ("bumpmap", "normalmap"):
        result = _build_perturbed(props, bsdfs)
        props.finish()
        return result
    children(plugin, {"texture": 10**9})

    def colour(name, default):
        return props.reflectance_or_texture(name, default, folders, textures)

    if kind == "diffuse":
        result = bsdfs.Diffuse(colour("reflectance", 0.5))
    elif kind == "conductor":
        eta, k = _conductor_ior(props)
        result = bsdfs.Conductor(colour("specular_reflectance", 1.0), eta, k)
    elif kind in ("dielectric", "thindielectric"):
        cls = bsdfs.Dielectric if kind == "dielectric" else bsdfs.ThinDielectric
        result = cls(_ior(props, "int_ior", "bk7"), _ior(props, "ext_ior", "air"),
                     colour("specular_reflectance", 1.0), colour("specular_transmittance", 1.0))
    elif kind == "roughdielectric":
        int_ior, ext_ior = _distinct_iors(props, "bk7")
        distribution, alpha_u, alpha_v, _ = _microfacet(props)
        result = bsdfs.RoughDielectric(distribution, alpha_u, alpha_v, int_ior, ext_ior,
                                       colour("specular_reflectance", 1.0),
                                       colour("specular_transmittance", 1.0))
    elif kind == "roughconductor":
        eta, k = _conductor_ior(props)
        distribution, alpha_u, alpha_v, sample_visible = _microfacet(props)
        result = bsdfs.RoughConductor(distribution, alpha_u, alpha_v,
                                      colour("specular_reflectance", 1.0), eta, k,
                                      sample_visible)
    elif kind in ("plastic", "roughplastic"):
        result = _build_plastic(props, bsdfs, colour)
    elif kind == "null":
        result = bsdfs.NullBSDF()
    elif kind in VARIANT_ONLY_BSDFS:
        raise plugin.error(f"BSDF \"{kind}\" {VARIANT_ONLY_BSDFS[kind]}")
    else:
        raise unsupported(plugin, "BSDF")
    props.finish()
    return result


# BSDFs built of nested BSDFs: how many they take, and their scalar texture parameter.
COMPOSITE_BSDFS = {"twosided": ((1, 2), None, None), "blendbsdf": ((2, 2), "weight", None),
                   "mask": ((1, 1), "opacity", 0.5)}


def _build_composite(props: Props, bsdfs):
    """``twosided`` (one BSDF for both sides, or front and back), ``blendbsdf``
    (two BSDFs and a ``weight``) and ``mask`` (one BSDF and an ``opacity``)."""
    plugin = props.plugin
    (least, most), scalar, default = COMPOSITE_BSDFS[plugin.type]
    nested = children(plugin, {"bsdf": most, "texture": 1 if scalar else 0})["bsdf"]
    if len(nested) < least:
        raise plugin.error(f"{plugin.type} needs {'exactly' if least == most else 'at least'} "
                           f"{least} nested <bsdf>, got {len(nested)}")
    inner = [build_bsdf(child, props.folders, props.texture_cache) for child in nested]
    if plugin.type == "twosided":
        return bsdfs.TwoSided(*inner)
    value = _scalar_or_texture(props, scalar, default)
    if plugin.type == "blendbsdf":
        return bsdfs.BlendBSDF(inner[0], inner[1], value)
    return bsdfs.MaskBSDF(inner[0], value)


def _scalar_or_texture(props: Props, name: str, default):
    """A number or a nested texture read per hit with ``eval_1`` (Mitsuba clips both to
    [0, 1] for a blend weight or an opacity); ``default`` None means required."""
    if name in props.textures:
        props.used.add(name)
        return build_texture(props.textures[name], props.folders, props.texture_cache)
    if default is None and not props.has(name):
        raise props.plugin.error(f"missing \"{name}\" (a <float> or a <texture>)")
    return props.float(name, default)


def _build_perturbed(props: Props, bsdfs):
    """``normalmap`` (an RGB texture named ``normalmap``) and ``bumpmap`` (one height
    texture of any name, ``scale`` 1), each around one nested BSDF; both take
    ``flip_invalid_normals`` and ``use_shadowing_function`` (true), as in Mitsuba."""
    from pathtracer.textures.base import BitmapTexture

    plugin = props.plugin
    kids = children(plugin, {"bsdf": 1, "texture": 1})
    if not kids["bsdf"]:
        raise plugin.error(f"{plugin.type} needs exactly one nested <bsdf>")
    nested = build_bsdf(kids["bsdf"][0], props.folders, props.texture_cache)
    flags = dict(flip_invalid_normals=props.bool("flip_invalid_normals", True),
                 use_shadowing_function=props.bool("use_shadowing_function", True))
    if plugin.type == "normalmap":
        if "normalmap" not in props.textures:
            raise plugin.error("normalmap needs a <texture name=\"normalmap\">")
        props.used.add("normalmap")
        texture = build_texture(props.textures["normalmap"], props.folders, props.texture_cache)
        return bsdfs.NormalMap(nested, texture, **flags)
    if not kids["texture"]:
        raise plugin.error("bumpmap needs one nested <texture> (the height)")
    name = next(iter(props.textures))
    props.used.add(name)
    texture = build_texture(props.textures[name], props.folders, props.texture_cache)
    if not isinstance(texture, BitmapTexture):
        raise props.textures[name].error(
            f"a bumpmap's height must be a bitmap: Mitsuba differentiates only bitmaps "
            f"(eval_1_grad), not \"{props.textures[name].type}\"")
    return bsdfs.BumpMap(nested, texture, props.float("scale", 1.0), **flags)


# -- textures ----------------------------------------------------------------

@register("texture", "bitmap", "checkerboard", "rawconstant")
def _build_texture(plugin: Plugin, folders: list[str], cache: dict):
    from pathtracer.io.bitmap import read_bitmap
    from pathtracer.textures import base as textures

    props = Props(plugin)
    children(plugin, {"texture": 2})
    to_uv = props.transform("to_uv")
    if plugin.type == "checkerboard":
        result = textures.Checkerboard(props.reflectance_or_texture("color0", 0.4, folders, cache),
                                       props.reflectance_or_texture("color1", 0.2, folders, cache),
                                       to_uv)
    elif plugin.type == "rawconstant":
        # A value used as given (no colour conversion, no range check): a float or a vector.
        value = props._get("value", ("float", "integer", "vector", "point", "rgb"),
                           "a <float> or a <vector>")
        if value is None:
            raise plugin.error("missing \"value\" (a <float> or a <vector>)")
        result = textures.ConstantTexture(np.asarray(value, dtype=float))
    elif plugin.type == "bitmap":
        filter_type = props.string("filter_type", "bilinear").strip().lower()
        wrap_mode = props.string("wrap_mode", "repeat").strip().lower()
        for name, value, allowed in (("filter_type", filter_type, textures.FILTER_TYPES),
                                     ("wrap_mode", wrap_mode, textures.WRAP_MODES)):
            if value not in allowed:
                raise plugin.error(f"unknown {name} \"{value}\" (supported: "
                                   f"{', '.join(allowed)})", props.line(name))
        raw = props.bool("raw", False)
        # accel only picks hardware texture units on GPUs, format the storage precision
        # (half or the variant's float): the values are the same up to rounding.
        props.ignore("accel", "format")
        path = find_file(plugin, props, "filename", folders)
        try:
            data = read_bitmap(path, raw=raw)
        except ValueError as e:
            raise plugin.error(f"{os.path.basename(path)}: {e}", props.line("filename")) from None
        result = textures.BitmapTexture(data, filter_type, wrap_mode, to_uv)
    else:
        raise unsupported(plugin, "texture")
    props.finish()
    return result


# -- shapes ------------------------------------------------------------------

class _Geometry:
    """Accumulates primitives of all shapes before they become arrays."""

    def __init__(self):
        self.tri_p, self.tri_n, self.tri_uv, self.tri_shape = [], [], [], []
        self.ntri = 0
        self.spheres, self.disks, self.curves, self.cylinders = [], [], [], []
        self.kind, self.prim, self.area, self.cdf, self.name = [], [], [], [], []

    def add_mesh(self, shape_id: int, p: np.ndarray, n: np.ndarray, uv: np.ndarray) -> None:
        """Add a mesh shape: (k, 3, 3) vertices, normals and (k, 3, 2) texture coordinates."""
        areas = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
        total = areas.sum()
        cdf = np.cumsum(areas) / total if total > 0 else np.arange(1, len(p) + 1) / len(p)
        cdf[-1] = 1.0
        self.tri_p.append(p)
        self.tri_n.append(n)
        self.tri_uv.append(uv)
        self.tri_shape.append(np.full(len(p), shape_id, dtype=np.int32))
        self.kind.append("mesh")
        self.prim.append((self.ntri, self.ntri + len(p)))
        self.area.append(total)
        self.cdf.append(cdf)
        self.ntri += len(p)

    def add_analytic(self, kind: str, table: list, entry, area: float) -> None:
        """Add one analytic shape (sphere, disk, curve, cylinder): ``entry`` goes into its
        ``table`` (e.g. ``self.spheres``); its primitive range is that one row."""
        table.append(entry)
        self.kind.append(kind)
        self.prim.append((len(table) - 1, len(table)))
        self.area.append(area)
        self.cdf.append(None)


def _shape_label(plugin: Plugin) -> str:
    ident = f' "{plugin.id}"' if plugin.id else ""
    return f"{plugin.type}{ident} ({plugin.file}:{plugin.line})"


def _flip(p: np.ndarray, n: np.ndarray, uv: np.ndarray):
    """Reverse the winding (flips the geometric normal) and negate the
    shading normals: Mitsuba's ``flip_normals`` on meshes. The texture
    coordinates follow their vertices."""
    return p[:, ::-1].copy(), -n[:, ::-1], uv[:, ::-1].copy()


def _normals(props: "Props", m: np.ndarray, n: np.ndarray) -> np.ndarray:
    """Object-space normals to world space as Mitsuba does: by the inverse
    transpose of ``to_world``, or by the matrix it tracks instead after a
    ``<rotate>`` about a non-unit axis."""
    normal_m = props.normal_matrix("to_world")
    if normal_m is None:
        return transform.apply_normals(m, n)
    return transform.apply_normal_matrix(normal_m, n)


def _planar_mesh(corners_local, normal_local, m, flip, props):
    """Triangles of a flat shape whose normal is the transformed local normal
    (Mitsuba's rectangle: normal by the inverse transpose, even when ``m``
    mirrors; the winding follows the true geometric normal). Texture
    coordinates: Mitsuba's rectangle maps local (x, y) in [-1, 1]^2 to
    ((x + 1) / 2, (y + 1) / 2)."""
    p = transform.apply_points(m, corners_local.reshape(-1, 3)).reshape(-1, 3, 3)
    uv = 0.5 * (corners_local[:, :, :2] + 1.0)
    n = _normals(props, m, normal_local[None])[0]
    geo = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    if np.dot(geo[0], n) < 0:
        p, uv = p[:, ::-1].copy(), uv[:, ::-1].copy()
    nn = np.broadcast_to(n, p.shape).copy()
    return _flip(p, nn, uv) if flip else (p, nn, uv)


_RECT_LOCAL = np.array([[[-1, -1, 0], [1, -1, 0], [1, 1, 0]],
                        [[-1, -1, 0], [1, 1, 0], [-1, 1, 0]]], dtype=float)


# Texture coordinates of Mitsuba's cube, per face (axis, sign): u and v as
# 0.5 + 0.5 * (sign_u * x[axis_u]), 0.5 + 0.5 * (sign_v * x[axis_v]) of the local
# corner x (measured with Mitsuba 3.9.1: SurfaceInteraction3f.uv of cube hits).
_CUBE_UV = {(0, 1.0): ((1, 1.0), (2, -1.0)), (0, -1.0): ((1, 1.0), (2, 1.0)),
            (1, 1.0): ((0, -1.0), (2, -1.0)), (1, -1.0): ((2, 1.0), (0, 1.0)),
            (2, 1.0): ((1, 1.0), (0, 1.0)), (2, -1.0): ((1, -1.0), (0, 1.0))}


def _cube_local():
    """12 triangles of [-1, 1]^3, counter-clockwise seen from outside, the
    outward face normal of each corner and Mitsuba's texture coordinates."""
    tris, normals, uvs = [], [], []
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
            (au, su), (av, sv) = _CUBE_UV[(axis, sign)]
            uv = [[0.5 + 0.5 * su * c[au], 0.5 + 0.5 * sv * c[av]] for c in quad]
            uvs += [[uv[0], uv[1], uv[2]], [uv[0], uv[2], uv[3]]]
    return np.array(tris), np.array(normals), np.array(uvs)


def _load_mesh(plugin: Plugin, props: Props, folders: list[str]) -> meshes.MeshData:
    path = find_file(plugin, props, "filename", folders)
    try:
        if plugin.type == "obj":
            return meshes.read_obj(path)
        if plugin.type == "ply":
            return meshes.read_ply(path)
        index = props.int("shape_index", 0)
        return meshes.read_serialized(path, index)
    except meshes.MeshFormatError as e:
        raise plugin.error(str(e), props.line("filename")) from None
    except OSError as e:
        raise plugin.error(f"cannot read mesh file \"{os.path.basename(path)}\": "
                           f"{e.strerror or e}", props.line("filename")) from None


def _mesh_triangles(plugin, props, folders, m):
    """World-space triangles and shading normals of an obj/ply/serialized shape."""
    data = _load_mesh(plugin, props, folders)
    face_normals = props.bool("face_normals", False)
    # Mitsuba flips v (v -> 1 - v) by default for OBJ files only; its serialized
    # shape has no flip_tex_coords parameter (never flips).
    flip_v = plugin.type != "serialized" and props.bool("flip_tex_coords", plugin.type == "obj")
    pos = transform.apply_points(m, data.positions)
    p = pos[data.faces]
    if data.texcoords is None:
        # Without stored coordinates Mitsuba's uv is the barycentrics (b1, b2).
        uv = np.broadcast_to(_BARYCENTRIC_UV, (len(p), 3, 2)).copy()
    else:
        uv = data.texcoords[data.faces]
        if flip_v:
            uv[:, :, 1] = 1.0 - uv[:, :, 1]
    if face_normals:
        geo = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
        n = np.repeat(meshes._unit(geo)[:, None], 3, axis=1)
    elif data.normals is not None:
        n = _normals(props, m, data.normals)[data.faces]
    else:
        # Mitsuba recomputes after applying to_world, so angles are world angles.
        n = meshes.smooth_vertex_normals(pos, data.faces)[data.faces]
    return p, n, uv


_BARYCENTRIC_UV = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])


def build_shape(plugin: Plugin, geo: _Geometry, shape_id: int, folders: list[str],
                parent: np.ndarray | None = None):
    """Add one shape's primitives to ``geo``; returns its nested bsdf and emitter plugins.

    ``folders`` are where mesh files are looked up (:func:`search_folders`). ``parent``
    is the ``to_world`` of the ``instance`` the shape is drawn by, applied after the
    shape's own (:mod:`pathtracer.scene.instances`).
    """
    props = Props(plugin)
    kids = children(plugin, {"bsdf": 1, "emitter": 1, "medium": 2})
    m = props.transform("to_world")
    if parent is not None:
        m = parent @ m
    flip = props.bool("flip_normals", False)
    kind = plugin.type
    if kind in ("rectangle", "cube", "obj", "ply", "serialized"):
        if kind == "rectangle":
            p, n, uv = _planar_mesh(_RECT_LOCAL, np.array([0.0, 0.0, 1.0]), m, flip, props)
        else:
            if kind == "cube":
                local_p, local_n, uv = _cube_local()
                p = transform.apply_points(m, local_p.reshape(-1, 3)).reshape(-1, 3, 3)
                if props.bool("face_normals", False):
                    geo_n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
                    n = np.repeat(meshes._unit(geo_n)[:, None], 3, axis=1)
                else:
                    n = _normals(props, m, local_n.reshape(-1, 3)).reshape(-1, 3, 3)
            else:
                p, n, uv = _mesh_triangles(plugin, props, folders, m)
            if flip:
                p, n, uv = _flip(p, n, uv)
        geo.add_mesh(shape_id, p, n, uv)
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
        # Object frame for texture coordinates: the inverse of the rotation (a
        # mirror included) left after dividing out the radius.
        to_local = (lin / np.sqrt(s2)).T
        geo.add_analytic("sphere", geo.spheres,
                         (full[:3, 3].copy(), float(np.sqrt(s2)), flip, shape_id, to_local),
                         4.0 * np.pi * s2)
    elif kind in ("bsplinecurve", "linearcurve"):
        _build_curve(plugin, props, geo, shape_id, folders, m, flip, kids)
    elif kind == "disk":
        transform.check_affine(m)
        if props.normal_matrix("to_world") is not None:
            raise plugin.error("a disk rotated about a non-unit axis is not supported (Mitsuba "
                               "then transforms its normal inconsistently with its surface)",
                               props.line("to_world"))
        # The unit disk maps to an ellipse of area pi |u x v| (u, v = images of x, y).
        geo.add_analytic("disk", geo.disks, (m, flip, shape_id),
                         np.pi * np.linalg.norm(np.cross(m[:3, 0], m[:3, 1])))
    elif kind == "cylinder":
        _add_cylinder(plugin, props, geo, shape_id, m, flip, kids["emitter"])
    else:
        raise unsupported(plugin, "shape")
    props.finish()
    geo.name.append(_shape_label(plugin))
    return (kids["bsdf"][0] if kids["bsdf"] else None,
            kids["emitter"][0] if kids["emitter"] else None)


def _build_curve(plugin, props, geo, shape_id, folders, m, flip, kids):
    """A ``bsplinecurve`` or ``linearcurve``: control points read and moved to world space."""
    from ..shapes.curves import CurveFileError, CurveShape, read_control_points
    if flip:
        raise plugin.error("flip_normals is not supported on curves (Mitsuba only ever "
                           "hits their outside)", props.line("flip_normals"))
    if kids["emitter"]:
        raise kids["emitter"][0].error("an area emitter on a curve is not supported (this "
                                       "tracer cannot sample points on curves)")
    transform.check_affine(m)
    path = find_file(plugin, props, "filename", folders)
    bspline = plugin.type == "bsplinecurve"
    try:
        curves = read_control_points(path, 4 if bspline else 2)
    except CurveFileError as e:
        raise plugin.error(f"{os.path.basename(path)}: {e}", props.line("filename")) from None
    except OSError as e:
        raise plugin.error(f"cannot read curve file \"{os.path.basename(path)}\": "
                           f"{e.strerror or e}", props.line("filename")) from None
    world = [np.column_stack([transform.apply_points(m, c[:, :3]), c[:, 3]]) for c in curves]
    if any(np.any(c[:, 3] < 0) for c in world):
        raise plugin.error(f"{os.path.basename(path)}: a control point has a negative radius",
                           props.line("filename"))
    shape = CurveShape(world, "bspline" if bspline else "linear", shape_id)
    geo.add_analytic("curve", geo.curves, shape, shape.area())


def _add_cylinder(plugin, props, geo, shape_id, m, flip, emitters) -> None:
    """Mitsuba's analytic ``cylinder`` (:mod:`pathtracer.cylinder`): ``p0`` (0, 0, 0),
    ``p1`` (0, 0, 1), ``radius`` (1), open at both ends."""
    from pathtracer.shapes.cylinder import cylinder_matrix

    if emitters:
        raise emitters[0].error("an area emitter on a cylinder is not supported (this tracer "
                                "samples area lights on meshes, spheres and disks only)")
    p0, p1 = props.point("p0", np.zeros(3)), props.point("p1", np.array([0.0, 0.0, 1.0]))
    radius = props.float("radius", 1.0)
    if not radius > 0 or not np.linalg.norm(p1 - p0) > 0:
        raise plugin.error("a cylinder needs radius > 0 and p0 != p1")
    transform.check_affine(m)
    full = cylinder_matrix(m, p0, p1, radius)
    if np.linalg.det(full[:3, :3]) <= 0:
        raise plugin.error("a mirroring to_world is not supported on a cylinder (Mitsuba flips "
                           "its normals by a rule this tracer does not reproduce)",
                           props.line("to_world"))
    # Mitsuba: 2 pi r l, r and l the lengths of the images of local x and z.
    geo.add_analytic("cylinder", geo.cylinders, (full, flip, shape_id),
                     2.0 * np.pi * np.linalg.norm(full[:3, 0]) * np.linalg.norm(full[:3, 2]))


# -- emitters, sensor, integrator -----------------------------------------

def build_emitter(plugin: Plugin, folders: list[str] = (".",), shape: int | None = None) -> Emitter:
    """The emitter of an ``<emitter>`` element: a top-level one, or (``shape`` given) the area
    emitter of the shape of that index.

    An emitter's factory is called as ``create(props, folders, shape)``: its :class:`Props`
    (read by the factory, checked here when it returns), where files are looked up, and the
    shape index (None at the top level).
    """
    if shape is not None and plugin.type != "area":
        raise plugin.error("only an area emitter can be nested in a shape")
    props = Props(plugin)
    create = factory("emitter", plugin.type)
    if create is None:
        raise unsupported(plugin, "emitter")
    result = create(props, folders, shape)
    props.finish()
    return result


def build_sensor(plugin: Plugin, resolution: tuple[int, int] | None = None,
                 spp: int | None = None) -> tuple[Camera, int, int]:
    """The camera of the ``<sensor>``, with the film resolution and the sampler's sample count
    and seed: its factory is called as ``create(plugin, resolution, spp)``, ``resolution``
    (width, height) and ``spp`` replacing the file's when given."""
    create = factory("sensor", plugin.type)
    if create is None:
        raise unsupported(plugin, "sensor")
    return create(plugin, resolution, spp)


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
    if plugin.type not in SUPPORTED["integrator"]:
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
    return IntegratorSpec(INTEGRATOR_ALIASES.get(plugin.type, plugin.type), params)


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

def _bbox(geo: _Geometry, tri_p: np.ndarray) -> np.ndarray:
    lo, hi = [], []
    if len(tri_p):
        lo.append(tri_p.reshape(-1, 3).min(0))
        hi.append(tri_p.reshape(-1, 3).max(0))
    for c, r, *_ in geo.spheres:
        lo.append(c - r)
        hi.append(c + r)
    for m, _, _ in geo.disks:
        extent = np.sqrt(m[:3, 0] ** 2 + m[:3, 1] ** 2)
        lo.append(m[:3, 3] - extent)
        hi.append(m[:3, 3] + extent)
    for curve in geo.curves:
        curve_lo, curve_hi = curve.bounds()
        lo.append(curve_lo)
        hi.append(curve_hi)
    for m, _, _ in geo.cylinders:
        corners = np.array([[x, y, z, 1.0] for x in (-1, 1) for y in (-1, 1) for z in (0, 1)])
        world = corners @ m.T
        lo.append(world[:, :3].min(0))
        hi.append(world[:, :3].max(0))
    if not lo:
        return np.zeros((2, 3))
    return np.array([np.min(lo, axis=0), np.max(hi, axis=0)])


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
                            "sampler": 10**9})
    media = MediaTable()
    shape_media = []
    for plugin in kids["sampler"]:   # top-level samplers: referenced by a sensor, or unused
        build_sampler(plugin)
    geo = _Geometry()
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
                from pathtracer import bsdfs
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
        if plugin.type not in SUPPORTED["shape"]:
            raise unsupported(plugin, "shape")
        shape_id = len(shape_bsdf)
        bsdf_plugin, emitter_plugin = build_shape(plugin, geo, shape_id, folders, parent)
        shape_media.append(media.shape_media(plugin))
        shape_bsdf.append(bsdf_id(bsdf_plugin, emitter=emitter_plugin is not None))
        if emitter_plugin is not None:
            _attach(emitter_plugin, plugin, attached)
            emitters.append(build_emitter(emitter_plugin, folders, shape_id))
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

    tri_p = np.concatenate(geo.tri_p) if geo.tri_p else np.zeros((0, 3, 3))
    tri_n = np.concatenate(geo.tri_n) if geo.tri_n else np.zeros((0, 3, 3))
    tri_uv = np.concatenate(geo.tri_uv) if geo.tri_uv else np.zeros((0, 3, 2))
    tri_shape = np.concatenate(geo.tri_shape) if geo.tri_shape else np.zeros(0, np.int32)
    sph = geo.spheres
    dsk = geo.disks
    return Scene(
        tri_p=tri_p, tri_n=tri_n, tri_shape=tri_shape, tri_uv=tri_uv,
        sphere_center=np.array([s[0] for s in sph]).reshape(-1, 3),
        sphere_radius=np.array([s[1] for s in sph], dtype=float),
        sphere_flip=np.array([s[2] for s in sph], dtype=bool),
        sphere_shape=np.array([s[3] for s in sph], dtype=np.int32),
        sphere_to_local=np.array([s[4] for s in sph]).reshape(-1, 3, 3),
        disk_to_world=np.array([d[0] for d in dsk]).reshape(-1, 4, 4),
        disk_to_local=np.array([np.linalg.inv(d[0]) for d in dsk]).reshape(-1, 4, 4),
        disk_flip=np.array([d[1] for d in dsk], dtype=bool),
        disk_shape=np.array([d[2] for d in dsk], dtype=np.int32),
        curves=geo.curves,
        cylinder_to_world=np.array([c[0] for c in geo.cylinders]).reshape(-1, 4, 4),
        cylinder_to_local=np.array([np.linalg.inv(c[0]) for c in geo.cylinders]).reshape(-1, 4, 4),
        cylinder_flip=np.array([c[1] for c in geo.cylinders], dtype=bool),
        cylinder_shape=np.array([c[2] for c in geo.cylinders], dtype=np.int32),
        shape_kind=geo.kind,
        shape_prim=np.array(geo.prim, dtype=np.int64).reshape(-1, 2),
        shape_bsdf=np.array(shape_bsdf, dtype=np.int32),
        shape_emitter=np.array(shape_emitter, dtype=np.int32),
        shape_area=np.array(geo.area, dtype=float),
        shape_tri_cdf=geo.cdf, shape_name=geo.name,
        bsdfs=bsdf_objects, emitters=emitters, environment=environment,
        camera=camera, spp=spp, seed=seed, integrator=integrator,
        source=source, bbox=_bbox(geo, tri_p), **_media_fields(media, shape_media, camera_medium))


SHAPE_MEDIUM_NAMES = ("interior", "exterior")


class MediaTable:
    """The scene's media, each built once per ``<medium>`` element (shared by ``<ref>``).

    A shape takes the media on its two sides as ``<medium name="interior">`` /
    ``name="exterior"`` (nested or ``<ref id=".." name=".."/>``); the sensor takes one
    medium, the one the camera sits in. A medium's factory is called as ``create(plugin)``.
    """

    def __init__(self):
        self.media: list[HomogeneousMedium] = []
        self._index: dict[int, int] = {}

    def index(self, plugin: Plugin) -> int:
        """Index of the medium of ``plugin`` in :attr:`media` (building it the first time)."""
        key = id(plugin)
        if key not in self._index:
            self.media.append(build_medium(plugin))
            self._index[key] = len(self.media) - 1
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


def build_medium(plugin: Plugin) -> HomogeneousMedium:
    """The participating medium of a ``<medium>`` element."""
    create = factory("medium", plugin.type)
    if create is None:
        raise unsupported(plugin, "medium")
    return create(plugin)


def _media_fields(media, shape_media: list, camera_medium: int) -> dict:
    """The :class:`Scene` fields of participating media (none: the defaults)."""
    if not media.media:
        return {}
    sides = np.array(shape_media, dtype=np.int32).reshape(-1, 2)
    return dict(media=media.media, shape_interior=sides[:, 0].copy(),
                shape_exterior=sides[:, 1].copy(), camera_medium=camera_medium)
