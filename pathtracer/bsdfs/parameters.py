"""What the BSDF plugins share in parsing their properties, and the builder of a ``<bsdf>``.

Each BSDF module registers a factory beside its class (``@register("bsdf", name)``)
that reads its properties with these helpers; :func:`build_bsdf` looks the element's
type up in the registry, for the loader and for the BSDFs that nest others.
"""
from __future__ import annotations

import numpy as np

from ..core.names import suggestion
from ..scene.properties import FLOAT_TAGS, Props, build_texture, children, unsupported
from ..scene.registry import factory
from ..scene.xml import Plugin
from .conductor_presets import CONDUCTOR_PRESETS

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


def build_bsdf(plugin: Plugin, folders: list[str] = (".",), textures: dict | None = None):
    """Construct the :mod:`pathtracer.bsdfs` object for a ``<bsdf>`` element.

    The factory registered for its type is called with the element's :class:`Props`
    (whose ``folders`` and ``texture_cache`` are set) and returns the BSDF; the
    properties it left unread are then refused.

    Parameters
    ----------
    plugin : Plugin
    folders : list of str
        Where texture files are looked up (:func:`~pathtracer.scene.properties.search_folders`).
    textures : dict, optional
        Textures already built, by ``id`` of their plugin (textures shared by ``<ref>``
        read the image once).
    """
    textures = {} if textures is None else textures
    props = Props(plugin, folders=folders, texture_cache=textures)
    create = factory("bsdf", plugin.type)
    if create is None:
        textures_only(props)
        if plugin.type in VARIANT_ONLY_BSDFS:
            raise plugin.error(f"BSDF \"{plugin.type}\" {VARIANT_ONLY_BSDFS[plugin.type]}")
        raise unsupported(plugin, "BSDF")
    result = create(props)
    props.finish()
    return result


def textures_only(props: Props) -> None:
    """Refuse nested elements other than (named) textures: a BSDF that wraps no other."""
    children(props.plugin, {"texture": 10**9})


def colour_or_texture(props: Props, name: str, default: float):
    """A reflectance (a colour in [0, 1]) or a nested texture (see
    :meth:`~pathtracer.scene.properties.Props.reflectance_or_texture`)."""
    return props.reflectance_or_texture(name, default)


def ior(props: Props, name: str, default: str) -> float:
    """An index of refraction: a positive ``<float>``, or a ``<string>`` name of
    :data:`IOR_BY_NAME` (as is ``default``)."""
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


def conductor_ior(props: Props) -> tuple[np.ndarray, np.ndarray]:
    """Complex IOR ``(eta, k)`` of a conductor: Mitsuba's ``material`` preset or explicit values.

    As Mitsuba: ``material="none"`` (the default) is ``0 + 1i``, a perfect
    mirror; explicit ``eta`` / ``k`` default to 0 / 1 and cannot be combined
    with another material.
    """
    material = props.string("material", "none").strip()
    if material == "none" or props.has("eta"):
        if material != "none":
            raise props.plugin.error(f"give either eta/k or material=\"{material}\", not both",
                                     props.line("material"))
        return props.color("eta", 0.0, kind="unbounded"), props.color("k", 1.0, kind="unbounded")
    if material not in CONDUCTOR_PRESETS:
        raise props.plugin.error(f"unknown conductor material \"{material}\" ("
                                 f"{suggestion(material, CONDUCTOR_PRESETS)}known: none, "
                                 f"{', '.join(CONDUCTOR_PRESETS)})", props.line("material"))
    if props.has("k"):
        raise props.plugin.error(f"\"k\" without \"eta\" cannot be combined with material="
                                 f"\"{material}\" (give both eta and k, or only the material)",
                                 props.line("k"))
    eta, k = CONDUCTOR_PRESETS[material]
    return np.array(eta), np.array(k)


def microfacet_parameters(props: Props, anisotropic: bool = True) -> tuple[str, float, float, bool]:
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
    alpha = roughness(props, "alpha", 0.1, anisotropic)
    alpha_u = roughness(props, "alpha_u", alpha, anisotropic)
    alpha_v = roughness(props, "alpha_v", alpha, anisotropic)
    return distribution, alpha_u, alpha_v, sample_visible


def roughness(props: Props, name: str, default, textured: bool):
    """A roughness: a number (>= 0), or, where Mitsuba takes one (``roughconductor``,
    ``roughdielectric``), a nested texture read per hit with ``eval_1``."""
    if textured and name in props.textures:
        props.used.add(name)
        return build_texture(props.textures[name], props.folders, props.texture_cache)
    value = props.float(name, default)
    if props.has(name) and not value >= 0.0:
        raise props.plugin.error(f"\"{name}\" must be >= 0", props.line(name))
    return value


def distinct_iors(props: Props, default_int: str) -> tuple[float, float]:
    """``int_ior`` and ``ext_ior``, which the rough interfaces need to differ (Mitsuba's check)."""
    int_ior, ext_ior = ior(props, "int_ior", default_int), ior(props, "ext_ior", "air")
    if int_ior == ext_ior:
        raise props.plugin.error(f"{props.plugin.type} needs int_ior != ext_ior (both {int_ior:g})",
                                 props.line("int_ior") if props.has("int_ior") else None)
    return int_ior, ext_ior


def plastic_parameters(props: Props, int_ior: float, ext_ior: float) -> dict:
    """The arguments ``plastic`` and ``roughplastic`` share, given their IORs."""
    # A texture's mean (Texture.mean) sets the lobe-selection weight, as in Mitsuba.
    return dict(diffuse_reflectance=colour_or_texture(props, "diffuse_reflectance", 0.5),
                specular_reflectance=colour_or_texture(props, "specular_reflectance", 1.0),
                int_ior=int_ior, ext_ior=ext_ior, nonlinear=props.bool("nonlinear", False))


def nested_bsdfs(props: Props, least: int, most: int, textures: int = 0) -> list:
    """The built BSDFs nested in a composite (``least`` to ``most`` of them, beside at
    most ``textures`` nested textures)."""
    plugin = props.plugin
    nested = children(plugin, {"bsdf": most, "texture": textures})["bsdf"]
    if len(nested) < least:
        raise plugin.error(f"{plugin.type} needs {'exactly' if least == most else 'at least'} "
                           f"{least} nested <bsdf>, got {len(nested)}")
    return [build_bsdf(child, props.folders, props.texture_cache) for child in nested]


def scalar_or_texture(props: Props, name: str, default):
    """A number or a nested texture read per hit with ``eval_1`` (Mitsuba clips both to
    [0, 1] for a blend weight or an opacity); ``default`` None means required."""
    if name in props.textures:
        props.used.add(name)
        return build_texture(props.textures[name], props.folders, props.texture_cache)
    if default is None and not props.has(name):
        raise props.plugin.error(f"missing \"{name}\" (a <float> or a <texture>)")
    return props.float(name, default)
