"""Tests of the ``principledthin`` BSDF (Mitsuba 3's thin Disney BSDF).

Chi-square of sample() against pdf() (the suite's per-test alpha), the estimator identity,
the symmetry of a sheet seen from either side, reciprocity, the XML plugin, then eval, pdf
and sample against Mitsuba 3's own plugin (scalar_rgb, marked ``mitsuba``), textured
parameters included. It renders in the ``principled`` feature scene (test_agreement.py).
"""
from __future__ import annotations

import numpy as np
import pytest

from pathtracer.bsdfs import PrincipledThin
from pathtracer.textures import Checkerboard
from tests.chi2 import chi2_sphere
from tests.test_bsdfs import _assert_close, _f32, _MitsubaBSDF, _pairs, density, direction, random_directions
from tests.test_bsdfs_composite import SCALE_UV, _checker_spec, _MitsubaAt
from tests.test_bsdfs_principled import _bsdf_of, _compare_samples, _sampler, _spec

statistical = pytest.mark.statistical(assertions=1)

CASES = {
    "default": {},
    "glossy_sheet": dict(base_color=[0.8, 0.3, 0.2], roughness=0.3, spec_trans=0.5, spec_tint=0.5,
                         sheen=0.6, sheen_tint=0.4, eta=1.3),
    "leaf": dict(base_color=[0.2, 0.6, 0.3], roughness=0.4, spec_trans=0.3, eta=1.45,
                 anisotropic=0.5, diff_trans=0.8, flatness=0.4),
    "translucent": dict(base_color=[0.5, 0.5, 0.3], roughness=0.6, diff_trans=1.2, sheen=0.3),
    "rates": dict(base_color=[0.9, 0.9, 0.9], roughness=0.2, spec_trans=0.8, eta=1.6, diff_trans=0.4,
                  specular_reflectance_sampling_rate=0.5, diffuse_transmittance_sampling_rate=2.0),
}


@statistical
@pytest.mark.parametrize("params, theta", [
    (dict(roughness=0.5, spec_trans=0.6, eta=1.5, diff_trans=0.6), 35.0),
    (dict(roughness=0.4, spec_trans=0.4, eta=1.3, anisotropic=0.7, sheen=0.5), 120.0),  # back side
    (dict(roughness=0.7, diff_trans=1.5, flatness=0.5,
          diffuse_transmittance_sampling_rate=0.5), 80.0),
])
def test_chi2_principledthin(params, theta):
    bsdf = PrincipledThin(**params)
    wi = direction(theta, 20.0)
    result = chi2_sphere(_sampler(bsdf, wi), density(bsdf.pdf, wi), n_samples=100_000,
                         res=(24, 36), subdiv=(48, 24), seed=int(theta) + 860)
    assert result.passed, result.message


@pytest.mark.parametrize("name", sorted(CASES))
def test_weight_is_eval_over_pdf_and_eta_is_one(name):
    bsdf = PrincipledThin(**CASES[name])
    n = 20_000
    rng = np.random.default_rng(870)
    wi = random_directions(n, 871)
    bs = bsdf.sample(wi, rng.random(n), rng.random((n, 2)))
    assert bs.valid.mean() > 0.9
    v = bs.valid
    value, pdf = bsdf.eval(wi[v], bs.wo[v]), bsdf.pdf(wi[v], bs.wo[v])
    np.testing.assert_allclose(pdf, bs.pdf[v], rtol=1e-9)
    np.testing.assert_allclose(value / pdf[:, None], bs.weight[v], rtol=1e-9, atol=1e-14)
    assert np.all(bs.eta == 1.0) and not bsdf.refracts
    assert np.all(bs.weight[~v] == 0)


@pytest.mark.parametrize("name", sorted(CASES))
def test_both_sides_alike_and_reciprocal(name):
    """A sheet: mirroring both directions through it changes nothing, and its reflection
    is reciprocal, f(wi, wo) = f(wo, wi)."""
    bsdf = PrincipledThin(**CASES[name])
    wi, wo = random_directions(4000, 872), random_directions(4000, 873)
    flip = np.array([1.0, 1.0, -1.0])
    np.testing.assert_allclose(bsdf.eval(wi * flip, wo * flip), bsdf.eval(wi, wo), rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(bsdf.pdf(wi * flip, wo * flip), bsdf.pdf(wi, wo), rtol=1e-12, atol=1e-15)
    reflect = wi[:, 2] * wo[:, 2] > 0
    f_io = bsdf.eval(wi, wo) / np.abs(wo[:, 2:3])
    f_oi = bsdf.eval(wo, wi) / np.abs(wi[:, 2:3])
    assert np.count_nonzero(f_io[reflect]) > 1000
    np.testing.assert_allclose(f_io[reflect], f_oi[reflect], rtol=1e-8, atol=1e-12)


def test_textured_parameters_are_looked_up_per_hit():
    colour0, colour1 = [0.8, 0.2, 0.1], [0.1, 0.3, 0.9]
    textured = PrincipledThin(base_color=Checkerboard(colour0, colour1, to_uv=SCALE_UV),
                              spec_trans=Checkerboard(0.5, 0.1, to_uv=SCALE_UV),
                              diff_trans=Checkerboard(0.4, 1.6, to_uv=SCALE_UV),
                              eta=Checkerboard(1.2, 1.7, to_uv=SCALE_UV))
    assert textured.textured
    rng = np.random.default_rng(874)
    uv = rng.random((400, 2))
    wi, wo = random_directions(400, 875), random_directions(400, 876)
    bound = textured.at(uv)
    cell = Checkerboard(0.0, 1.0, to_uv=SCALE_UV).eval_1(uv) > 0.5   # numbers: eval_1's cells
    for which, params in ((False, dict(base_color=colour1, spec_trans=0.5, diff_trans=0.4, eta=1.2)),
                          (True, dict(base_color=colour0, spec_trans=0.1, diff_trans=1.6, eta=1.7))):
        rows = cell == which
        plain = PrincipledThin(**params)
        np.testing.assert_allclose(bound.eval(wi, wo)[rows], plain.eval(wi[rows], wo[rows]),
                                   rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(bound.pdf(wi, wo)[rows], plain.pdf(wi[rows], wo[rows]),
                                   rtol=1e-12, atol=1e-15)


def test_xml(tmp_path):
    bsdf = _bsdf_of(tmp_path, '<float name="diff_trans" value="0.5"/>', "principledthin")
    assert isinstance(bsdf, PrincipledThin) and bsdf.eta_thin == 1.5 and bsdf.on["diff_trans"]
    from pathtracer.scene.errors import SceneError
    with pytest.raises(SceneError, match='"eta" must be positive'):
        _bsdf_of(tmp_path, '<float name="eta" value="0"/>', "principledthin")
    with pytest.raises(SceneError, match="clearcoat"):
        _bsdf_of(tmp_path, '<float name="clearcoat" value="0.5"/>', "principledthin")


@pytest.mark.mitsuba
@pytest.mark.parametrize("name", sorted(CASES))
def test_mitsuba_eval_pdf_sample(name, mi):
    ours = PrincipledThin(**CASES[name])
    theirs = _MitsubaBSDF(mi, _spec(CASES[name], "principledthin"))
    wi, wo = _pairs(300, 880, ours)
    value, pdf = theirs.eval_pdf(wi, wo)
    assert np.count_nonzero(pdf) > 450
    _assert_close(ours.eval(wi, wo), value, rtol=1e-3, floor=1e-5, what=f"{name} eval")
    _assert_close(ours.pdf(wi, wo), pdf, rtol=1e-3, floor=1e-5, what=f"{name} pdf")
    n, rng = 500, np.random.default_rng(881)
    wi = _f32(random_directions(n, 882))
    u1, u2 = _f32(rng.random(n)), _f32(np.clip(rng.random((n, 2)), 1e-6, 1 - 1e-6))
    _compare_samples(ours.sample(wi, u1, u2), theirs.sample(wi, u1, u2), n)


@pytest.mark.mitsuba
def test_mitsuba_textured_parameters(mi):
    colour0, colour1 = [0.8, 0.2, 0.1], [0.1, 0.3, 0.9]
    checker = {"base_color": (colour0, colour1), "roughness": (0.2, 0.7), "spec_trans": (0.5, 0.1),
               "anisotropic": (0.3, 0.6), "diff_trans": (0.4, 1.6), "eta": (1.2, 1.7),
               "sheen": (0.7, 0.0), "sheen_tint": (0.0, 1.0), "spec_tint": (0.6, 0.1),
               "flatness": (0.4, 0.9)}
    ours = PrincipledThin(**{k: Checkerboard(*v, to_uv=SCALE_UV) for k, v in checker.items()})
    theirs = _MitsubaAt(mi, {"type": "principledthin",
                             **{k: _checker_spec(*v) for k, v in checker.items()}})
    rng = np.random.default_rng(883)
    n = 400
    uv = _f32(rng.random((2 * n, 2)))
    wi = _f32(random_directions(2 * n, 884))
    bound = ours.at(uv)
    sampled = bound.sample(wi, rng.random(2 * n), rng.random((2 * n, 2))).wo
    wo = _f32(np.concatenate((random_directions(n, 885), sampled[n:])))
    value, pdf = theirs.eval_pdf(wi, wo, uv)
    _assert_close(bound.eval(wi, wo), value, rtol=1e-3, floor=1e-5, what="textured eval")
    _assert_close(bound.pdf(wi, wo), pdf, rtol=1e-3, floor=1e-5, what="textured pdf")
    u1, u2 = _f32(rng.random(2 * n)), _f32(np.clip(rng.random((2 * n, 2)), 1e-6, 1 - 1e-6))
    _compare_samples(bound.sample(wi, u1, u2), theirs.sample(wi, u1, u2, uv), 2 * n)
