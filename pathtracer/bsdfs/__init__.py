"""BSDFs in the local shading frame (Mitsuba 3 conventions, vectorized over (n, 3) arrays).

See :mod:`pathtracer.bsdfs.base` for the conventions shared by every BSDF.
"""
from .base import BSDF, BSDFSample
from .blend import BlendBSDF
from .conductor import Conductor
from .dielectric import Dielectric
from .diffuse import Diffuse
from .fresnel import fresnel_conductor, fresnel_dielectric, fresnel_schlick, reflect, refract
from .mask import MaskBSDF
from .microfacet import MicrofacetDistribution
from .null import NullBSDF
from .perturbed import BumpMap, NormalMap
from .plastic import Plastic
from .roughconductor import RoughConductor
from .roughdielectric import RoughDielectric
from .roughplastic import RoughPlastic
from .thindielectric import ThinDielectric
from .twosided import TwoSided

__all__ = [
    "BSDF", "BSDFSample", "BlendBSDF", "BumpMap", "Conductor", "Dielectric", "Diffuse", "MaskBSDF",
    "MicrofacetDistribution", "NormalMap", "NullBSDF", "Plastic", "RoughConductor", "RoughDielectric",
    "RoughPlastic", "ThinDielectric", "TwoSided", "fresnel_conductor",
    "fresnel_dielectric", "fresnel_schlick", "reflect", "refract",
]
