"""How a ``<bsdf>`` element becomes a :mod:`pathtracer.bsdfs` object (moved from the loader)."""
from __future__ import annotations

import numpy as np

from ..scene.properties import FLOAT_TAGS, Props, build_texture, children, unsupported
from ..scene.xml import Plugin

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
    from pathtracer.textures.bitmap import BitmapTexture

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
