r"""Common interface of the BSDFs: the sample record and the abstract base class.

Conventions (Mitsuba 3's)
-------------------------
* All directions are unit vectors in the local shading frame: :math:`z` is
  the shading normal, :math:`\cos\theta = z`.
* ``wi`` points from the surface toward where the light goes after the
  scattering event (toward the camera when tracing from the camera).
* ``wo`` is the sampled or evaluated direction toward the next vertex (the
  light). Evaluation returns :math:`f(w_i, w_o)\,|\cos\theta_o|`: **the
  cosine foreshortening factor is included**.
* For a direction sampled from a smooth lobe, ``weight`` is
  :math:`f\,|\cos\theta_o| / p`; for a Dirac lobe it is the factor that
  multiplies the path throughput (Fresnel terms, colour, :math:`\eta^2`
  radiance scaling, divided by the discrete lobe-selection probability).

Colour parameters (``reflectance``, ``specular_reflectance``, ...) are (3,)
arrays when constant, or :class:`~pathtracer.textures.Texture` objects; a
BSDF with a texture is :attr:`BSDF.textured` and is evaluated through
:meth:`BSDF.at`, which looks the textures up at the hits' ``uv``.
"""
from __future__ import annotations

import copy
from dataclasses import dataclass

import numpy as np

from ..core.vec import select
from ..textures.base import ConstantTexture, Texture


@dataclass
class BSDFSample:
    """Outcome of :meth:`BSDF.sample` for ``n`` shading points.

    Attributes
    ----------
    wo : (n, 3) ndarray
        Sampled direction, local frame.
    weight : (n, 3) ndarray
        Throughput multiplier: ``eval / pdf`` for smooth lobes, the Dirac
        weight for delta lobes; 0 where ``valid`` is False.
    pdf : (n,) ndarray
        Solid-angle density of ``wo`` for smooth lobes. For delta lobes,
        as in Mitsuba's ``BSDFSample3f.pdf``, the discrete probability of
        the chosen lobe (1 for a mirror, :math:`F` or :math:`1 - F` for a
        dielectric): use ``delta`` before using it for MIS. 0 where invalid.
    delta : (n,) bool
        The sampled lobe is a Dirac delta (no MIS / NEE against it).
    eta : (n,) ndarray
        Relative index of refraction of the crossing: 1 for reflection,
        :math:`\\eta_{it}` (:math:`\\eta` entering, :math:`1/\\eta` leaving)
        for transmission, as Mitsuba's ``bs.eta``.
    valid : (n,) bool
        False where no direction could be sampled (e.g. ``wi`` below a
        one-sided surface, or ``wo`` below the surface for a rough conductor).
    """

    wo: np.ndarray
    weight: np.ndarray
    pdf: np.ndarray
    delta: np.ndarray
    eta: np.ndarray
    valid: np.ndarray

    def __len__(self) -> int:
        return self.wo.shape[0]


def as_colour(value) -> np.ndarray:
    """An RGB colour as a (3,) float64 array (a scalar is repeated)."""
    colour = np.asarray(value, dtype=np.float64)
    return np.broadcast_to(colour, (3,)).copy()


def as_colour_or_texture(value):
    """A spatially varying :class:`~pathtracer.textures.Texture` as given, anything else
    (a constant texture included) as a (3,) colour: constants keep the fast path."""
    if isinstance(value, ConstantTexture):
        return value.value.copy()
    if isinstance(value, Texture):
        return value
    return as_colour(value)


def make_sample(wo: np.ndarray, weight: np.ndarray, pdf: np.ndarray, delta,
                eta, valid: np.ndarray) -> BSDFSample:
    """Assemble a :class:`BSDFSample`, zeroing weight and pdf where invalid.

    ``delta`` and ``eta`` may be scalars; they are broadcast to (n,).
    """
    n = wo.shape[0]
    valid = np.asarray(valid, dtype=bool)
    weight = select(valid, weight)
    pdf = np.where(valid, pdf, 0.0)
    wo = np.where(np.isfinite(wo), wo, 0.0)
    delta = np.broadcast_to(np.asarray(delta, dtype=bool), (n,)).copy()
    eta = np.broadcast_to(np.asarray(eta, dtype=np.float64), (n,)).copy()
    return BSDFSample(wo=wo, weight=weight, pdf=pdf, delta=delta, eta=eta, valid=valid)


class BSDF:
    """Abstract BSDF evaluated and sampled in the local shading frame.

    Attributes
    ----------
    has_smooth : bool
        Has a non-delta lobe: next-event estimation (and ``eval``/``pdf``)
        are meaningful.
    is_delta : bool
        Every lobe is a Dirac delta: ``eval`` and ``pdf`` are identically 0.
    """

    has_smooth: bool = False
    is_delta: bool = False
    #: Transmits into a medium of another index ``eta`` (its transmission carries the
    #: 1/eta'^2 radiance scaling, which importance transport drops: see
    #: :func:`pathtracer.bsdfs.shading.eval_bsdf`).
    refracts: bool = False
    #: Attributes that may hold a :class:`~pathtracer.textures.Texture`.
    texture_params: tuple = ()
    #: Attributes that may hold a texture read as one number per hit (Mitsuba's
    #: ``eval_1``: roughness, blend weight, opacity).
    scalar_texture_params: tuple = ()

    @property
    def textured(self) -> bool:
        """Some parameter varies over the surface: call :meth:`at` before evaluating."""
        return any(isinstance(getattr(self, name), Texture)
                   for name in self.texture_params + self.scalar_texture_params)

    #: Needs the hits' differential geometry in :meth:`at` (shading-normal perturbation).
    needs_geometry: bool = False
    #: Sees the azimuth of the tangent frame (anisotropic roughness): queried in Mitsuba's
    #: tangent frame (:mod:`pathtracer.bsdfs.tangent_frame`).
    anisotropic: bool = False

    def at(self, uv: np.ndarray, geometry=None) -> "BSDF":
        """The same BSDF for a batch of hits with texture coordinates ``uv`` (n, 2).

        A shallow copy whose textured parameters are replaced by their (n, 3)
        values at the hits (constant parameters stay (3,) arrays; both
        broadcast the same way in ``eval`` and ``sample``). Rows of the batch
        given to the copy must be those of ``uv``. ``geometry``
        (:class:`pathtracer.shapes.tangents.LocalGeometry` of the same rows) is given when
        :attr:`needs_geometry`; plain BSDFs ignore it.
        """
        bound = copy.copy(self)
        for name in self.texture_params:
            value = getattr(self, name)
            if isinstance(value, Texture):
                setattr(bound, name, value.eval(uv))
        for name in self.scalar_texture_params:
            value = getattr(self, name)
            if isinstance(value, Texture):
                setattr(bound, name, value.eval_1(uv))
        bound.bind_derived()
        return bound

    def bind_derived(self) -> None:
        """Recompute state derived from textured parameters once :meth:`at` has replaced
        them by their values at the hits (a microfacet distribution, a lobe weight)."""

    def eval(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        r"""BSDF times foreshortening, :math:`f(w_i, w_o)\,|\cos\theta_o|` -> (n, 3)."""
        raise NotImplementedError

    def pdf(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """Solid-angle density with which :meth:`sample` picks ``wo`` -> (n,) (0 for delta lobes)."""
        raise NotImplementedError

    def sample(self, wi: np.ndarray, u1: np.ndarray, u2: np.ndarray) -> BSDFSample:
        """Sample ``wo`` given ``wi``.

        Parameters
        ----------
        wi : (n, 3) ndarray
            Direction toward the previous vertex, local frame.
        u1 : (n,) ndarray
            Uniform sample for the choice of lobe.
        u2 : (n, 2) ndarray
            Uniform sample for the direction within the lobe.
        """
        raise NotImplementedError


class DeltaBSDF(BSDF):
    """A BSDF whose every lobe is a Dirac delta (mirror, smooth glass): ``eval`` and ``pdf``
    are 0 for any pair of directions, and only :meth:`sample` finds its directions."""

    has_smooth = False
    is_delta = True

    def eval(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """0 -> (n, 3): a delta lobe has no finite value."""
        return np.zeros((wi.shape[0], 3))

    def pdf(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """0 -> (n,): a delta lobe has no finite density."""
        return np.zeros(wi.shape[0])
