"""BSDFs in the local shading frame (Mitsuba 3 conventions, vectorized over (n, 3) arrays).

See :mod:`pathtracer.bsdfs.base` for the conventions shared by every BSDF. Each plugin
module registers the factory that builds it from a ``<bsdf>`` element (see
:mod:`pathtracer.bsdfs.parameters`) when it is imported here.
"""
from .base import BSDF, BSDFSample
from .fresnel import fresnel_conductor, fresnel_dielectric, fresnel_schlick, reflect, refract
from .microfacet import MicrofacetDistribution

# isort: off
# The plugins in the order the loader's "supported" list names them (registration order).
from .diffuse import Diffuse
from .twosided import TwoSided
from .conductor import Conductor
from .roughconductor import RoughConductor
from .dielectric import Dielectric
from .thindielectric import ThinDielectric
from .roughdielectric import RoughDielectric
from .plastic import Plastic
from .roughplastic import RoughPlastic
from .principled import Principled
from .principledthin import PrincipledThin
from .null import NullBSDF
from .blend import BlendBSDF
from .mask import MaskBSDF
from .perturbed import BumpMap, NormalMap
# isort: on

__all__ = [
    "BSDF", "BSDFSample", "BlendBSDF", "BumpMap", "Conductor", "Dielectric", "Diffuse", "MaskBSDF",
    "MicrofacetDistribution", "NormalMap", "NullBSDF", "Plastic", "Principled", "PrincipledThin",
    "RoughConductor", "RoughDielectric",
    "RoughPlastic", "ThinDielectric", "TwoSided", "fresnel_conductor",
    "fresnel_dielectric", "fresnel_schlick", "reflect", "refract",
]
