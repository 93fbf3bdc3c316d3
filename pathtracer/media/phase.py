r"""Phase functions: the angular distribution of light scattered inside a medium.

Mitsuba 3's conventions: ``wi`` points back along the incoming ray (``-d``),
``wo`` is the outgoing direction, both world-space unit vectors. A phase
function is normalised over the sphere, :math:`\int p(w_i, w_o)\,dw_o = 1`, and
is sampled exactly: the pdf of :meth:`sample` equals the value, so the sample
weight ``p / pdf`` is 1 (as the slides put it, "the phase pdf cancels").

Henyey-Greenstein with asymmetry :math:`g \in (-1, 1)` (forward scattering for
:math:`g > 0`), written with :math:`\mu = w_i \cdot w_o` as Mitsuba writes it:

.. math::

    p(\mu) = \frac{1}{4\pi} \frac{1 - g^2}{(1 + g^2 + 2 g \mu)^{3/2}}

so that :math:`\mu = -1` (no deflection) is the peak when :math:`g > 0`.
"""
from __future__ import annotations

import numpy as np

from ..core.sampling import INV_FOUR_PI, square_to_uniform_sphere
from ..core.vec import dot, to_world
from ..scene.properties import Props, children, registered
from ..scene.registry import register
from ..scene.xml import Plugin


class IsotropicPhase:
    """Every direction equally likely: :math:`p = 1 / 4\\pi` (Mitsuba's ``isotropic``)."""

    kind = "isotropic"

    def eval(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """Phase function value (= its sampling pdf) -> (n,)."""
        return np.full(len(wi), INV_FOUR_PI)

    def sample(self, wi: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Directions ``wo`` (n, 3) and their pdf (n,) from uniform ``u`` (n, 2)."""
        return square_to_uniform_sphere(u), np.full(len(wi), INV_FOUR_PI)


class HenyeyGreensteinPhase:
    """Henyey-Greenstein lobe with mean cosine ``g`` (Mitsuba's ``hg``)."""

    kind = "hg"

    def __init__(self, g: float):
        if not -1.0 < g < 1.0:
            raise ValueError(f"g must lie in (-1, 1), got {g}")
        self.g = float(g)

    def value(self, mu: np.ndarray) -> np.ndarray:
        """:math:`p(\\mu)` with :math:`\\mu = w_i \\cdot w_o`."""
        g = self.g
        denom = 1.0 + g * g + 2.0 * g * mu
        return INV_FOUR_PI * (1.0 - g * g) / (denom * np.sqrt(denom))

    def eval(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """Phase function value (= its sampling pdf) -> (n,)."""
        return self.value(dot(wi, wo))

    def sample(self, wi: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Invert the cdf of the deflection cosine, then a uniform azimuth about ``-wi``.

        Returns directions ``wo`` (n, 3) and their pdf (n,).
        """
        g = self.g
        if abs(g) < 1e-4:   # the inversion is 0/0 at g = 0: the isotropic limit
            cos_dev = 1.0 - 2.0 * u[:, 0]
        else:
            s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u[:, 0])
            cos_dev = (1.0 + g * g - s * s) / (2.0 * g)
        cos_dev = np.clip(cos_dev, -1.0, 1.0)
        sin_dev = np.sqrt(np.maximum(1.0 - cos_dev ** 2, 0.0))
        phi = 2.0 * np.pi * u[:, 1]
        # cos_dev is the cosine to the propagation direction -wi.
        local = np.stack((sin_dev * np.cos(phi), sin_dev * np.sin(phi), cos_dev), axis=1)
        wo = to_world(local, -wi)
        return wo, self.value(-cos_dev)


def build_phase(plugin: Plugin):
    """The phase function of a ``<phase>`` element (a medium's)."""
    create = registered(plugin, "phase function")
    return create(Props(plugin))


@register("phase", "isotropic")
def create_isotropic(props: Props) -> IsotropicPhase:
    """No parameters."""
    children(props.plugin, {})
    props.finish()
    return IsotropicPhase()


@register("phase", "hg")
def create_hg(props: Props) -> HenyeyGreensteinPhase:
    """``g`` (0.8), in (-1, 1)."""
    plugin = props.plugin
    children(plugin, {})
    g = props.float("g", 0.8)
    if not -1.0 < g < 1.0:
        raise plugin.error(f"g must lie in (-1, 1), got {g}", props.line("g"))
    props.finish()
    return HenyeyGreensteinPhase(g)
