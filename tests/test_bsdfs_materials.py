"""Tests of the BSDFs users' Mitsuba scenes need: plastic, roughplastic, roughdielectric,
thindielectric and the conductors' named materials / explicit complex IOR.

As tests/test_bsdfs.py: chi-square of sample() against the density it draws from (at
the suite's per-test alpha), estimator identities and physics without Mitsuba, then
eval / pdf / sample against Mitsuba 3's own plugins (scalar_rgb, marked ``mitsuba``).
"""
from __future__ import annotations

import numpy as np
import pytest

from mitsuba_refs.report.wording import verdict_line
from pathtracer.bsdfs import (
    Conductor,
    Plastic,
    RoughConductor,
    RoughDielectric,
    RoughPlastic,
    ThinDielectric,
    fresnel_dielectric,
)
from pathtracer.bsdfs.conductor_presets import CONDUCTOR_PRESETS
from pathtracer.bsdfs.fresnel import fresnel_diffuse_reflectance
from pathtracer.bsdfs.microfacet_albedo import interpolate, table_cosines
from tests.chi2 import chi2_sphere
from tests.test_bsdfs import _assert_close, _f32, _MitsubaBSDF, _pairs, density, direction, random_directions, tile

statistical = pytest.mark.statistical(assertions=1)
COLOUR = [0.2, 0.5, 0.8]


def smooth_only_sampler(bsdf, wi):
    """chi2 callback: delta-lobe samples count as 'no smooth sample' (the null cell, mass P_s)."""
    def sample(u):
        bs = bsdf.sample(tile(wi, u.shape[0]), u[:, 0], u[:, 1:])
        return bs.wo, bs.valid & ~bs.delta
    return sample


def exact_sampler(bsdf, wi):
    def sample(u):
        bs = bsdf.sample(tile(wi, u.shape[0]), u[:, 0], u[:, 1:])
        return bs.wo, bs.valid
    return sample


# --------------------------------------------------------------------------
# Chi-square: sample() against the density it draws from
# --------------------------------------------------------------------------

@statistical
@pytest.mark.parametrize("theta", [10.0, 60.0, 85.0])
def test_chi2_plastic(theta):
    """Diffuse samples follow (1 - P_s) cos/pi; the specular share P_s lands in the null cell."""
    bsdf = Plastic(COLOUR, 1.0, 1.5, 1.0)
    wi = direction(theta)
    result = chi2_sphere(smooth_only_sampler(bsdf, wi), density(bsdf.pdf, wi), n_samples=100_000,
                         seed=int(theta) + 300)
    assert result.passed, result.message


ROUGH_PLASTIC_CASES = [("ggx", 0.1, 30.0), ("ggx", 0.4, 75.0), ("beckmann", 0.2, 50.0)]


@statistical
@pytest.mark.parametrize("distribution, alpha, theta", ROUGH_PLASTIC_CASES)
def test_chi2_roughplastic(distribution, alpha, theta):
    bsdf = RoughPlastic(distribution, alpha, COLOUR, 1.0, 1.5, 1.0)
    wi = direction(theta)
    result = chi2_sphere(exact_sampler(bsdf, wi), density(bsdf.pdf_exact, wi), n_samples=100_000,
                         res=(20, 36), subdiv=(48, 24), seed=int(theta) + 310)
    assert result.passed, result.message


ROUGH_DIELECTRIC_CASES = [
    ("ggx", 0.3, 0.3, 1.5, 40.0),       # from outside
    ("beckmann", 0.5, 0.5, 1.5, 70.0),
    ("ggx", 0.3, 0.3, 1.5, 150.0),      # from inside: total internal reflection above 41.8 deg
    ("beckmann", 0.25, 0.25, 1.33, 120.0),
    ("ggx", 0.15, 0.5, 1.5, 30.0),      # anisotropic
]


@statistical
@pytest.mark.parametrize("distribution, alpha_u, alpha_v, eta, theta", ROUGH_DIELECTRIC_CASES)
def test_chi2_roughdielectric(distribution, alpha_u, alpha_v, eta, theta):
    """Reflection and transmission over the whole sphere, z = 0 on a cell edge."""
    bsdf = RoughDielectric(distribution, alpha_u, alpha_v, eta, 1.0)
    wi = direction(theta, 20.0)
    result = chi2_sphere(exact_sampler(bsdf, wi), density(bsdf.pdf_exact, wi), n_samples=100_000,
                         res=(24, 36), subdiv=(48, 24), seed=int(theta) + 320)
    assert result.passed, result.message


@statistical
@pytest.mark.parametrize("bsdf, theta", [
    (RoughConductor("beckmann", 0.3, 0.3, 1.0, sample_visible=False), 40.0),
    (RoughConductor("ggx", 0.1, 0.4, 1.0, sample_visible=False), 70.0),
    (RoughPlastic("ggx", 0.3, COLOUR, sample_visible=False), 60.0)], ids=["rc-beckmann", "rc-ggx-aniso", "rp-ggx"])
def test_chi2_without_visible_normals(bsdf, theta):
    """sample_visible=false draws D(m) cos(m): sample() against pdf() (no G1 approximation involved)."""
    wi = direction(theta)
    result = chi2_sphere(exact_sampler(bsdf, wi), density(bsdf.pdf, wi), n_samples=100_000,
                         res=(20, 36), subdiv=(48, 24), seed=int(theta) + 325)
    assert result.passed, result.message


@statistical
def test_chi2_has_power_on_roughdielectric():
    """Samples for eta = 1.5 tested against the density for eta = 1.6 must fail."""
    wi = direction(40.0)
    truth, wrong = RoughDielectric("ggx", 0.3, 0.3, 1.5, 1.0), RoughDielectric("ggx", 0.3, 0.3, 1.6, 1.0)
    result = chi2_sphere(exact_sampler(truth, wi), density(wrong.pdf_exact, wi), n_samples=100_000,
                         res=(24, 36), subdiv=(48, 24), seed=331)
    assert not result.passed


# --------------------------------------------------------------------------
# Estimator identities and physics
# --------------------------------------------------------------------------

SMOOTH = {
    "plastic": lambda: Plastic(COLOUR, [1.0, 0.9, 0.8], 1.5, 1.0),
    "plastic_nonlinear": lambda: Plastic(COLOUR, 1.0, 1.49, 1.0, nonlinear=True),
    "roughplastic_ggx": lambda: RoughPlastic("ggx", 0.2, COLOUR, 1.0, 1.5, 1.0),
    "roughplastic_beckmann": lambda: RoughPlastic("beckmann", 0.2, COLOUR, 1.0, 1.5, 1.0, nonlinear=True),
    "roughdielectric_ggx": lambda: RoughDielectric("ggx", 0.3, 0.3, 1.5, 1.0),
    "roughdielectric_beckmann": lambda: RoughDielectric("beckmann", 0.1, 0.4, 1.33, 1.0),
    "roughconductor_all_normals": lambda: RoughConductor("beckmann", 0.2, 0.5, COLOUR, sample_visible=False),
    "roughplastic_all_normals": lambda: RoughPlastic("ggx", 0.2, COLOUR, sample_visible=False),
}


@pytest.mark.parametrize("name", sorted(SMOOTH))
def test_weight_is_eval_over_pdf(name):
    """For every smooth sample: pdf() and eval()/pdf() reproduce what sample() returned."""
    bsdf = SMOOTH[name]()
    n = 20_000
    rng = np.random.default_rng(340)
    two_sided = name.startswith("roughdielectric")
    wi = random_directions(n, 341, upper=None if two_sided else True)
    bs = bsdf.sample(wi, rng.random(n), rng.random((n, 2)))
    smooth = bs.valid & ~bs.delta
    assert smooth.mean() > 0.5
    value, pdf = bsdf.eval(wi[smooth], bs.wo[smooth]), bsdf.pdf(wi[smooth], bs.wo[smooth])
    np.testing.assert_allclose(pdf, bs.pdf[smooth], rtol=1e-7)
    np.testing.assert_allclose(value / pdf[:, None], bs.weight[smooth], rtol=1e-6, atol=1e-12)
    assert np.all(bs.weight[~bs.valid] == 0) and np.all(bs.pdf[~bs.valid] == 0)


@pytest.mark.parametrize("name", ["plastic", "roughplastic_ggx", "roughdielectric_ggx",
                                  "roughdielectric_beckmann"])
def test_reciprocity(name):
    r"""Reflection: f(wi, wo) = f(wo, wi). Transmission: the physical BTDF obeys
    f(wi, wo) / eta_o^2 = f(wo, wi) / eta_i^2 (Veach 1997, 5.2); Mitsuba's radiance-mode
    value is that times (eta_i / eta_o)^2, so f(wi, wo) / eta_i^2 is symmetric."""
    bsdf = SMOOTH[name]()
    two_sided = name.startswith("roughdielectric")
    wi = random_directions(4000, 342, None if two_sided else True)
    wo = random_directions(4000, 343, None if two_sided else True)
    f_io = bsdf.eval(wi, wo) / np.abs(wo[:, 2:3])
    f_oi = bsdf.eval(wo, wi) / np.abs(wi[:, 2:3])
    if two_sided:
        def index(v):   # index of refraction of the medium each direction points into
            return np.where(v[:, 2] > 0, 1.0, bsdf.eta)[:, None]

        f_io, f_oi = f_io / index(wi) ** 2, f_oi / index(wo) ** 2
    assert np.count_nonzero(f_io) > 1000
    np.testing.assert_allclose(f_io, f_oi, rtol=1e-8, atol=1e-12)


@pytest.mark.parametrize("name", sorted(SMOOTH))
def test_albedo_at_most_one(name):
    """Energy: the mean flux fraction (weight without the eta^2 radiance scaling) is at most 1."""
    bsdf = SMOOTH[name]()
    n = 50_000
    rng = np.random.default_rng(344)
    angles = [5.0, 45.0, 80.0] + ([120.0, 170.0] if name.startswith("roughdielectric") else [])
    for theta in angles:
        bs = bsdf.sample(tile(direction(theta), n), rng.random(n), rng.random((n, 2)))
        flux = bs.weight * (bs.eta ** 2)[:, None]
        mean, sd = flux.mean(axis=0), flux.std(axis=0) / np.sqrt(n)
        assert np.all(mean <= 1.0 + 4 * sd + 1e-12), (theta, mean)
        if name.startswith("roughdielectric"):   # the flux weight is G1(wo, m) <= 1 per sample
            assert np.all(flux <= 1.0 + 1e-4), theta


def test_roughdielectric_conserves_energy_where_g1_is_exact():
    """A GGX interface loses only what masking removes: reflection + transmission ~ 1 at low roughness."""
    bsdf = RoughDielectric("ggx", 0.01, 0.01, 1.5, 1.0)
    n = 20_000
    rng = np.random.default_rng(345)
    for theta in (20.0, 160.0):
        bs = bsdf.sample(tile(direction(theta), n), rng.random(n), rng.random((n, 2)))
        flux = (bs.weight * (bs.eta ** 2)[:, None]).mean(axis=0)
        np.testing.assert_allclose(flux, 1.0, atol=2e-3)


def test_plastic_diffuse_lobe_matches_the_internal_scattering_model():
    r"""Integrated over wo, the diffuse lobe of a white base gives
    (1 - F_i) (1 - F_dr(eta)) / (eta^2 (1 - F_dr(1/eta))), which is 1 - F_i up to the fits' error."""
    bsdf = Plastic(1.0, 1.0, 1.5, 1.0)
    wi = direction(30.0)
    F_i = fresnel_dielectric(np.array([wi[2]]), 1.5)[0][0]
    n = 400_000
    wo = random_directions(n, 346, True)
    estimate = bsdf.eval(tile(wi, n), wo)[:, 0].mean() * 2.0 * np.pi
    expected = ((1 - F_i) * (1 - fresnel_diffuse_reflectance(1.5))
                / (1.5 ** 2 * (1 - fresnel_diffuse_reflectance(1 / 1.5))))
    assert abs(estimate - expected) < 5e-3
    assert abs(expected - (1 - F_i)) < 0.01 * (1 - F_i)


def test_fresnel_diffuse_reflectance_is_the_cosine_weighted_average():
    """The fits are within 0.6 % of 2 int F(mu) mu dmu for eta in [1/2, 2]."""
    mu = (np.arange(20000) + 0.5) / 20000
    for eta in (1.33, 1.5, 2.0, 1 / 1.33, 1 / 1.5, 0.5):
        exact = 2.0 * np.mean(fresnel_dielectric(mu, eta)[0] * mu)
        assert abs(fresnel_diffuse_reflectance(eta) / exact - 1.0) < 6e-3, eta


def test_roughplastic_tables_are_physical_and_approach_the_smooth_limit():
    bsdf = RoughPlastic("ggx", 0.01, 0.5, 1.0, 1.5, 1.0)
    T = bsdf.transmittance
    assert np.all((T >= 0) & (T <= 1)) and np.all(np.diff(T[1:]) > -1e-3)
    smooth_T = 1.0 - fresnel_dielectric(table_cosines(), 1.5)[0]
    np.testing.assert_allclose(T[8:], smooth_T[8:], atol=5e-3)          # away from grazing
    assert abs(bsdf.internal_reflectance - fresnel_diffuse_reflectance(1 / 1.5)) < 0.02
    np.testing.assert_allclose(interpolate(T, table_cosines()[1:]), T[1:], atol=1e-12)


def test_thindielectric_sums_the_internal_reflections():
    bsdf = ThinDielectric(1.5, 1.0, [1.0, 0.9, 0.8], [0.7, 0.8, 1.0])
    cos = np.array([1.0, 0.7, 0.2, 0.01, -0.5])
    R = fresnel_dielectric(np.abs(cos), 1.5)[0]
    series = R + (1 - R) ** 2 * sum(R ** (2 * j + 1) for j in range(200))
    np.testing.assert_allclose(bsdf.reflectance(cos), series, rtol=1e-10)
    wi = np.array([direction(30.0), -direction(60.0)])
    reflected = bsdf.sample(wi, np.array([0.0, 0.0]), np.zeros((2, 2)))
    passed = bsdf.sample(wi, np.array([1.0, 1.0]), np.zeros((2, 2)))
    np.testing.assert_allclose(reflected.wo, wi * [-1, -1, 1])
    np.testing.assert_allclose(passed.wo, -wi)
    np.testing.assert_allclose(reflected.weight, [[1.0, 0.9, 0.8]] * 2)
    np.testing.assert_allclose(passed.weight, [[0.7, 0.8, 1.0]] * 2)
    assert np.all(passed.delta) and np.all(passed.eta == 1)


def test_conductor_presets_table():
    """Every Mitsuba material, with plausible metal indices (gold reflects red most)."""
    assert {"Au", "Ag", "Al", "Cu", "Cr", "W", "a-C"} <= set(CONDUCTOR_PRESETS)
    eta, k = map(np.array, CONDUCTOR_PRESETS["Au"])
    gold = Conductor(1.0, eta, k).sample(direction(0.0)[None], np.zeros(1), np.zeros((1, 2))).weight[0]
    assert gold[0] > gold[1] > gold[2] and 0.9 < gold[0] < 1.0
    assert all(len(e) == 3 and len(kk) == 3 for e, kk in CONDUCTOR_PRESETS.values())


# --------------------------------------------------------------------------
# Comparison with Mitsuba 3's own plugins
# --------------------------------------------------------------------------

def _compare_eval_pdf(mi, spec, ours, n=250, seed=350, rtol=1e-3):
    theirs = _MitsubaBSDF(mi, spec)
    wi, wo = _pairs(n, seed, ours)
    value, pdf = theirs.eval_pdf(wi, wo)
    assert np.count_nonzero(pdf) > n // 2
    _assert_close(ours.eval(wi, wo), value, rtol=rtol, floor=1e-5, what=f"{spec['type']} eval")
    _assert_close(ours.pdf(wi, wo), pdf, rtol=rtol, floor=1e-5, what=f"{spec['type']} pdf")
    return theirs


def _compare_samples(theirs, ours, n=400, seed=360, two_sided=False):
    """Same uniforms: same direction, weight, pdf and eta (lobe choices may differ only at ties)."""
    rng = np.random.default_rng(seed)
    wi = _f32(random_directions(n, seed + 1, None if two_sided else True))
    u1, u2 = _f32(rng.random(n)), _f32(np.clip(rng.random((n, 2)), 1e-6, 1 - 1e-6))
    ref, bs = theirs.sample(wi, u1, u2), ours.sample(wi, u1, u2)
    # Mitsuba marks nothing invalid, it returns weight 0 (e.g. beyond the critical angle).
    their_valid = np.any(ref["weight"] > 0, axis=1)
    our_valid = bs.valid & np.any(bs.weight > 0, axis=1)
    same = (our_valid == their_valid) & (np.linalg.norm(bs.wo - ref["wo"], axis=1) < 1e-3)
    assert same.mean() > 0.98, same.mean()
    both = same & our_valid
    assert both.mean() > 0.5
    _assert_close(bs.weight[both], ref["weight"][both], rtol=2e-3, what="sample weight")
    _assert_close(bs.pdf[both], ref["pdf"][both], rtol=2e-3, floor=1e-4, what="sample pdf")
    np.testing.assert_allclose(bs.eta[both], ref["eta"][both], rtol=1e-6)


def _rgb(value):
    return {"type": "rgb", "value": list(value)}


@pytest.mark.mitsuba
@pytest.mark.parametrize("nonlinear, int_ior, ext_ior", [(False, 1.6, 1.000277), (True, 1.6, 1.000277),
                                                        (True, 1.2, 1.5)])   # eta < 1: other F_dr fit
def test_mitsuba_plastic(nonlinear, int_ior, ext_ior, mi):
    spec = {"type": "plastic", "diffuse_reflectance": _rgb(COLOUR), "nonlinear": nonlinear,
            "specular_reflectance": _rgb([1.0, 0.9, 0.7]), "int_ior": int_ior, "ext_ior": ext_ior}
    ours = Plastic(COLOUR, [1.0, 0.9, 0.7], int_ior, ext_ior, nonlinear)
    theirs = _compare_eval_pdf(mi, spec, ours)
    _compare_samples(theirs, ours)


@pytest.mark.mitsuba
@pytest.mark.parametrize("distribution, alpha, nonlinear, int_ior, ext_ior", [
    ("ggx", 0.05, False, 1.5046, 1.000277), ("ggx", 0.5, True, 1.5046, 1.000277),
    ("beckmann", 0.2, False, 1.5, 1.0), ("beckmann", 0.005, False, 2.0, 1.000277),
    ("ggx", 0.3, True, 1.2, 1.5)])
def test_mitsuba_roughplastic(distribution, alpha, nonlinear, int_ior, ext_ior, mi):
    """Also checks the coating tables: eval's diffuse term is T_i T_o / (1 - R_int)."""
    spec = {"type": "roughplastic", "distribution": distribution, "alpha": alpha,
            "diffuse_reflectance": _rgb(COLOUR), "nonlinear": nonlinear, "int_ior": int_ior,
            "ext_ior": ext_ior}
    ours = RoughPlastic(distribution, alpha, COLOUR, 1.0, int_ior, ext_ior, nonlinear)
    theirs = _compare_eval_pdf(mi, spec, ours)
    _compare_samples(theirs, ours)


@pytest.mark.mitsuba
@pytest.mark.parametrize("distribution, alpha_u, alpha_v, int_ior, ext_ior", [
    ("ggx", 0.1, 0.1, 1.5, 1.0), ("beckmann", 0.3, 0.3, 1.5, 1.0), ("ggx", 0.6, 0.6, 1.0, 1.33),
    ("beckmann", 0.05, 0.3, 1.5046, 1.000277)])
def test_mitsuba_roughdielectric(distribution, alpha_u, alpha_v, int_ior, ext_ior, mi):
    spec = {"type": "roughdielectric", "distribution": distribution, "alpha_u": alpha_u,
            "alpha_v": alpha_v, "int_ior": int_ior, "ext_ior": ext_ior,
            "specular_reflectance": _rgb([1.0, 0.9, 0.8]), "specular_transmittance": _rgb([0.7, 0.8, 1.0])}
    ours = RoughDielectric(distribution, alpha_u, alpha_v, int_ior, ext_ior, [1.0, 0.9, 0.8], [0.7, 0.8, 1.0])
    theirs = _compare_eval_pdf(mi, spec, ours)
    _compare_samples(theirs, ours, two_sided=True)


@pytest.mark.mitsuba
@pytest.mark.parametrize("distribution, alpha_u, alpha_v", [("beckmann", 0.3, 0.3), ("ggx", 0.1, 0.4)])
def test_mitsuba_sampling_without_visible_normals(distribution, alpha_u, alpha_v, mi):
    """sample_visible=false on roughconductor (gold) and roughplastic: same values, densities, samples."""
    eta, k = CONDUCTOR_PRESETS["Au"]
    spec = {"type": "roughconductor", "distribution": distribution, "alpha_u": alpha_u, "alpha_v": alpha_v,
            "material": "Au", "sample_visible": False}
    ours = RoughConductor(distribution, alpha_u, alpha_v, 1.0, eta, k, sample_visible=False)
    _compare_samples(_compare_eval_pdf(mi, spec, ours), ours)
    spec = {"type": "roughplastic", "distribution": distribution, "alpha": alpha_u,
            "diffuse_reflectance": _rgb(COLOUR), "sample_visible": False}
    ours = RoughPlastic(distribution, alpha_u, COLOUR, sample_visible=False)
    _compare_samples(_compare_eval_pdf(mi, spec, ours), ours)


@pytest.mark.mitsuba
def test_mitsuba_thindielectric(mi):
    spec = {"type": "thindielectric", "int_ior": 1.33, "specular_reflectance": _rgb([1.0, 0.9, 0.8]),
            "specular_transmittance": _rgb([0.7, 0.8, 1.0])}
    ours = ThinDielectric(1.33, 1.000277, [1.0, 0.9, 0.8], [0.7, 0.8, 1.0])
    theirs = _MitsubaBSDF(mi, spec)
    _compare_samples(theirs, ours, two_sided=True)
    value, pdf = theirs.eval_pdf(*_pairs(20, 370))
    assert not value.any() and not pdf.any()


@pytest.mark.mitsuba
def test_mitsuba_conductor_presets_are_mitsubas_rgb_values(mi):
    """The committed table is what Mitsuba's scalar_rgb conductor plugin holds for every material."""
    from mitsuba_refs.reference.conductor_presets import mitsuba_presets
    theirs = mitsuba_presets()
    assert set(theirs) == set(CONDUCTOR_PRESETS)
    for name, (eta, k) in theirs.items():
        np.testing.assert_allclose(CONDUCTOR_PRESETS[name], (eta, k), rtol=1e-7, err_msg=name)


@pytest.mark.mitsuba
@pytest.mark.parametrize("material", ["Au", "Cu", "Al", "Ag", "Cr", "a-C"])
def test_mitsuba_conductor_materials(material, mi):
    """Smooth conductor weights at angles from normal to grazing, and the rough one's eval."""
    eta, k = map(np.array, CONDUCTOR_PRESETS[material])
    smooth_theirs = _MitsubaBSDF(mi, {"type": "conductor", "material": material,
                                      "specular_reflectance": _rgb([1.0, 0.8, 0.9])})
    smooth = Conductor([1.0, 0.8, 0.9], eta, k)
    wi = _f32(np.array([direction(t, 30.0) for t in (0.0, 20.0, 45.0, 60.0, 75.0, 85.0, 89.0)]))
    u = np.full(len(wi), 0.5)
    ref, bs = smooth_theirs.sample(wi, u, np.full((len(wi), 2), 0.5)), smooth.sample(wi, u, np.full((len(wi), 2), 0.5))
    _assert_close(bs.weight, ref["weight"], rtol=1e-5, what=f"{material} conductor weight")
    rough_theirs = {"type": "roughconductor", "material": material, "distribution": "ggx", "alpha": 0.2}
    _compare_eval_pdf(mi, rough_theirs, RoughConductor("ggx", 0.2, 0.2, 1.0, eta, k), n=150)


@pytest.mark.mitsuba
def test_mitsuba_conductor_explicit_eta_k(mi):
    eta, k = [0.2, 0.9, 1.1], [3.9, 2.4, 2.2]
    theirs = _MitsubaBSDF(mi, {"type": "conductor", "eta": _rgb(eta), "k": _rgb(k)})
    wi = _f32(random_directions(200, 380, True))
    u = np.zeros(200)
    ref, bs = theirs.sample(wi, u, np.zeros((200, 2))), Conductor(1.0, eta, k).sample(wi, u, np.zeros((200, 2)))
    _assert_close(bs.weight, ref["weight"], rtol=1e-5, what="conductor with eta/k")
    only_eta = _MitsubaBSDF(mi, {"type": "conductor", "eta": 1.5})     # k defaults to 1
    ref = only_eta.sample(wi, u, np.zeros((200, 2)))
    _assert_close(Conductor(1.0, 1.5, 1.0).sample(wi, u, np.zeros((200, 2))).weight, ref["weight"],
                  rtol=1e-5, what="conductor with eta only")


@pytest.mark.statistical(assertions=1)
def test_smallpt_renders_every_material_as_path_does():
    """smallpt's roulette reads each object's colour (``obj.c``): on plastic, rough and thin
    dielectrics and conductors it must find one (thindielectric's ``reflectance`` is a method,
    which crashed it) and keep path's expectation."""
    from mitsuba_refs.stats import compare_means
    from pathtracer import load_scene, render
    from tests.budget import ALPHA
    scene = load_scene("materials", width=16, height=16)
    smallpt = render(scene, "smallpt", spp=64, seed=3, processes=1)
    path = render(scene, "path", spp=256, seed=4, processes=1)
    agreement = compare_means(smallpt.mean, smallpt.variance, smallpt.spp,
                              path.mean, path.variance, path.spp, alpha=ALPHA)
    assert agreement.agree, verdict_line(agreement)
