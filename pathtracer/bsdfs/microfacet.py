r"""Beckmann and GGX microfacet distributions, evaluated and sampled as in Mitsuba 3.

Notation: :math:`m` is a microfacet normal, :math:`\alpha_u, \alpha_v` the
roughness along the tangent and bitangent (local :math:`x` and :math:`y`).

Normal distributions (normalised so that :math:`\int D(m)\cos\theta_m\,dm = 1`)

.. math::
    D_{Beckmann}(m) = \frac{\exp\!\left(-\dfrac{(m_x/\alpha_u)^2 + (m_y/\alpha_v)^2}{m_z^2}\right)}
                           {\pi\,\alpha_u\alpha_v\,m_z^4},\qquad
    D_{GGX}(m) = \frac{1}{\pi\,\alpha_u\alpha_v\,
                   \left((m_x/\alpha_u)^2 + (m_y/\alpha_v)^2 + m_z^2\right)^2}.

Smith masking for one direction :math:`v`, with
:math:`a = 1/(\alpha_v(v)\tan\theta_v)` and :math:`\alpha_v(v)^2\tan^2\theta_v
= ((\alpha_u v_x)^2 + (\alpha_v v_y)^2)/v_z^2`:

.. math::
    G_1^{GGX} = \frac{2}{1 + \sqrt{1 + \alpha_v(v)^2\tan^2\theta_v}},\qquad
    G_1^{Beckmann} = \frac{2}{1 + \operatorname{erf}(a) + e^{-a^2}/(a\sqrt\pi)}.

**Mitsuba evaluates the Beckmann** :math:`G_1` **with a rational
approximation** (relative error < 0.35 %):

.. math:: G_1 \approx \frac{3.535a + 2.181a^2}{1 + 2.276a + 2.577a^2}
          \ (a < 1.6),\qquad 1\ (a \ge 1.6).

:meth:`MicrofacetDistribution.smith_g1` replicates it so that our values
(``eval``, ``pdf``, sample weights) equal Mitsuba's;
:meth:`MicrofacetDistribution.smith_g1_exact` is the exact function.

Visible-normal sampling draws :math:`m` from
:math:`D_{w_i}(m) = G_1(w_i, m)\,\max(0, w_i\cdot m)\,D(m)/\cos\theta_i`
with the **exact** :math:`G_1` (that is what the stretch-sample-unstretch
construction produces, for both distributions); Mitsuba nevertheless
reports the density with its approximate :math:`G_1`, and so do we: for
Beckmann the reported pdf is off by the approximation's error, exactly as
in Mitsuba, which makes our estimator statistically identical to theirs.
"""
from __future__ import annotations

import numpy as np

from ..core.sampling import square_to_uniform_disk_concentric
from ..core.vec import dot_einsum
from ..textures.base import Texture

SQRT_PI = np.sqrt(np.pi)
ALPHA_MIN = 1e-4


def _special():
    # Imported on first use: SciPy costs every process ~25 MB, and only Beckmann needs it.
    from scipy import special
    return special

# Bracket (in slope units) of the Beckmann visible-slope inversion: the
# slope density beyond |x| = 7 is below exp(-49) and never matters.
_SLOPE_BOUND = 7.0
_NEWTON_MAX_ITERATIONS = 60
_NEWTON_TOLERANCE = 1e-13


def _clamp_alpha(alpha):
    """A roughness clamped below at 1e-4: a float, or an array for per-row (textured) values."""
    if np.ndim(alpha) == 0:
        return max(float(alpha), ALPHA_MIN)
    return np.maximum(np.asarray(alpha, dtype=np.float64), ALPHA_MIN)


def textured_distribution(bsdf, distribution: str, alpha_u, alpha_v, sample_visible: bool):
    """The :class:`MicrofacetDistribution` of a rough BSDF, or None when a roughness is a
    texture (the BSDF then builds it per batch of hits in ``bind_derived``).

    Sets ``bsdf.distribution``, ``bsdf.alpha_u``, ``bsdf.alpha_v`` (clamped floats, or the
    textures) and ``bsdf.sample_visible``.
    """
    alpha_v = alpha_u if alpha_v is None else alpha_v
    if isinstance(alpha_u, Texture) or isinstance(alpha_v, Texture):
        distr = None
        check = MicrofacetDistribution(distribution, 0.1, 0.1, sample_visible)
        bsdf.alpha_u = alpha_u if isinstance(alpha_u, Texture) else _clamp_alpha(alpha_u)
        bsdf.alpha_v = alpha_v if isinstance(alpha_v, Texture) else _clamp_alpha(alpha_v)
    else:
        distr = check = MicrofacetDistribution(distribution, alpha_u, alpha_v, sample_visible)
        bsdf.alpha_u, bsdf.alpha_v = distr.alpha_u, distr.alpha_v
    bsdf.distribution, bsdf.sample_visible = check.distribution, check.sample_visible
    return distr


class RoughSurface:
    """What a rough BSDF built by :func:`textured_distribution` shares (a mixin before
    :class:`~pathtracer.bsdfs.base.BSDF`): its anisotropy and its per-batch distribution."""

    @property
    def anisotropic(self) -> bool:
        """Sees the azimuth of the tangent frame (alpha_u != alpha_v, or a textured roughness)."""
        return isinstance(self.alpha_u, Texture) or isinstance(self.alpha_v, Texture) \
            or self.alpha_u != self.alpha_v

    def bind_derived(self) -> None:
        """The distribution of the hits' roughness (when a texture gives it)."""
        if self.distr is None:
            self.distr = MicrofacetDistribution(self.distribution, self.alpha_u, self.alpha_v,
                                                self.sample_visible)


def _normalize(v: np.ndarray) -> np.ndarray:
    """Rows of ``v`` scaled to unit length."""
    return v / np.sqrt(dot_einsum(v, v))[:, None]


class MicrofacetDistribution:
    r"""Anisotropic Beckmann or GGX distribution of microfacet normals.

    Parameters
    ----------
    distribution : {"beckmann", "ggx"}
    alpha_u, alpha_v : float or (n,) ndarray
        Roughness along local x and y (clamped below at 1e-4 as in Mitsuba); one value
        per query row when a texture gives it.
    sample_visible : bool
        :meth:`sample` draws visible normals (default, Mitsuba's too) or normals
        distributed as :math:`D(m)\cos\theta_m` (:meth:`sample_all`).
    """

    def __init__(self, distribution: str, alpha_u: float, alpha_v: float | None = None,
                 sample_visible: bool = True):
        distribution = distribution.lower()
        if distribution not in ("beckmann", "ggx"):
            raise ValueError(f'invalid microfacet distribution "{distribution}": '
                             'must be "beckmann" or "ggx"')
        self.distribution = distribution
        self.alpha_u = _clamp_alpha(alpha_u)
        self.alpha_v = _clamp_alpha(alpha_u if alpha_v is None else alpha_v)
        self.sample_visible = bool(sample_visible)

    @property
    def is_beckmann(self) -> bool:
        return self.distribution == "beckmann"

    # ------------------------------------------------------------------
    # Distribution of normals and masking
    # ------------------------------------------------------------------

    def eval(self, m: np.ndarray) -> np.ndarray:
        r""":math:`D(m)` -> (n,); 0 where :math:`D\cos\theta_m \le 10^{-20}` (includes :math:`m_z \le 0`)."""
        cos_theta_2 = m[:, 2] ** 2
        ex = m[:, 0] / self.alpha_u
        ey = m[:, 1] / self.alpha_v
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            if self.is_beckmann:
                d = np.exp(-(ex * ex + ey * ey) / cos_theta_2) / (
                    np.pi * self.alpha_u * self.alpha_v * cos_theta_2 * cos_theta_2)
            else:
                t = ex * ex + ey * ey + cos_theta_2
                d = 1.0 / (np.pi * self.alpha_u * self.alpha_v * t * t)
            keep = d * m[:, 2] > 1e-20
        return np.where(keep, d, 0.0)

    def _tan_theta_alpha_2(self, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        r""":math:`(\alpha_u v_x)^2 + (\alpha_v v_y)^2` and that over :math:`v_z^2`."""
        xy_alpha_2 = (self.alpha_u * v[:, 0]) ** 2 + (self.alpha_v * v[:, 1]) ** 2
        with np.errstate(divide="ignore", invalid="ignore"):
            return xy_alpha_2, xy_alpha_2 / (v[:, 2] ** 2)

    def _g1_mask(self, v: np.ndarray, m: np.ndarray, g1: np.ndarray,
                 xy_alpha_2: np.ndarray) -> np.ndarray:
        """Normal incidence -> 1; back of the microfacet visible (v.m and v_z of opposite sign) -> 0."""
        g1 = np.where(xy_alpha_2 == 0.0, 1.0, g1)
        return np.where(dot_einsum(v, m) * v[:, 2] <= 0.0, 0.0, g1)

    def smith_g1(self, v: np.ndarray, m: np.ndarray) -> np.ndarray:
        r"""Mitsuba's Smith :math:`G_1(v, m)` -> (n,) (rational approximation for Beckmann)."""
        xy_alpha_2, tan_theta_alpha_2 = self._tan_theta_alpha_2(v)
        with np.errstate(divide="ignore", invalid="ignore"):
            if self.is_beckmann:
                a = 1.0 / np.sqrt(tan_theta_alpha_2)
                rational = (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a)
                g1 = np.where(a >= 1.6, 1.0, rational)
            else:
                g1 = 2.0 / (1.0 + np.sqrt(1.0 + tan_theta_alpha_2))
        return self._g1_mask(v, m, g1, xy_alpha_2)

    def smith_g1_exact(self, v: np.ndarray, m: np.ndarray) -> np.ndarray:
        r"""Exact Smith :math:`G_1(v, m) = 1/(1 + \Lambda(v))` -> (n,) (same as :meth:`smith_g1` for GGX)."""
        if not self.is_beckmann:
            return self.smith_g1(v, m)
        xy_alpha_2, tan_theta_alpha_2 = self._tan_theta_alpha_2(v)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            a = 1.0 / np.sqrt(tan_theta_alpha_2)
            g1 = 2.0 / (1.0 + _special().erf(a) + np.exp(-a * a) / (a * SQRT_PI))
        return self._g1_mask(v, m, g1, xy_alpha_2)

    def G(self, wi: np.ndarray, wo: np.ndarray, m: np.ndarray) -> np.ndarray:
        r"""Separable shadowing-masking :math:`G_1(w_i, m)\,G_1(w_o, m)`."""
        return self.smith_g1(wi, m) * self.smith_g1(wo, m)

    # ------------------------------------------------------------------
    # Visible-normal sampling
    # ------------------------------------------------------------------

    def pdf(self, wi: np.ndarray, m: np.ndarray) -> np.ndarray:
        r"""Density of :meth:`sample` as Mitsuba reports it.

        Visible normals: :math:`D(m)\,G_1(w_i, m)\,|w_i\cdot m| / \cos\theta_i`;
        otherwise :math:`D(m)\cos\theta_m`.
        """
        if not self.sample_visible:
            return self.eval(m) * m[:, 2]
        return self._pdf_visible(wi, m)

    def _pdf_visible(self, wi: np.ndarray, m: np.ndarray) -> np.ndarray:
        with np.errstate(divide="ignore", invalid="ignore"):
            return self.eval(m) * self.smith_g1(wi, m) * np.abs(dot_einsum(wi, m)) / wi[:, 2]

    def pdf_exact(self, wi: np.ndarray, m: np.ndarray) -> np.ndarray:
        r"""Density :meth:`sample` actually draws from (exact :math:`G_1`)."""
        if not self.sample_visible:
            return self.pdf(wi, m)
        with np.errstate(divide="ignore", invalid="ignore"):
            return self.eval(m) * self.smith_g1_exact(wi, m) * np.abs(dot_einsum(wi, m)) / wi[:, 2]

    def sample(self, wi: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """A microfacet normal and its density: :meth:`sample_visible_normal` or :meth:`sample_all`."""
        if self.sample_visible:
            return self.sample_visible_normal(wi, u)
        return self.sample_all(u)

    def sample_all(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        r"""Draw :math:`m` with density :math:`D(m)\cos\theta_m`, ignoring visibility (Walter et al. 2007).

        The azimuth is uniform when :math:`\alpha_u = \alpha_v`, otherwise
        :math:`\tan\phi = (\alpha_v/\alpha_u)\tan 2\pi u_y` (quadrant kept), with the
        effective roughness :math:`\alpha^2 = 1/(\cos^2\phi/\alpha_u^2 + \sin^2\phi/\alpha_v^2)`;
        the elevation inverts the radial CDF:
        :math:`\tan^2\theta_m = -\alpha^2\ln(1 - u_x)` (Beckmann),
        :math:`\alpha^2 u_x/(1 - u_x)` (GGX). Returns (m, pdf), pdf = :meth:`pdf`.
        """
        alpha_u = np.broadcast_to(self.alpha_u, u.shape[:1])
        alpha_v = np.broadcast_to(self.alpha_v, u.shape[:1])
        phi = 2.0 * np.pi * u[:, 1]
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            tan_phi = (alpha_v / alpha_u) * np.tan(phi)
            cos_aniso = np.copysign(1.0 / np.sqrt(tan_phi * tan_phi + 1.0), np.abs(u[:, 1] - 0.5) - 0.25)
            sin_aniso = cos_aniso * tan_phi
            isotropic = alpha_u == alpha_v
            cos_phi = np.where(isotropic, np.cos(phi), cos_aniso)
            sin_phi = np.where(isotropic, np.sin(phi), sin_aniso)
            alpha_2 = np.where(isotropic, alpha_u * alpha_u,
                               1.0 / ((cos_phi / alpha_u) ** 2 + (sin_phi / alpha_v) ** 2))
            if self.is_beckmann:
                tan_theta_2 = -alpha_2 * np.log1p(-u[:, 0])
            else:
                tan_theta_2 = alpha_2 * u[:, 0] / (1.0 - u[:, 0])
            cos_theta = 1.0 / np.sqrt(1.0 + tan_theta_2)
            sin_theta = np.sqrt(np.maximum(1.0 - cos_theta * cos_theta, 0.0))
        m = np.stack((cos_phi * sin_theta, sin_phi * sin_theta, cos_theta), axis=1)
        return m, self.pdf(m, m)

    def sample_visible_normal(self, wi: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        r"""Draw a visible normal for ``wi`` (:math:`\cos\theta_i > 0`) and its density.

        Stretch-sample-unstretch (Heitz and d'Eon 2014):

        1. stretch :math:`w_i` to the configuration of roughness 1:
           :math:`\tilde w_i = \mathrm{normalize}(\alpha_u w_{i,x}, \alpha_v w_{i,y}, w_{i,z})`;
        2. sample a slope :math:`(\tilde x, \tilde y)` of the visible
           roughness-1 distribution for the elevation of :math:`\tilde w_i`
           (:meth:`sample_visible_11`, :math:`\tilde w_i` in the xz-plane);
        3. rotate by the azimuth :math:`\phi_i` of :math:`\tilde w_i` and
           scale by :math:`(\alpha_u, \alpha_v)`;
        4. :math:`m = \mathrm{normalize}(-x, -y, 1)`.

        Parameters
        ----------
        wi : (n, 3) ndarray
        u : (n, 2) ndarray
            Uniform samples.

        Returns
        -------
        m : (n, 3) ndarray
            Microfacet normals (upper hemisphere).
        pdf : (n,) ndarray
            :meth:`pdf` of ``m`` (Mitsuba's convention, see the module docstring).
        """
        stretch = np.ones_like(wi)
        stretch[:, 0], stretch[:, 1] = self.alpha_u, self.alpha_v
        wi_p = _normalize(wi * stretch)
        sin_theta = np.hypot(wi_p[:, 0], wi_p[:, 1])
        on_axis = sin_theta <= 1e-12
        safe_sin = np.where(on_axis, 1.0, sin_theta)
        cos_phi = np.where(on_axis, 1.0, np.clip(wi_p[:, 0] / safe_sin, -1.0, 1.0))
        sin_phi = np.where(on_axis, 0.0, np.clip(wi_p[:, 1] / safe_sin, -1.0, 1.0))

        slope_x, slope_y = self.sample_visible_11(wi_p[:, 2], u)

        # Infinite slopes (a measure-zero corner of the square for GGX) give
        # non-finite normals, which callers treat as invalid samples.
        with np.errstate(invalid="ignore"):
            sx = (cos_phi * slope_x - sin_phi * slope_y) * self.alpha_u
            sy = (sin_phi * slope_x + cos_phi * slope_y) * self.alpha_v
            m = _normalize(np.stack((-sx, -sy, np.ones_like(sx)), axis=1))
            return m, self._pdf_visible(wi, m)

    def sample_visible_11(self, cos_theta_i: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        r"""Slopes of visible normals of the isotropic roughness-1 distribution.

        The incident direction is :math:`(\sin\theta_i, 0, \cos\theta_i)`; a
        facet of slope :math:`(\tilde x, \tilde y)` has normal
        :math:`\propto(-\tilde x, -\tilde y, 1)`, so it is visible with
        projected area :math:`\propto \cos\theta_i - \tilde x\sin\theta_i > 0`.
        """
        if self.is_beckmann:
            return _beckmann_visible_slopes_11(cos_theta_i, u)
        return _ggx_visible_slopes_11(cos_theta_i, u)


# ----------------------------------------------------------------------
# Roughness-1 visible slope samplers
# ----------------------------------------------------------------------

def reflection_half_vector(wi: np.ndarray, wo: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Half vector of a reflection pair and the mask of pairs with both directions above the
    surface (elsewhere the half vector is +z, a harmless placeholder) -> ((n, 3), (n,))."""
    active = (wi[:, 2] > 0.0) & (wo[:, 2] > 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        h = _normalize(wi + wo)
    active &= np.all(np.isfinite(h), axis=1)
    return np.where(active[:, None], h, np.array([0.0, 0.0, 1.0])), active


def _beckmann_slope_cdf(x: np.ndarray, cos_theta: np.ndarray, sin_theta: np.ndarray) -> np.ndarray:
    r"""Unnormalised CDF of the visible Beckmann slope :math:`\tilde x` (times :math:`\sin\theta`).

    With the slope density :math:`e^{-\tilde x^2 - \tilde y^2}/\pi` and the
    visibility weight :math:`\cos\theta - t\sin\theta` for :math:`t < \cot\theta`:

    .. math::
        K(x) = \int_{-\infty}^{x} e^{-t^2}(\cos\theta - t\sin\theta)\,dt
             = \cos\theta\,\tfrac{\sqrt\pi}{2}\,\operatorname{erfc}(-x) + \sin\theta\,\tfrac{e^{-x^2}}{2}.
    """
    return cos_theta * (0.5 * SQRT_PI) * _special().erfc(-x) + sin_theta * 0.5 * np.exp(-x * x)


def _beckmann_visible_slopes_11(cos_theta_i: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r"""Exact inversion sampling of the visible Beckmann slopes (roughness 1).

    :math:`\tilde x` solves :math:`K(\tilde x) = u_x K(\cot\theta_i)`
    (:func:`_beckmann_slope_cdf`, increasing on :math:`(-\infty, \cot\theta_i]`)
    by Newton's method safeguarded with bisection, run to convergence
    (:math:`10^{-13}`). The visibility weight does not depend on
    :math:`\tilde y`, so :math:`\tilde y` keeps its Gaussian marginal
    :math:`e^{-\tilde y^2}/\sqrt\pi`: :math:`\tilde y = \operatorname{erf}^{-1}(2u_y - 1)`.
    The root is found once per distinct :math:`(\cos\theta_i, u_x)`: quadrature
    grids (:mod:`.microfacet_albedo`) repeat each pair many times.
    """
    order = np.lexsort((u[:, 0], cos_theta_i))
    cos_sorted, u_sorted = cos_theta_i[order], u[order, 0]
    first = np.ones(order.size, dtype=bool)
    first[1:] = (np.diff(cos_sorted) != 0.0) | (np.diff(u_sorted) != 0.0)
    distinct = _beckmann_visible_slope_x_11(cos_sorted[first], u_sorted[first])
    slope_x = np.empty(order.size)
    slope_x[order] = distinct[np.cumsum(first) - 1]
    u_y = np.clip(u[:, 1], 1e-15, 1.0 - 1e-15)
    slope_y = _special().erfinv(2.0 * u_y - 1.0)
    return slope_x, slope_y


def _beckmann_visible_slope_x_11(cos_theta_i: np.ndarray, u_x: np.ndarray) -> np.ndarray:
    r"""The slope :math:`\tilde x` of :func:`_beckmann_visible_slopes_11` for each (cosine, uniform) pair."""
    cos_theta = np.clip(cos_theta_i, 0.0, 1.0)
    sin_theta = np.sqrt(np.maximum(1.0 - cos_theta * cos_theta, 0.0))
    with np.errstate(divide="ignore"):
        cot_theta = np.where(sin_theta > 0.0, cos_theta / np.where(sin_theta > 0.0, sin_theta, 1.0), np.inf)
    hi = np.minimum(cot_theta, _SLOPE_BOUND)
    lo = np.full_like(hi, -_SLOPE_BOUND)
    target = u_x * _beckmann_slope_cdf(hi, cos_theta, sin_theta)

    x0 = np.clip(_special().erfinv(np.clip(2.0 * u_x - 1.0, -1.0 + 1e-15, 1.0 - 1e-15)), lo, hi)
    return _solve_increasing(x0, lo, hi, target, cos_theta, sin_theta)


def _solve_increasing(x: np.ndarray, lo: np.ndarray, hi: np.ndarray, target: np.ndarray,
                      cos_theta: np.ndarray, sin_theta: np.ndarray) -> np.ndarray:
    r"""Root of :math:`K(x) = \text{target}` in :math:`[lo, hi]`: Newton steps, bisection when they leave the bracket.

    :math:`K'(x) = e^{-x^2}(\cos\theta - x\sin\theta) \ge 0` on the bracket.
    Only the unconverged entries are iterated.
    """
    x, lo, hi = x.copy(), lo.copy(), hi.copy()
    active = np.arange(x.shape[0])
    for _ in range(_NEWTON_MAX_ITERATIONS):
        if active.size == 0:
            break
        xa, la, ha, ca, sa = x[active], lo[active], hi[active], cos_theta[active], sin_theta[active]
        fx = _beckmann_slope_cdf(xa, ca, sa) - target[active]
        la = np.where(fx <= 0.0, xa, la)
        ha = np.where(fx > 0.0, xa, ha)
        derivative = np.exp(-xa * xa) * (ca - xa * sa)
        with np.errstate(divide="ignore", invalid="ignore"):
            x_new = xa - fx / derivative
        in_bracket = np.isfinite(x_new) & (x_new > la) & (x_new < ha)
        x_new = np.where(in_bracket, x_new, 0.5 * (la + ha))
        done = (np.abs(x_new - xa) <= _NEWTON_TOLERANCE * (1.0 + np.abs(xa))) | (ha - la <= _NEWTON_TOLERANCE)
        x[active], lo[active], hi[active] = x_new, la, ha
        active = active[~done]
    return x


def _ggx_visible_slopes_11(cos_theta_i: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r"""Exact GGX visible slopes (roughness 1) by Heitz's 2018 hemisphere construction.

    For roughness 1 the GGX microsurface is a hemisphere, so the visible
    normals are the points of that hemisphere seen from :math:`w_i`: a
    uniform point :math:`(t_1, t_2)` of the unit disk perpendicular to
    :math:`w_i` (concentric map), with the half :math:`t_2 < 0` squeezed by
    :math:`s = (1 + \cos\theta_i)/2` onto the part of the projected disk
    that the hemisphere covers,

    .. math:: t_2 \leftarrow (1 - s)\sqrt{1 - t_1^2} + s\,t_2,

    lifted to :math:`h = (t_1, t_2, \sqrt{1 - t_1^2 - t_2^2})` in the basis
    (:math:`T_1 = -y`, :math:`T_2 = (-\cos\theta_i, 0, \sin\theta_i)`,
    :math:`w_i`) and converted to the slope :math:`(-n_x/n_z, -n_y/n_z)` of
    the normal :math:`n` it represents.
    """
    p = square_to_uniform_disk_concentric(u)
    t1 = p[:, 0]
    s = 0.5 * (1.0 + cos_theta_i)
    t2 = (1.0 - s) * np.sqrt(np.maximum(1.0 - t1 * t1, 0.0)) + s * p[:, 1]
    h = np.sqrt(np.maximum(1.0 - t1 * t1 - t2 * t2, 0.0))

    sin_theta_i = np.sqrt(np.maximum(1.0 - cos_theta_i * cos_theta_i, 0.0))
    n_x = h * sin_theta_i - t2 * cos_theta_i
    n_y = -t1
    n_z = t2 * sin_theta_i + h * cos_theta_i
    with np.errstate(divide="ignore", invalid="ignore"):
        return -n_x / n_z, -n_y / n_z
