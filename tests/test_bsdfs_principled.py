"""Tests of the ``principled`` BSDF (Mitsuba 3's Disney BSDF).

Chi-square of sample() against pdf() (the suite's per-test alpha), estimator identities,
reciprocity, energy and the reduction to ``roughdielectric`` without Mitsuba; the XML
plugin's parsing and refusals; then eval, pdf and sample against Mitsuba 3's own plugin
(scalar_rgb, marked ``mitsuba``) for several parameter sets and with textured parameters.
The scene render against Mitsuba is the ``principled`` feature scene (test_agreement.py).
"""
from __future__ import annotations

import numpy as np
import pytest

from pathtracer.bsdfs import Principled, RoughDielectric
from pathtracer.bsdfs.principled import eta_from_specular
from pathtracer.scene.errors import SceneError
from pathtracer.scene.load import load_scene
from pathtracer.textures import Checkerboard
from tests.chi2 import chi2_sphere
from tests.test_bsdfs import _assert_close, _f32, _MitsubaBSDF, _pairs, density, direction, random_directions, tile
from tests.test_bsdfs_composite import SCALE_UV, _checker_spec, _MitsubaAt

statistical = pytest.mark.statistical(assertions=1)

#: Parameter sets: each lobe on in some, off in others (Mitsuba's names and defaults).
CASES = {
    "default": {},
    "sheen_clearcoat": dict(base_color=[0.8, 0.3, 0.2], roughness=0.3, metallic=0.4, spec_tint=0.5,
                            sheen=0.6, sheen_tint=0.4, clearcoat=0.7, clearcoat_gloss=0.6),
    "glass_anisotropic": dict(base_color=[0.2, 0.6, 0.9], roughness=0.4, spec_trans=0.6, eta=1.45,
                              anisotropic=0.5),
    "mixed": dict(base_color=[0.5, 0.5, 0.3], roughness=0.6, flatness=0.5, specular=0.8,
                  spec_trans=0.3, clearcoat=0.3, metallic=0.2, sheen=0.3),
    "brushed_metal": dict(base_color=[0.9, 0.7, 0.3], roughness=0.25, metallic=1.0, anisotropic=0.8),
    "rates": dict(base_color=[0.3, 0.8, 0.4], roughness=0.5, spec_trans=0.4, clearcoat=0.5,
                  diffuse_reflectance_sampling_rate=0.3, main_specular_sampling_rate=2.0,
                  clearcoat_sampling_rate=0.5),
}
#: The sets that transmit (queried from both sides).
TWO_SIDED = {"glass_anisotropic", "mixed", "rates"}


def _make(name: str) -> Principled:
    return Principled(**CASES[name])


def _sampler(bsdf, wi):
    def sample(u):
        bs = bsdf.sample(tile(wi, u.shape[0]), u[:, 0], u[:, 1:])
        return bs.wo, bs.valid
    return sample


# --------------------------------------------------------------------------
# Chi-square: sample() against pdf() (GGX's pdf is exact, GTR1 is sampled exactly)
# --------------------------------------------------------------------------

CHI2_CASES = [
    (dict(), 40.0),
    (dict(base_color=[0.8, 0.3, 0.2], roughness=0.4, metallic=0.3, sheen=0.5, clearcoat=1.0,
          clearcoat_gloss=0.3), 60.0),
    (dict(roughness=0.5, spec_trans=0.7, eta=1.5, anisotropic=0.6), 30.0),
    (dict(roughness=0.45, spec_trans=0.7, eta=1.5), 140.0),          # from inside
    (dict(base_color=[0.9, 0.7, 0.3], roughness=0.5, metallic=1.0, anisotropic=0.8), 75.0),
    (dict(roughness=0.7, flatness=0.6, specular=0.9, spec_trans=0.4, clearcoat=0.5,
          main_specular_sampling_rate=0.5), 10.0),
]


@statistical
@pytest.mark.parametrize("params, theta", CHI2_CASES)
def test_chi2_principled(params, theta):
    """Every lobe's directions over the whole sphere, z = 0 on a cell edge."""
    bsdf = Principled(**params)
    wi = direction(theta, 20.0)
    result = chi2_sphere(_sampler(bsdf, wi), density(bsdf.pdf, wi), n_samples=100_000,
                         res=(24, 36), subdiv=(48, 24), seed=int(theta) + 800)
    assert result.passed, result.message


@statistical
def test_chi2_has_power_on_the_clearcoat():
    """The binning resolves the GTR1 lobe: clearcoat-only samples (the other sampling rates
    0) for clearcoat_gloss 0.3 tested against the density for gloss 0.4 must fail."""
    wi = direction(50.0, 20.0)
    rates = dict(diffuse_reflectance_sampling_rate=0.0, main_specular_sampling_rate=0.0)
    truth = Principled(roughness=0.6, clearcoat=1.0, clearcoat_gloss=0.3, **rates)
    wrong = Principled(roughness=0.6, clearcoat=1.0, clearcoat_gloss=0.4, **rates)
    result = chi2_sphere(_sampler(truth, wi), density(wrong.pdf, wi), n_samples=100_000,
                         res=(24, 36), subdiv=(48, 24), seed=801)
    assert not result.passed


# --------------------------------------------------------------------------
# Estimator identities and physics
# --------------------------------------------------------------------------

@pytest.mark.parametrize("name", sorted(CASES))
def test_weight_is_eval_over_pdf(name):
    """For every sample: pdf() and eval()/pdf() reproduce what sample() returned."""
    bsdf = _make(name)
    n = 20_000
    rng = np.random.default_rng(810)
    wi = random_directions(n, 811, upper=None if name in TWO_SIDED else True)
    bs = bsdf.sample(wi, rng.random(n), rng.random((n, 2)))
    assert bs.valid.mean() > 0.6
    v = bs.valid
    value, pdf = bsdf.eval(wi[v], bs.wo[v]), bsdf.pdf(wi[v], bs.wo[v])
    np.testing.assert_allclose(pdf, bs.pdf[v], rtol=1e-9)
    np.testing.assert_allclose(value / pdf[:, None], bs.weight[v], rtol=1e-9, atol=1e-14)
    assert np.all(bs.weight[~v] == 0) and np.all(bs.pdf[~v] == 0)
    assert not np.any(bs.delta)
    crossing = bs.wo[v, 2] * wi[v, 2] < 0
    np.testing.assert_array_equal(bs.eta[v] != 1.0, crossing)


@pytest.mark.parametrize("name", sorted(CASES))
def test_reciprocity(name):
    r"""Reflection: f(wi, wo) = f(wo, wi) (each lobe is symmetric in its half vector).
    Transmission: f(wi, wo) / eta_i^2 is symmetric (the radiance-mode BTDF, as
    roughdielectric's test)."""
    bsdf = _make(name)
    two_sided = name in TWO_SIDED
    wi = random_directions(4000, 812, None if two_sided else True)
    wo = random_directions(4000, 813, None if two_sided else True)
    f_io = bsdf.eval(wi, wo) / np.abs(wo[:, 2:3])
    f_oi = bsdf.eval(wo, wi) / np.abs(wi[:, 2:3])
    if two_sided:
        def index(v):
            return np.where(v[:, 2] > 0, 1.0, bsdf.eta)[:, None]

        f_io, f_oi = f_io / index(wi) ** 2, f_oi / index(wo) ** 2
    assert np.count_nonzero(f_io) > 1000
    np.testing.assert_allclose(f_io, f_oi, rtol=1e-8, atol=1e-12)


def test_reduces_to_roughdielectric():
    """base_color 1, spec_trans 1: exactly GGX roughdielectric with alpha = roughness^2
    (value and density, both sides)."""
    ours = Principled(base_color=1.0, spec_trans=1.0, roughness=0.5, eta=1.5)
    theirs = RoughDielectric("ggx", 0.25, 0.25, 1.5, 1.0)
    wi, wo = random_directions(5000, 814), random_directions(5000, 815)
    rng = np.random.default_rng(816)
    wo[:2500] = theirs.sample(wi[:2500], rng.random(2500), rng.random((2500, 2))).wo
    np.testing.assert_allclose(ours.eval(wi, wo), theirs.eval(wi, wo), rtol=1e-10, atol=1e-14)
    np.testing.assert_allclose(ours.pdf(wi, wo), theirs.pdf(wi, wo), rtol=1e-10, atol=1e-14)


@pytest.mark.parametrize("params", [dict(base_color=1.0, metallic=1.0, roughness=0.3),
                                    dict(base_color=1.0, metallic=1.0, roughness=0.6, anisotropic=0.9),
                                    dict(base_color=1.0, spec_trans=1.0, roughness=0.4, eta=1.5)])
def test_specular_lobes_do_not_create_energy(params):
    """A white metal (Schlick F <= 1) and a white glass: mean flux fraction <= 1 at every
    angle (the weight without the 1/eta'^2 radiance scaling); the diffuse lobe is not
    energy-conserving in Burley's model and is left out."""
    bsdf = Principled(**params)
    n = 50_000
    rng = np.random.default_rng(817)
    for theta in (5.0, 45.0, 80.0, 130.0):
        bs = bsdf.sample(tile(direction(theta), n), rng.random(n), rng.random((n, 2)))
        flux = bs.weight * (bs.eta ** 2)[:, None]
        mean, sd = flux.mean(axis=0), flux.std(axis=0) / np.sqrt(n)
        assert np.all(mean <= 1.0 + 4 * sd + 1e-12), (theta, mean)


def test_one_sided_without_transmission():
    """Without spec_trans nothing is reflected below the surface and nothing sampled there."""
    bsdf = _make("sheen_clearcoat")
    wi = random_directions(2000, 818, upper=False)
    wo = random_directions(2000, 819)
    assert np.all(bsdf.eval(wi, wo) == 0)
    rng = np.random.default_rng(820)
    assert not np.any(bsdf.sample(wi, rng.random(2000), rng.random((2000, 2))).valid)
    assert not bsdf.refracts and _make("glass_anisotropic").refracts


def test_textured_parameters_are_looked_up_per_hit():
    """A checkerboard per parameter: at each uv the BSDF equals the constant one of that cell."""
    colour0, colour1 = [0.8, 0.2, 0.1], [0.1, 0.3, 0.9]
    textured = Principled(base_color=Checkerboard(colour0, colour1, to_uv=SCALE_UV),
                          roughness=Checkerboard(0.2, 0.7, to_uv=SCALE_UV),
                          metallic=Checkerboard(0.0, 0.8, to_uv=SCALE_UV),
                          spec_trans=Checkerboard(0.5, 0.1, to_uv=SCALE_UV),
                          anisotropic=Checkerboard(0.3, 0.6, to_uv=SCALE_UV),
                          clearcoat=Checkerboard(1.0, 0.2, to_uv=SCALE_UV), eta=1.4)
    assert textured.textured and textured.anisotropic and textured.refracts
    rng = np.random.default_rng(821)
    n = 400
    uv = rng.random((n, 2))
    wi, wo = random_directions(n, 822), random_directions(n, 823)
    bound = textured.at(uv)
    # Mitsuba's checkerboard picks the cells of eval_1 (numbers) the other way round
    # from those of eval (colours): where a number reads color0, base_color reads color1.
    cell = Checkerboard(0.0, 1.0, to_uv=SCALE_UV).eval_1(uv) > 0.5
    for which, params in ((False, dict(base_color=colour1, roughness=0.2, metallic=0.0,
                                       spec_trans=0.5, anisotropic=0.3, clearcoat=1.0)),
                          (True, dict(base_color=colour0, roughness=0.7, metallic=0.8,
                                      spec_trans=0.1, anisotropic=0.6, clearcoat=0.2))):
        rows = cell == which
        plain = Principled(eta=1.4, **params)
        np.testing.assert_allclose(bound.eval(wi, wo)[rows], plain.eval(wi[rows], wo[rows]),
                                   rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(bound.pdf(wi, wo)[rows], plain.pdf(wi[rows], wo[rows]),
                                   rtol=1e-12, atol=1e-15)
        u1, u2 = rng.random(n), rng.random((n, 2))
        a, b = bound.sample(wi, u1, u2), plain.sample(wi[rows], u1[rows], u2[rows])
        np.testing.assert_allclose(a.weight[rows], b.weight, rtol=1e-12, atol=1e-15)


# --------------------------------------------------------------------------
# The XML plugin
# --------------------------------------------------------------------------

FILM = ('<film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/>'
        '<rfilter type="box"/></film>')


def _bsdf_of(tmp_path, bsdf_body: str, plugin: str = "principled"):
    """The BSDF of a one-sphere scene file (its element starts on line 4)."""
    path = tmp_path / "principled.xml"
    path.write_text(f"""<scene version="3.0.0">
<sensor type="perspective"><float name="fov" value="40"/>{FILM}</sensor>
<shape type="sphere">
<bsdf type="{plugin}">
{bsdf_body}
</bsdf>
</shape>
</scene>
""")
    found = [b for b in load_scene(str(path)).bsdfs if type(b).__name__.lower() == plugin]
    assert len(found) == 1
    return found[0]


def test_xml_parameters_and_defaults(tmp_path):
    bsdf = _bsdf_of(tmp_path, """<rgb name="base_color" value="0.1, 0.2, 0.3"/>
            <float name="metallic" value="0.5"/> <float name="sheen" value="0"/>
            <float name="specular" value="0.7"/>
            <texture type="checkerboard" name="roughness">
                <float name="color0" value="0.1"/> <float name="color1" value="0.9"/>
            </texture>""")
    assert isinstance(bsdf, Principled)
    np.testing.assert_allclose(bsdf.base_color, [0.1, 0.2, 0.3])
    assert bsdf.metallic == 0.5 and not bsdf.on["sheen"] and bsdf.textured
    assert bsdf.eta == pytest.approx(eta_from_specular(0.7))
    default = _bsdf_of(tmp_path, "")
    assert default.eta == pytest.approx(1.5, abs=2e-3)     # specular 0.5 is about glass
    np.testing.assert_allclose(default.base_color, 0.5)
    assert default.roughness == 0.5 and not default.refracts and not default.anisotropic
    # As Mitsuba: an index of 1 (or a specular of 0) cannot transmit, and is moved off it.
    assert _bsdf_of(tmp_path, '<float name="eta" value="1"/><float name="spec_trans" value="0.5"/>').eta == 1.001
    assert _bsdf_of(tmp_path, '<float name="specular" value="0"/><float name="spec_trans" value="0.5"/>').eta \
        == pytest.approx(eta_from_specular(1e-3))


@pytest.mark.parametrize("body, message", [
    ('<float name="eta" value="1.5"/><float name="specular" value="0.5"/>', "either eta or specular"),
    ('<float name="eta" value="-1"/>', '"eta" must be positive'),
    ('<float name="specular" value="13"/>', '"specular" must be in'),
    ('<float name="clearcoat_sampling_rate" value="-1"/>', "must be >= 0"),
    ('<float name="sheen_color" value="1"/>', "sheen_color"),
    ('<texture type="checkerboard" name="eta"/>', "eta"),
])
def test_xml_refusals_name_the_line(body, message, tmp_path):
    with pytest.raises(SceneError) as error:
        _bsdf_of(tmp_path, body)
    text = str(error.value)
    assert message in text and "principled.xml:" in text and "\n" not in text


# --------------------------------------------------------------------------
# Comparison with Mitsuba 3's own plugin
# --------------------------------------------------------------------------

def _spec(params: dict, plugin: str = "principled") -> dict:
    spec = {"type": plugin}
    for key, value in params.items():
        spec[key] = {"type": "rgb", "value": list(value)} if key == "base_color" and np.ndim(value) \
            else value
    return spec


@pytest.mark.mitsuba
@pytest.mark.parametrize("name", sorted(CASES))
def test_mitsuba_eval_pdf(name, mi):
    ours = _make(name)
    theirs = _MitsubaBSDF(mi, _spec(CASES[name]))
    wi, wo = _pairs(300, 830, ours)
    value, pdf = theirs.eval_pdf(wi, wo)
    assert np.count_nonzero(pdf) > 450 and np.count_nonzero(value) > 450
    _assert_close(ours.eval(wi, wo), value, rtol=1e-3, floor=1e-5, what=f"{name} eval")
    _assert_close(ours.pdf(wi, wo), pdf, rtol=1e-3, floor=1e-5, what=f"{name} pdf")


def _compare_samples(ours_sample, ref, n):
    """Same uniforms: same validity, direction, weight, pdf and eta (ties at lobe edges aside)."""
    their_valid = np.any(ref["weight"] > 0, axis=1)
    bs = ours_sample
    our_valid = bs.valid & np.any(bs.weight > 0, axis=1)
    close = np.linalg.norm(bs.wo - ref["wo"], axis=1) < 1e-3
    same = (our_valid == their_valid) & (close | ~our_valid)
    assert same.mean() > 0.98, same.mean()
    both = same & our_valid
    assert both.sum() > 0.3 * n
    _assert_close(bs.weight[both], ref["weight"][both], rtol=2e-3, what="sample weight")
    _assert_close(bs.pdf[both], ref["pdf"][both], rtol=2e-3, floor=1e-4, what="sample pdf")
    if "eta" in ref:
        np.testing.assert_allclose(bs.eta[both], ref["eta"][both], rtol=1e-6)


@pytest.mark.mitsuba
@pytest.mark.parametrize("name", sorted(CASES))
def test_mitsuba_sample(name, mi):
    ours = _make(name)
    theirs = _MitsubaBSDF(mi, _spec(CASES[name]))
    n, rng = 500, np.random.default_rng(840)
    wi = _f32(random_directions(n, 841, None if name in TWO_SIDED else True))
    u1, u2 = _f32(rng.random(n)), _f32(np.clip(rng.random((n, 2)), 1e-6, 1 - 1e-6))
    _compare_samples(ours.sample(wi, u1, u2), theirs.sample(wi, u1, u2), n)


def _textured_case(mi):
    colour0, colour1 = [0.8, 0.2, 0.1], [0.1, 0.3, 0.9]
    checker = {"base_color": (colour0, colour1), "roughness": (0.2, 0.7), "metallic": (0.0, 0.8),
               "spec_trans": (0.5, 0.1), "anisotropic": (0.3, 0.6), "clearcoat": (1.0, 0.2),
               "clearcoat_gloss": (0.2, 0.9), "sheen": (0.7, 0.0), "sheen_tint": (0.0, 1.0),
               "spec_tint": (0.6, 0.1), "flatness": (0.4, 0.9)}
    ours = Principled(eta=1.4, **{k: Checkerboard(*v, to_uv=SCALE_UV) for k, v in checker.items()})
    spec = {"type": "principled", "eta": 1.4, **{k: _checker_spec(*v) for k, v in checker.items()}}
    return ours, _MitsubaAt(mi, spec)


@pytest.mark.mitsuba
def test_mitsuba_textured_parameters(mi):
    """Every texturable parameter a checkerboard: eval, pdf and samples at random uv."""
    ours, theirs = _textured_case(mi)
    rng = np.random.default_rng(850)
    n = 400
    uv = _f32(rng.random((2 * n, 2)))
    wi = _f32(random_directions(2 * n, 851))
    bound = ours.at(uv)
    sampled = bound.sample(wi, rng.random(2 * n), rng.random((2 * n, 2))).wo
    wo = _f32(np.concatenate((random_directions(n, 852), sampled[n:])))
    value, pdf = theirs.eval_pdf(wi, wo, uv)
    assert np.count_nonzero(pdf) > n
    _assert_close(bound.eval(wi, wo), value, rtol=1e-3, floor=1e-5, what="textured eval")
    _assert_close(bound.pdf(wi, wo), pdf, rtol=1e-3, floor=1e-5, what="textured pdf")
    u1, u2 = _f32(rng.random(2 * n)), _f32(np.clip(rng.random((2 * n, 2)), 1e-6, 1 - 1e-6))
    _compare_samples(bound.sample(wi, u1, u2), theirs.sample(wi, u1, u2, uv), 2 * n)


@pytest.mark.mitsuba
def test_mitsuba_twosided_principled(mi):
    """Blender's exporter may wrap the material in twosided: the back side is the front's."""
    from pathtracer.bsdfs import TwoSided
    params = dict(base_color=[0.8, 0.3, 0.2], roughness=0.3, metallic=0.4, sheen=0.6,
                  clearcoat=0.7, anisotropic=0.5)
    ours = TwoSided(Principled(**params))
    theirs = _MitsubaBSDF(mi, {"type": "twosided", "material": _spec(params)})
    wi, wo = _pairs(300, 890, ours)
    value, pdf = theirs.eval_pdf(wi, wo)
    assert np.count_nonzero(pdf[wi[:, 2] < 0]) > 200
    _assert_close(ours.eval(wi, wo), value, rtol=1e-3, floor=1e-5, what="twosided eval")
    _assert_close(ours.pdf(wi, wo), pdf, rtol=1e-3, floor=1e-5, what="twosided pdf")
