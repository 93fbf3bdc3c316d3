"""Tests of the BSDFs: sampling vs density (chi-square), estimator identities, physics, and Mitsuba 3.

Chi-square tests run at the suite's per-test alpha (tests/budget.py).
The last section compares eval, pdf and sample with Mitsuba's own plugins
(scalar_rgb, float32 on their side) and is skipped when mitsuba is absent.
"""
from __future__ import annotations

import numpy as np
import pytest

from pathtracer.bsdfs import (
    Conductor,
    Dielectric,
    Diffuse,
    RoughConductor,
    TwoSided,
    fresnel_dielectric,
    fresnel_schlick,
    reflect,
    refract,
)
from pathtracer.bsdfs.diffuse import hemisphere_sampling
from pathtracer.bsdfs.fresnel import fresnel_conductor, schlick_f0
from pathtracer.core import sampling

pytestmark = pytest.mark.statistical(assertions=1)

try:
    from tests.chi2 import chi2_from_counts, chi2_sphere
except ImportError:  # tests/ is not a package: pytest puts it on sys.path
    from chi2 import chi2_from_counts, chi2_sphere


def direction(theta_deg: float, phi_deg: float = 30.0) -> np.ndarray:
    """Unit vector at polar angle theta and azimuth phi (degrees)."""
    t, p = np.radians(theta_deg), np.radians(phi_deg)
    return np.array([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)])


def tile(v: np.ndarray, n: int) -> np.ndarray:
    return np.tile(v, (n, 1))


def random_directions(n: int, seed: int, upper: bool | None = None) -> np.ndarray:
    v = sampling.square_to_uniform_sphere(np.random.default_rng(seed).random((n, 2)))
    if upper is True:
        v[:, 2] = np.abs(v[:, 2])
    elif upper is False:
        v[:, 2] = -np.abs(v[:, 2])
    return v


def sampler(bsdf, wi):
    """chi2 callback: (n, 3) uniforms -> (wo, valid) for a fixed wi."""
    def sample(u):
        bs = bsdf.sample(tile(wi, u.shape[0]), u[:, 0], u[:, 1:])
        return bs.wo, bs.valid
    return sample


def density(pdf, wi):
    return lambda wo: pdf(tile(wi, wo.shape[0]), wo)


# Incident directions: near-normal, oblique, steep and grazing (cos = 0.052).
WI_ANGLES = [5.0, 45.0, 70.0, 87.0]
ALPHAS = [0.05, 0.1, 0.3, 0.7]
DISTRIBUTIONS = ["beckmann", "ggx"]


# --------------------------------------------------------------------------
# Chi-square: sample() against pdf()
# --------------------------------------------------------------------------

@pytest.mark.parametrize("hemisphere", ["cosine", "uniform"])
@pytest.mark.parametrize("theta", [0.0, 60.0, 89.0])
def test_chi2_diffuse(hemisphere, theta):
    bsdf = Diffuse([0.2, 0.5, 0.8])
    wi = direction(theta)
    with hemisphere_sampling(hemisphere):
        result = chi2_sphere(sampler(bsdf, wi), density(bsdf.pdf, wi), seed=21)
    assert result.passed, result.message


def test_chi2_twosided_diffuse_back_side():
    bsdf = TwoSided(Diffuse(0.5))
    wi = -direction(40.0)
    result = chi2_sphere(sampler(bsdf, wi), density(bsdf.pdf, wi), seed=22)
    assert result.passed, result.message


def _chi2_rough(bsdf: RoughConductor, wi: np.ndarray, seed: int):
    """Chi-square of a rough conductor against the density its sampler really draws from.

    For Beckmann that is ``pdf_exact`` (exact Smith G1); ``pdf`` uses
    Mitsuba's rational approximation (see pathtracer/bsdfs/microfacet.py).
    Narrow lobes away from the horizon are binned around the mirror
    direction; otherwise around the normal, with the horizon on a cell edge
    (and fine rings just above it for grazing incidence, where the lobe is
    squeezed against the horizon).
    """
    narrow = min(bsdf.alpha_u, bsdf.alpha_v) <= 0.1
    subdiv = (48, 24)
    if narrow and wi[2] > 0.3:
        kwargs = dict(axis=reflect(wi[None])[0], z_power=3.0, res=(12, 24))
    elif wi[2] <= 0.3:
        # At grazing incidence a narrow lobe is also narrow in azimuth (~0.01 rad).
        edges = np.concatenate(([-1.0], np.linspace(0.0, 0.2, 21), [0.4, 0.7, 1.0]))
        kwargs = dict(axis=(0.0, 0.0, 1.0), z_edges=edges, res=(0, 36))
        subdiv = (48, 96) if narrow else (48, 24)
    else:
        kwargs = dict(axis=(0.0, 0.0, 1.0), res=(20, 36))
    return chi2_sphere(sampler(bsdf, wi), density(bsdf.pdf_exact, wi), n_samples=100_000,
                       subdiv=subdiv, seed=seed, **kwargs)


@pytest.mark.parametrize("distribution", DISTRIBUTIONS)
@pytest.mark.parametrize("alpha", ALPHAS)
@pytest.mark.parametrize("theta", [5.0, 45.0, 87.0])
def test_chi2_roughconductor(distribution, alpha, theta):
    bsdf = RoughConductor(distribution, alpha, alpha, [1.0, 0.8, 0.5])
    result = _chi2_rough(bsdf, direction(theta), seed=int(100 * alpha + theta))
    assert result.passed, result.message


@pytest.mark.parametrize("distribution", DISTRIBUTIONS)
@pytest.mark.parametrize("theta, phi", [(30.0, 20.0), (75.0, 110.0)])
def test_chi2_roughconductor_anisotropic(distribution, theta, phi):
    bsdf = RoughConductor(distribution, 0.05, 0.4, 1.0)
    result = _chi2_rough(bsdf, direction(theta, phi), seed=int(theta + phi))
    assert result.passed, result.message


def test_chi2_twosided_roughconductor_back_side():
    bsdf = TwoSided(RoughConductor("ggx", 0.3, 0.3, 1.0))
    wi = -direction(50.0)
    result = chi2_sphere(sampler(bsdf, wi), density(bsdf.pdf, wi), n_samples=100_000, seed=23)
    assert result.passed, result.message


def test_beckmann_pdf_is_mitsubas_approximation():
    """pdf() uses the rational G1 (within 0.35 % of pdf_exact); GGX pdf is exact."""
    wi, wo = random_directions(20_000, 1, True), random_directions(20_000, 2, True)
    beckmann = RoughConductor("beckmann", 0.3, 0.3, 1.0)
    p, p_exact = beckmann.pdf(wi, wo), beckmann.pdf_exact(wi, wo)
    ok = p_exact > 0
    assert np.max(np.abs(p[ok] / p_exact[ok] - 1.0)) < 0.0036
    assert np.max(np.abs(p[ok] / p_exact[ok] - 1.0)) > 1e-4  # it is not the exact function
    ggx = RoughConductor("ggx", 0.3, 0.3, 1.0)
    np.testing.assert_array_equal(ggx.pdf(wi, wo), ggx.pdf_exact(wi, wo))


def test_chi2_has_power_on_bsdfs():
    """Samples of alpha = 0.3 tested against the density of alpha = 0.33 must fail."""
    wi = direction(45.0)
    truth, wrong = RoughConductor("ggx", 0.3, 0.3, 1.0), RoughConductor("ggx", 0.33, 0.33, 1.0)
    result = chi2_sphere(sampler(truth, wi), density(wrong.pdf_exact, wi), n_samples=100_000, seed=24)
    assert not result.passed


# --------------------------------------------------------------------------
# Estimator identities
# --------------------------------------------------------------------------

SMOOTH_BSDFS = {
    "diffuse": Diffuse([0.2, 0.5, 0.8]),
    "twosided_diffuse": TwoSided(Diffuse([0.7, 0.1, 0.3])),
    "beckmann_0.1": RoughConductor("beckmann", 0.1, 0.1, [1.0, 0.8, 0.5]),
    "beckmann_0.7": RoughConductor("beckmann", 0.7, 0.7, 1.0),
    "ggx_0.05": RoughConductor("ggx", 0.05, 0.05, 1.0),
    "ggx_0.3": RoughConductor("ggx", 0.3, 0.3, [0.9, 0.6, 0.3]),
    "ggx_aniso": RoughConductor("ggx", 0.05, 0.4, 1.0),
    "beckmann_aniso": RoughConductor("beckmann", 0.4, 0.1, 1.0),
    "twosided_ggx": TwoSided(RoughConductor("ggx", 0.2, 0.2, 1.0)),
}


@pytest.mark.parametrize("name", sorted(SMOOTH_BSDFS))
def test_weight_is_eval_over_pdf(name):
    bsdf = SMOOTH_BSDFS[name]
    n = 20_000
    rng = np.random.default_rng(5)
    wi = random_directions(n, 6, upper=None if name.startswith("twosided") else True)
    bs = bsdf.sample(wi, rng.random(n), rng.random((n, 2)))
    assert bs.valid.mean() > 0.5
    assert not bs.delta.any() and np.all(bs.eta == 1.0)
    ok = bs.valid
    value, pdf = bsdf.eval(wi[ok], bs.wo[ok]), bsdf.pdf(wi[ok], bs.wo[ok])
    np.testing.assert_allclose(pdf, bs.pdf[ok], rtol=1e-7)
    np.testing.assert_allclose(value / pdf[:, None], bs.weight[ok], rtol=1e-7, atol=1e-12)
    assert np.all(bs.weight[~ok] == 0) and np.all(bs.pdf[~ok] == 0)


@pytest.mark.parametrize("name", sorted(SMOOTH_BSDFS))
def test_reciprocity(name):
    """f(wi, wo) = f(wo, wi), i.e. eval(wi, wo)/|cos o| = eval(wo, wi)/|cos i|."""
    bsdf = SMOOTH_BSDFS[name]
    upper = None if name.startswith("twosided") else True
    wi, wo = random_directions(5000, 7, upper), random_directions(5000, 8, upper)
    if upper is None:  # same side, else a two-sided BRDF is 0 both ways
        wo[:, 2] = np.abs(wo[:, 2]) * np.sign(wi[:, 2])
    f_io = bsdf.eval(wi, wo) / np.abs(wo[:, 2:3])
    f_oi = bsdf.eval(wo, wi) / np.abs(wi[:, 2:3])
    np.testing.assert_allclose(f_io, f_oi, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("name", sorted(SMOOTH_BSDFS))
def test_albedo_at_most_one(name):
    """Energy conservation: E[weight] = albedo <= 1 (per channel, MC with 4 sigma)."""
    bsdf = SMOOTH_BSDFS[name]
    n = 100_000
    rng = np.random.default_rng(9)
    for theta in WI_ANGLES:
        wi = tile(direction(theta), n)
        w = bsdf.sample(wi, rng.random(n), rng.random((n, 2))).weight
        mean, sd = w.mean(axis=0), w.std(axis=0) / np.sqrt(n)
        assert np.all(mean <= 1.0 + 4 * sd + 1e-12), (theta, mean)
        # Mitsuba's rational Beckmann G1 peaks at 1.00006 (a = 1.6): allow that much per sample.
        assert np.all(w <= 1.0 + 1e-4)


def test_diffuse_albedo_and_integral():
    bsdf = Diffuse([0.2, 0.5, 0.8])
    n = 100_000
    rng = np.random.default_rng(10)
    wi = tile(direction(30.0), n)
    bs = bsdf.sample(wi, rng.random(n), rng.random((n, 2)))
    np.testing.assert_array_equal(bs.weight, np.broadcast_to([0.2, 0.5, 0.8], (n, 3)))  # zero variance
    with hemisphere_sampling("uniform"):
        bs_u = bsdf.sample(wi, rng.random(n), rng.random((n, 2)))
    sd = bs_u.weight.std(axis=0) / np.sqrt(n)
    assert np.all(np.abs(bs_u.weight.mean(axis=0) - [0.2, 0.5, 0.8]) < 5 * sd)
    assert np.all(bs_u.weight.std(axis=0) > 0.1 * np.array([0.2, 0.5, 0.8]))
    # Both densities integrate to one over the sphere (quadrature in z, phi).
    for hemisphere in ("cosine", "uniform"):
        with hemisphere_sampling(hemisphere):
            assert abs(_integrate(density(bsdf.pdf, direction(30.0))) - 1.0) < 1e-4


def test_diffuse_one_sided():
    bsdf = Diffuse(0.5)
    wi, wo = direction(30.0)[None], direction(40.0)[None]
    flip = np.array([1.0, 1.0, -1.0])
    assert np.all(bsdf.eval(wi * flip, wo) == 0) and np.all(bsdf.eval(wi, wo * flip) == 0)
    assert bsdf.pdf(wi * flip, wo)[0] == 0
    bs = bsdf.sample(wi * flip, np.array([0.5]), np.array([[0.3, 0.6]]))
    assert not bs.valid[0] and np.all(bs.weight == 0)
    np.testing.assert_allclose(bsdf.eval(wi, wo)[0], 0.5 / np.pi * wo[0, 2])


def _integrate(pdf, res_z=2000, res_phi=720) -> float:
    """Midpoint quadrature of a density over the sphere (z = 0 is a node edge)."""
    z = -1.0 + (np.arange(res_z) + 0.5) * (2.0 / res_z)
    phi = (np.arange(res_phi) + 0.5) * (2.0 * np.pi / res_phi)
    zz, pp = np.meshgrid(z, phi, indexing="ij")
    r = np.sqrt(1.0 - zz ** 2)
    v = np.stack((r * np.cos(pp), r * np.sin(pp), zz), axis=-1).reshape(-1, 3)
    return float(pdf(v).sum() * (2.0 / res_z) * (2.0 * np.pi / res_phi))


@pytest.mark.parametrize("distribution", DISTRIBUTIONS)
@pytest.mark.parametrize("alpha, theta", [(0.1, 10.0), (0.3, 45.0), (0.7, 70.0), (0.3, 85.0)])
def test_roughconductor_pdf_integrates_to_valid_fraction(distribution, alpha, theta):
    """The density of the sampled lobe integrates to the probability of a valid sample."""
    bsdf = RoughConductor(distribution, alpha, alpha, 1.0)
    wi = direction(theta)
    integral = _integrate(lambda wo: bsdf.pdf_exact(tile(wi, wo.shape[0]), wo))
    n = 400_000
    rng = np.random.default_rng(11)
    valid = bsdf.sample(tile(wi, n), rng.random(n), rng.random((n, 2))).valid.mean()
    assert abs(integral - valid) < 5 * np.sqrt(valid * (1 - valid) / n) + 2e-3, (integral, valid)
    assert integral <= 1.0 + 1e-3
    if theta <= 10.0:  # near-normal incidence: almost nothing is rejected (GGX tails: ~1 %)
        assert abs(integral - 1.0) < (2e-3 if distribution == "beckmann" else 0.02)


def test_roughconductor_rejects_below_surface():
    bsdf = RoughConductor("ggx", 0.7, 0.7, 1.0)
    n = 50_000
    rng = np.random.default_rng(12)
    bs = bsdf.sample(tile(direction(85.0), n), rng.random(n), rng.random((n, 2)))
    assert 0.01 < np.mean(~bs.valid) < 0.9
    assert np.all(bs.wo[bs.valid, 2] > 0) and np.all(bs.weight[~bs.valid] == 0)
    bs = bsdf.sample(tile(-direction(30.0), 10), rng.random(10), rng.random((10, 2)))
    assert not bs.valid.any()
    assert np.all(bsdf.eval(tile(-direction(30.0), 3), tile(direction(20.0), 3)) == 0)


def test_roughconductor_normal_incidence_and_tiny_alpha():
    """Degenerate inputs give finite results (normal incidence, alpha clamped to 1e-4)."""
    for distribution in DISTRIBUTIONS:
        bsdf = RoughConductor(distribution, 0.0, 0.0, 1.0)
        assert bsdf.alpha_u == 1e-4
        n = 1000
        rng = np.random.default_rng(13)
        bs = bsdf.sample(tile(np.array([0.0, 0.0, 1.0]), n), rng.random(n), rng.random((n, 2)))
        assert np.all(np.isfinite(bs.wo)) and np.all(np.isfinite(bs.weight))
        assert bs.valid.mean() > 0.99
        # Beckmann slopes are Gaussian; GGX slopes are heavy-tailed (a few % of
        # samples tilt by more than 1e-6 in cos even at alpha = 1e-4).
        tilted = np.mean(1.0 - bs.wo[bs.valid, 2] > 1e-6)
        assert tilted == 0.0 if distribution == "beckmann" else tilted < 0.05


def test_beckmann_vndf_inversion_accuracy():
    """The Newton inversion of the visible-slope CDF is converged (CDF residual ~ 1e-13)."""
    from pathtracer.bsdfs.microfacet import _beckmann_slope_cdf, _beckmann_visible_slopes_11
    rng = np.random.default_rng(14)
    u = rng.random((20_000, 2))
    cos_theta = rng.random(20_000)
    sin_theta = np.sqrt(1 - cos_theta ** 2)
    x, _ = _beckmann_visible_slopes_11(cos_theta, u)
    cot = cos_theta / sin_theta
    total = _beckmann_slope_cdf(np.minimum(cot, 7.0), cos_theta, sin_theta)
    residual = _beckmann_slope_cdf(x, cos_theta, sin_theta) / total - u[:, 0]
    assert np.max(np.abs(residual)) < 1e-9
    assert np.all(x <= cot + 1e-12)


# --------------------------------------------------------------------------
# Smooth conductor and two-sided adapter
# --------------------------------------------------------------------------

def test_conductor_mirror():
    bsdf = Conductor([0.9, 0.5, 0.1])
    n = 1000
    rng = np.random.default_rng(15)
    wi = random_directions(n, 16)
    bs = bsdf.sample(wi, rng.random(n), rng.random((n, 2)))
    up = wi[:, 2] > 0
    np.testing.assert_array_equal(bs.valid, up)
    np.testing.assert_allclose(bs.wo[up], wi[up] * [-1, -1, 1])
    np.testing.assert_array_equal(bs.weight[up], np.broadcast_to([0.9, 0.5, 0.1], (up.sum(), 3)))
    assert np.all(bs.weight[~up] == 0) and bs.delta.all() and np.all(bs.eta == 1)
    assert np.all(bsdf.eval(wi, bs.wo) == 0) and np.all(bsdf.pdf(wi, bs.wo) == 0)
    assert bsdf.is_delta and not bsdf.has_smooth


def test_twosided_mirrors_back_side():
    nested = RoughConductor("beckmann", 0.3, 0.3, [1.0, 0.5, 0.2])
    bsdf = TwoSided(nested)
    wi, wo = random_directions(2000, 17, False), random_directions(2000, 18, False)
    flip = np.array([1.0, 1.0, -1.0])
    np.testing.assert_array_equal(bsdf.eval(wi, wo), nested.eval(wi * flip, wo * flip))
    np.testing.assert_array_equal(bsdf.pdf(wi, wo), nested.pdf(wi * flip, wo * flip))
    rng = np.random.default_rng(19)
    u1, u2 = rng.random(2000), rng.random((2000, 2))
    bs, bs_front = bsdf.sample(wi, u1, u2), nested.sample(wi * flip, u1, u2)
    np.testing.assert_array_equal(bs.wo, bs_front.wo * flip)
    np.testing.assert_array_equal(bs.weight, bs_front.weight)
    assert np.all(bs.wo[bs.valid, 2] < 0)
    # Front side: identical to the nested BSDF.
    np.testing.assert_array_equal(bsdf.eval(wi * flip, wo * flip), nested.eval(wi * flip, wo * flip))
    # Opposite sides: no transmission.
    assert np.all(bsdf.eval(wi, wo * flip) == 0)
    assert TwoSided(Conductor()).is_delta and TwoSided(Diffuse()).has_smooth


# --------------------------------------------------------------------------
# Fresnel and the smooth dielectric
# --------------------------------------------------------------------------

def _fresnel_by_energy_flux(cos_i: np.ndarray, eta: float) -> tuple[np.ndarray, np.ndarray]:
    """Independent reference: reflectance and transmittance from amplitude coefficients (from outside)."""
    sin_t = np.sqrt(1 - cos_i ** 2) / eta
    cos_t = np.sqrt(1 - sin_t ** 2)
    r_s = (cos_i - eta * cos_t) / (cos_i + eta * cos_t)
    r_p = (eta * cos_i - cos_t) / (eta * cos_i + cos_t)
    t_s = 2 * cos_i / (cos_i + eta * cos_t)
    t_p = 2 * cos_i / (eta * cos_i + cos_t)
    flux = eta * cos_t / cos_i
    return 0.5 * (r_s ** 2 + r_p ** 2), 0.5 * flux * (t_s ** 2 + t_p ** 2)


@pytest.mark.parametrize("eta", [1.5, 1.33, 2.4, 1.0 / 1.5])
def test_fresnel_energy_and_special_angles(eta):
    cos_i = np.linspace(1e-3, 1.0, 500)
    F, cos_t, eta_it, eta_ti = fresnel_dielectric(cos_i, eta)
    if eta > 1:
        R, T = _fresnel_by_energy_flux(cos_i, eta)
        np.testing.assert_allclose(F, R, rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(F + T, 1.0, rtol=1e-12)  # F + T = 1
        brewster = np.array([np.cos(np.arctan(eta))])
        F_b, ct_b, _, _ = fresnel_dielectric(brewster, eta)
        r_s = (brewster - eta * -ct_b) / (brewster + eta * -ct_b)
        np.testing.assert_allclose(F_b, 0.5 * r_s ** 2, rtol=1e-12)  # r_p = 0
    np.testing.assert_allclose(F[-1], ((eta - 1) / (eta + 1)) ** 2, rtol=1e-12)
    np.testing.assert_allclose(fresnel_schlick(np.array([1.0]), schlick_f0(eta)), F[-1:], rtol=1e-12)
    # Snell's law, sides and the returned ratios.
    np.testing.assert_allclose(eta_it, eta)
    np.testing.assert_allclose(eta_ti, 1 / eta)
    tir = 1 - (1 - cos_i ** 2) / eta ** 2 < 0
    np.testing.assert_allclose(np.sqrt(1 - cos_t[~tir] ** 2), np.sqrt(1 - cos_i[~tir] ** 2) / eta, atol=1e-12)
    assert np.all(cos_t <= 0)
    assert np.all(F[tir] == 1.0) and (tir.any() == (eta < 1))
    # Light from inside sees 1/eta: F(cos_i, eta) from inside equals F(-cos_i, 1/eta).
    F_in, cos_t_in, eta_it_in, _ = fresnel_dielectric(-cos_i, eta)
    np.testing.assert_allclose(F_in, fresnel_dielectric(cos_i, 1 / eta)[0], rtol=1e-12)
    np.testing.assert_allclose(eta_it_in, 1 / eta)
    assert np.all(cos_t_in >= 0)
    # Reciprocity of the Fresnel reflectance across the interface.
    ok = ~tir
    np.testing.assert_allclose(fresnel_dielectric(-cos_t[ok], 1 / eta)[0], F[ok], rtol=1e-9)


def test_fresnel_special_cases():
    F, cos_t, _, _ = fresnel_dielectric(np.array([0.0, 0.5, -0.5]), np.array([1.5, 1.0, 1.0]))
    np.testing.assert_array_equal(F, [1.0, 0.0, 0.0])
    np.testing.assert_allclose(cos_t, [-np.sqrt(1 - 1 / 1.5 ** 2), -0.5, 0.5])
    assert np.all(fresnel_conductor(np.linspace(0, 1, 11), 1j) == 1.0)  # material "none"


def test_schlick_is_an_approximation():
    cos_i = np.linspace(0.05, 1.0, 200)
    F = fresnel_dielectric(cos_i, 1.5)[0]
    S = fresnel_schlick(cos_i, schlick_f0(1.5))
    assert np.max(np.abs(S - F)) < 0.05 and np.max(np.abs(S - F)) > 1e-3


def test_reflect_refract_helpers():
    wi = random_directions(1000, 20, True)
    F, cos_t, eta_it, eta_ti = fresnel_dielectric(wi[:, 2], 1.5)
    wt = refract(wi, cos_t, eta_ti)
    np.testing.assert_allclose(np.linalg.norm(wt, axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(wt[:, :2], axis=1) * 1.5, np.linalg.norm(wi[:, :2], axis=1))
    # Refraction is reversible: refracting wt (seen from inside) leads back to wi.
    F2, cos_t2, _, eta_ti2 = fresnel_dielectric(wt[:, 2], 1.5)
    np.testing.assert_allclose(refract(wt, cos_t2, eta_ti2), wi, atol=1e-12)
    np.testing.assert_allclose(F2, F, rtol=1e-9)
    np.testing.assert_allclose(reflect(wi), wi * [-1, -1, 1])


@pytest.mark.parametrize("theta", [0.0, 30.0, 60.0, 85.0])
@pytest.mark.parametrize("side", ["outside", "inside"])
def test_dielectric_sample(theta, side):
    eta = 1.5
    bsdf = Dielectric(eta, 1.0, specular_reflectance=[1.0, 0.9, 0.8], specular_transmittance=[0.7, 0.8, 1.0])
    wi = direction(theta) * (1 if side == "outside" else np.array([1, 1, -1]))
    n = 100_000
    rng = np.random.default_rng(int(theta) + (side == "inside"))
    bs = bsdf.sample(tile(wi, n), rng.random(n), rng.random((n, 2)))
    F, cos_t, eta_it, eta_ti = (x[0] for x in fresnel_dielectric(np.array([wi[2]]), eta))
    reflected = bs.wo[:, 2] * wi[2] > 0
    assert bs.valid.all() and bs.delta.all()
    # Lobe chosen with probability F (binomial chi-square).
    result = chi2_from_counts([reflected.sum(), (~reflected).sum()], [F * n, (1 - F) * n])
    assert result.passed, result.message
    np.testing.assert_allclose(bs.pdf, np.where(reflected, F, 1 - F))
    np.testing.assert_allclose(bs.wo[reflected], tile(wi * [-1, -1, 1], reflected.sum()))
    np.testing.assert_array_equal(bs.eta, np.where(reflected, 1.0, eta_it))
    np.testing.assert_allclose(bs.weight[reflected], tile(np.array([1.0, 0.9, 0.8]), reflected.sum()))
    # Transmission: radiance scaled by eta_ti^2 = 1/eta^2 entering, eta^2 leaving.
    factor = 1 / eta ** 2 if side == "outside" else eta ** 2
    np.testing.assert_allclose(bs.weight[~reflected], tile(np.array([0.7, 0.8, 1.0]) * factor, (~reflected).sum()))
    if (~reflected).any():
        wt = bs.wo[~reflected][0]
        np.testing.assert_allclose(np.linalg.norm(wt[:2]), np.linalg.norm(wi[:2]) * eta_ti, atol=1e-12)
        assert wt[2] * wi[2] < 0
    # Energetics: the expected weight of a white interface is F + (1 - F) eta_ti^2.
    white = Dielectric(eta, 1.0).sample(tile(wi, n), rng.random(n), rng.random((n, 2))).weight[:, 0]
    sd = white.std() / np.sqrt(n) + 1e-12
    assert abs(white.mean() - (F + (1 - F) * eta_ti ** 2)) < 5 * sd


def test_dielectric_total_internal_reflection():
    eta = 1.5
    critical = np.degrees(np.arcsin(1 / eta))
    bsdf = Dielectric(eta, 1.0)
    wi = direction(critical + 1.0) * [1, 1, -1]
    n = 10_000
    rng = np.random.default_rng(21)
    bs = bsdf.sample(tile(wi, n), rng.random(n), rng.random((n, 2)))
    assert np.all(bs.wo[:, 2] < 0) and np.all(bs.pdf == 1.0) and np.all(bs.eta == 1.0)
    np.testing.assert_array_equal(bs.weight, np.ones((n, 3)))
    wi_ok = direction(critical - 1.0) * [1, 1, -1]
    bs = bsdf.sample(tile(wi_ok, n), rng.random(n), rng.random((n, 2)))
    assert np.any(bs.wo[:, 2] > 0)


def test_dielectric_defaults_and_flags():
    bsdf = Dielectric()
    np.testing.assert_allclose(bsdf.eta, 1.5046 / 1.000277)
    assert bsdf.is_delta and not bsdf.has_smooth
    wi, wo = random_directions(10, 22), random_directions(10, 23)
    assert np.all(bsdf.eval(wi, wo) == 0) and np.all(bsdf.pdf(wi, wo) == 0)


# --------------------------------------------------------------------------
# Comparison with Mitsuba 3's own plugins
# --------------------------------------------------------------------------

def _f32(x: np.ndarray) -> np.ndarray:
    """Round to float32 so that both renderers see exactly the same inputs."""
    return np.asarray(x, dtype=np.float32).astype(np.float64)


class _MitsubaBSDF:
    """Loop over Mitsuba's scalar BSDF calls with the identity shading frame."""

    def __init__(self, mi, spec: dict):
        self.mi = mi
        self.bsdf = mi.load_dict(spec)
        self.ctx = mi.BSDFContext()
        self.si = mi.SurfaceInteraction3f()
        self.si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))

    def eval_pdf(self, wi: np.ndarray, wo: np.ndarray):
        mi, values, pdfs = self.mi, [], []
        for a, b in zip(wi, wo):
            self.si.wi = mi.Vector3f(*a)
            v = self.bsdf.eval(self.ctx, self.si, mi.Vector3f(*b))
            values.append([v[0], v[1], v[2]])
            pdfs.append(self.bsdf.pdf(self.ctx, self.si, mi.Vector3f(*b)))
        return np.array(values), np.array(pdfs)

    def sample(self, wi: np.ndarray, u1: np.ndarray, u2: np.ndarray):
        mi, out = self.mi, {"wo": [], "weight": [], "pdf": [], "eta": []}
        for a, s1, s2 in zip(wi, u1, u2):
            self.si.wi = mi.Vector3f(*a)
            bs, w = self.bsdf.sample(self.ctx, self.si, float(s1), mi.Point2f(*s2))
            out["wo"].append([bs.wo[0], bs.wo[1], bs.wo[2]])
            out["weight"].append([w[0], w[1], w[2]])
            out["pdf"].append(bs.pdf)
            out["eta"].append(bs.eta)
        return {k: np.array(v) for k, v in out.items()}


def _assert_close(ours, theirs, rtol=1e-4, floor=1e-6, what=""):
    """Relative agreement with an absolute floor scaled to the data (float32 on Mitsuba's side)."""
    ours, theirs = np.asarray(ours), np.asarray(theirs)
    scale = max(float(np.max(np.abs(theirs))), 1e-30)
    err = np.abs(ours - theirs) / np.maximum(np.abs(theirs), floor * scale)
    worst = np.unravel_index(np.argmax(err), err.shape)
    assert err[worst] <= rtol, \
        f"{what}: rel. error {err[worst]:.3g} at {worst}: ours {ours[worst]}, mitsuba {theirs[worst]}"


def _pairs(n: int, seed: int, bsdf=None):
    """(wi, wo) pairs rounded to float32: random on the sphere, both above, and (if ``bsdf``
    is given) wo sampled from it, so that narrow lobes are hit."""
    wi = np.concatenate((random_directions(n, seed), random_directions(n, seed + 1, True)))
    wo = np.concatenate((random_directions(n, seed + 2), random_directions(n, seed + 3, True)))
    if bsdf is not None:
        rng = np.random.default_rng(seed + 4)
        wi_s = random_directions(n, seed + 5)
        wi = np.concatenate((wi, wi_s))
        wo = np.concatenate((wo, bsdf.sample(wi_s, rng.random(n), rng.random((n, 2))).wo))
    # A few grazing and normal directions.
    wi[:8] = [direction(t, p) for t, p in [(0, 0), (89.5, 10), (88, 200), (60, 90), (0.1, 0), (45, 45),
                                           (80, 300), (30, 0)]]
    return _f32(wi), _f32(wo)


ROUGH_CASES = [(d, a, a) for d in DISTRIBUTIONS for a in ALPHAS] + [
    ("beckmann", 0.05, 0.4), ("ggx", 0.05, 0.4), ("ggx", 0.6, 0.15), ("beckmann", 0.3, 0.08)]


def _rough_spec(distribution, alpha_u, alpha_v, colour, eta_k=None):
    spec = {"type": "roughconductor", "distribution": distribution,
            "specular_reflectance": {"type": "rgb", "value": list(colour)}}
    if alpha_u == alpha_v:
        spec["alpha"] = alpha_u
    else:
        spec["alpha_u"], spec["alpha_v"] = alpha_u, alpha_v
    if eta_k is not None:
        spec["eta"] = {"type": "rgb", "value": list(eta_k[0])}
        spec["k"] = {"type": "rgb", "value": list(eta_k[1])}
    return spec


@pytest.mark.mitsuba
@pytest.mark.parametrize("distribution, alpha_u, alpha_v", ROUGH_CASES)
def test_mitsuba_roughconductor_eval_pdf(distribution, alpha_u, alpha_v, mi):
    colour = [0.9, 0.6, 0.3]
    theirs = _MitsubaBSDF(mi, _rough_spec(distribution, alpha_u, alpha_v, colour))
    ours = RoughConductor(distribution, alpha_u, alpha_v, colour)
    wi, wo = _pairs(500, 30, ours)
    value, pdf = theirs.eval_pdf(wi, wo)
    assert np.count_nonzero(pdf) > 300
    _assert_close(ours.eval(wi, wo), value, what="eval")
    _assert_close(ours.pdf(wi, wo), pdf, what="pdf")


@pytest.mark.mitsuba
def test_mitsuba_roughconductor_complex_ior(mi):
    eta_k = ([0.2, 0.9, 1.1], [3.9, 2.4, 2.2])
    for distribution in DISTRIBUTIONS:
        theirs = _MitsubaBSDF(mi, _rough_spec(distribution, 0.2, 0.2, [1, 1, 1], eta_k))
        ours = RoughConductor(distribution, 0.2, 0.2, 1.0, eta=eta_k[0], k=eta_k[1])
        wi, wo = _pairs(300, 31, ours)
        value, _ = theirs.eval_pdf(wi, wo)
        _assert_close(ours.eval(wi, wo), value, what="eval with complex IOR")


@pytest.mark.mitsuba
@pytest.mark.parametrize("distribution, alpha_u, alpha_v", ROUGH_CASES)
def test_mitsuba_roughconductor_sample(distribution, alpha_u, alpha_v, mi):
    """Same uniforms -> the same microfacet normal: our VNDF samplers invert the same maps as Mitsuba's."""
    colour = [0.9, 0.6, 0.3]
    theirs = _MitsubaBSDF(mi, _rough_spec(distribution, alpha_u, alpha_v, colour))
    ours = RoughConductor(distribution, alpha_u, alpha_v, colour)
    n = 1500
    rng = np.random.default_rng(32)
    wi = _f32(np.concatenate((random_directions(n, 33, True), [direction(t, 40) for t in (0, 60, 85, 89)])))
    u1, u2 = _f32(rng.random(len(wi))), _f32(np.clip(rng.random((len(wi), 2)), 1e-6, 1 - 1e-6))
    ref = theirs.sample(wi, u1, u2)
    bs = ours.sample(wi, u1, u2)
    their_valid = np.any(ref["weight"] > 0, axis=1)
    # Validity may differ only where wo is within float32 noise of the horizon.
    differ = bs.valid != their_valid
    assert np.all(np.abs(ref["wo"][differ, 2]) < 1e-4), ref["wo"][differ]
    both = bs.valid & their_valid
    assert both.mean() > 0.5
    np.testing.assert_allclose(bs.wo[both], ref["wo"][both], atol=1e-4)
    _assert_close(bs.weight[both], ref["weight"][both], rtol=2e-3, what="sample weight")
    _assert_close(bs.pdf[both], ref["pdf"][both], rtol=2e-3, what="sample pdf")
    assert np.median(np.linalg.norm(bs.wo[both] - ref["wo"][both], axis=1)) < 1e-5


@pytest.mark.mitsuba
def test_mitsuba_diffuse_and_twosided(mi):
    colour = [0.2, 0.5, 0.8]
    wi, wo = _pairs(800, 40)
    diffuse = {"type": "diffuse", "reflectance": {"type": "rgb", "value": colour}}
    for spec, ours in [(diffuse, Diffuse(colour)),
                       ({"type": "twosided", "material": diffuse},
                        TwoSided(Diffuse(colour))),
                       ({"type": "twosided", "material": _rough_spec("ggx", 0.3, 0.3, colour)},
                        TwoSided(RoughConductor("ggx", 0.3, 0.3, colour))),
                       ({"type": "twosided", "material": _rough_spec("beckmann", 0.1, 0.1, colour)},
                        TwoSided(RoughConductor("beckmann", 0.1, 0.1, colour)))]:
        theirs = _MitsubaBSDF(mi, spec)
        value, pdf = theirs.eval_pdf(wi, wo)
        _assert_close(ours.eval(wi, wo), value, what=f"{spec['type']} eval")
        _assert_close(ours.pdf(wi, wo), pdf, what=f"{spec['type']} pdf")
        rng = np.random.default_rng(41)
        u1, u2 = _f32(rng.random(len(wi))), _f32(np.clip(rng.random((len(wi), 2)), 1e-6, 1 - 1e-6))
        ref, bs = theirs.sample(wi, u1, u2), ours.sample(wi, u1, u2)
        their_valid = np.any(ref["weight"] > 0, axis=1)
        differ = bs.valid != their_valid
        assert np.all(np.abs(ref["wo"][differ, 2]) < 1e-4)
        both = bs.valid & their_valid
        np.testing.assert_allclose(bs.wo[both], ref["wo"][both], atol=1e-4)
        _assert_close(bs.weight[both], ref["weight"][both], rtol=2e-3, what=f"{spec['type']} weight")
        _assert_close(bs.pdf[both], ref["pdf"][both], rtol=2e-3, what=f"{spec['type']} sample pdf")


@pytest.mark.mitsuba
@pytest.mark.parametrize("int_ior, ext_ior", [(1.5, 1.0), (1.5046, 1.000277), (1.33, 1.5), (2.4, 1.0)])
def test_mitsuba_dielectric_sample(int_ior, ext_ior, mi):
    refl, trans = [1.0, 0.9, 0.8], [0.7, 0.8, 1.0]
    theirs = _MitsubaBSDF(mi, {"type": "dielectric", "int_ior": int_ior, "ext_ior": ext_ior,
                               "specular_reflectance": {"type": "rgb", "value": refl},
                               "specular_transmittance": {"type": "rgb", "value": trans}})
    ours = Dielectric(int_ior, ext_ior, refl, trans)
    n = 1500
    rng = np.random.default_rng(50)
    wi = _f32(random_directions(n, 51))
    wi[:4] = _f32(np.array([direction(0), direction(0) * [1, 1, -1], direction(89.9), direction(70) * [1, 1, -1]]))
    u1, u2 = _f32(rng.random(n)), _f32(rng.random((n, 2)))
    ref, bs = theirs.sample(wi, u1, u2), ours.sample(wi, u1, u2)
    # Lobe choice: identical except where u1 is within float32 noise of F.
    F = fresnel_dielectric(wi[:, 2], int_ior / ext_ior)[0]
    same_lobe = np.sign(ref["wo"][:, 2]) == np.sign(bs.wo[:, 2])
    assert np.all(same_lobe | (np.abs(u1 - F) < 1e-5))
    s = same_lobe
    np.testing.assert_allclose(bs.wo[s], ref["wo"][s], atol=1e-5)
    _assert_close(bs.weight[s], ref["weight"][s], rtol=1e-5, what="dielectric weight")
    _assert_close(bs.pdf[s], ref["pdf"][s], rtol=1e-4, floor=1e-3, what="dielectric lobe probability")
    _assert_close(bs.eta[s], ref["eta"][s], rtol=1e-6, what="dielectric bs.eta")
    assert ours.eval(wi, bs.wo).sum() == 0 and ours.pdf(wi, bs.wo).sum() == 0
    value, pdf = theirs.eval_pdf(wi[:50], bs.wo[:50])
    assert np.all(value == 0) and np.all(pdf == 0)


@pytest.mark.mitsuba
def test_mitsuba_conductor_sample(mi):
    colour = [0.9, 0.5, 0.1]
    theirs = _MitsubaBSDF(mi, {"type": "conductor", "specular_reflectance": {"type": "rgb", "value": colour}})
    ours = Conductor(colour)
    n = 500
    rng = np.random.default_rng(60)
    wi = _f32(random_directions(n, 61))
    u1, u2 = _f32(rng.random(n)), _f32(rng.random((n, 2)))
    ref, bs = theirs.sample(wi, u1, u2), ours.sample(wi, u1, u2)
    np.testing.assert_array_equal(bs.valid, np.any(ref["weight"] > 0, axis=1))
    v = bs.valid
    np.testing.assert_allclose(bs.wo[v], ref["wo"][v], atol=1e-7)
    _assert_close(bs.weight, ref["weight"], rtol=1e-6, what="conductor weight")
    np.testing.assert_allclose(bs.pdf[v], ref["pdf"][v])


@pytest.mark.mitsuba
def test_mitsuba_fresnel_functions(mi):
    rng = np.random.default_rng(70)
    cos_i = _f32(np.concatenate((rng.uniform(-1, 1, 300), [0.0, 1.0, -1.0, 1e-3, -1e-3])))
    for eta in (1.5, 1.0 / 1.33, 1.000277, 2.4):
        eta = float(np.float32(eta))
        ours = fresnel_dielectric(cos_i, eta)
        theirs = np.array([mi.fresnel(float(c), eta) for c in cos_i])
        # Near eta = 1, F ~ (eta - 1)^2 suffers float32 cancellation on Mitsuba's side.
        rtol = 2e-5 if abs(eta - 1) > 0.01 else 3e-3
        for k, name in enumerate(("F", "cos_theta_t", "eta_it", "eta_ti")):
            np.testing.assert_allclose(ours[k], theirs[:, k], rtol=rtol, atol=2e-6, err_msg=name)
    cos_i = _f32(rng.uniform(0, 1, 200))
    for eta, k in [(0.2, 3.9), (1.1, 2.2), (0.0, 1.0), (2.5, 0.1)]:
        ours = fresnel_conductor(cos_i, complex(eta, k))
        theirs = np.array([mi.fresnel_conductor(float(c), mi.Complex2f(eta, k)) for c in cos_i])
        np.testing.assert_allclose(ours, theirs, rtol=2e-5, atol=1e-6)
