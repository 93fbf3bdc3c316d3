"""Participating media: closed forms without Mitsuba, and Mitsuba's ``volpath``.

Closed forms: phase functions integrate to one and are sampled as they say
(chi-square); the transmittance of a slab behind null boundaries is
exp(-sigma_t d) per channel (coloured sigma_t, so the per-channel free-flight
weights are exercised); an emitter seen through a purely absorbing slab;
a point light over a plane inside a purely absorbing medium
(L = rho / pi * I cos exp(-sigma_a (r + s)) / r^2, s the camera's distance);
the volumetric furnace (albedo-1 medium inside an emitting diffuse enclosure,
camera inside the medium: Le / (1 - rho) whatever the medium). Against the
committed Mitsuba references of the lecture's scenes: mean, variance (volpath
is Mitsuba's estimator) and convergence.
"""
from pathlib import Path

import numpy as np
import pytest

from mitsuba_refs.report.wording import verdict_line
from mitsuba_refs.stats import MeanTestOptions, VarianceTestOptions
from mitsuba_refs.verdicts.compare import compare
from mitsuba_refs.verdicts.convergence import check_convergence
from pathtracer import load_scene, render
from pathtracer.core.rng import RandomStream, sample_keys
from pathtracer.media.homogeneous import shadow_transmittance
from pathtracer.media.phase import HenyeyGreensteinPhase, IsotropicPhase
from tests.budget import ALPHA
from tests.chi2 import chi2_sphere
from tests.scenes import medium_ball_on_floor
from tests.test_analytic import assert_matches, footprint_average

VOLUMETRIC = ("volpath", "volpath_phase", "volpathmis")

SENSOR = """
    <sensor type="perspective">
        <float name="fov" value="{fov}"/>
        <transform name="to_world"><lookat origin="{origin}" target="{target}" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="16"/></sampler>
        <film type="hdrfilm">
            <integer name="width" value="{size}"/><integer name="height" value="{size}"/>
            <rfilter type="box"/>
        </film>
        {medium}
    </sensor>"""


def write_scene(tmp_path, body, fov=30, origin="0, 0, 4", target="0, 0, 0", size=16, medium=""):
    path = tmp_path / "scene.xml"
    sensor = SENSOR.format(fov=fov, origin=origin, target=target, size=size, medium=medium)
    path.write_text(f'<scene version="3.0.0">{sensor}{body}</scene>')
    return load_scene(str(path))


# -- phase functions -------------------------------------------------------------------------

PHASES = [IsotropicPhase(), HenyeyGreensteinPhase(-0.5), HenyeyGreensteinPhase(0.3),
          HenyeyGreensteinPhase(0.9)]


@pytest.mark.parametrize("phase", PHASES, ids=["isotropic", "hg-0.5", "hg0.3", "hg0.9"])
def test_phase_function_is_normalised_and_sampled_with_its_value(phase):
    wi = np.tile([0.0, 0.6, 0.8], (200_000, 1))
    # Midpoint rule in (mu, phi) about -wi, fine near the forward peak.
    mu = 1 - np.geomspace(1e-7, 2, 200_001)
    mid, width = 0.5 * (mu[1:] + mu[:-1]), -np.diff(mu)
    value = phase.value(-mid) if hasattr(phase, "value") else np.full_like(mid, 1 / (4 * np.pi))
    assert abs(2 * np.pi * np.sum(value * width) - 1.0) < 1e-4
    u = np.random.default_rng(1).random((200_000, 2))
    wo, pdf = phase.sample(wi, u)
    np.testing.assert_allclose(np.linalg.norm(wo, axis=1), 1.0, rtol=1e-12)
    np.testing.assert_allclose(pdf, phase.eval(wi, wo), rtol=1e-9)


@pytest.mark.statistical(assertions=1)
@pytest.mark.parametrize("g", [-0.5, 0.2, 0.85])
def test_hg_sampling_matches_its_density_chi2(g):
    phase = HenyeyGreensteinPhase(g)
    wi = np.array([0.0, 0.6, 0.8])

    def sample(u):
        return phase.sample(np.tile(wi, (len(u), 1)), u[:, :2])[0]

    def pdf(wo):
        return phase.eval(np.tile(wi, (len(wo), 1)), wo)

    result = chi2_sphere(sample, pdf, axis=-wi if g > 0 else wi, z_power=3 if abs(g) > 0.5 else 1,
                         seed=5, alpha=ALPHA)
    assert result.passed, result


# -- transmittance ---------------------------------------------------------------------------

SLAB = """
    <medium type="homogeneous" id="slab">
        <rgb name="sigma_t" value="0.25, 0.5, 1"/>
        <float name="scale" value="2"/>
        <float name="albedo" value="{albedo}"/>
    </medium>
    <shape type="cube">
        <transform name="to_world"><scale value="10, 10, {half}"/></transform>
        <bsdf type="null"/>
        <ref id="slab" name="interior"/>
    </shape>"""


@pytest.mark.statistical(assertions=1)
def test_slab_transmittance_is_exp_minus_sigma_t_d(tmp_path):
    """Shadow rays through a slab between null boundaries: E[T] = exp(-sigma_t d) per channel."""
    d = 0.8
    scene = write_scene(tmp_path, SLAB.format(albedo=0.5, half=d / 2))
    n = 60_000
    start = np.tile([0.0, 0.0, 2.0], (n, 1))
    wo = np.tile([0.0, 0.0, -1.0], (n, 1))
    rng = RandomStream(sample_keys(3, np.arange(n)))
    channel = np.minimum((rng.next_1d() * 3).astype(np.int64), 2)
    T = shadow_transmittance(scene, start, np.zeros((n, 3)), wo, np.full(n, 4.0),
                             np.full(n, -1), channel, rng, 10)
    expected = np.exp(-np.array([0.5, 1.0, 2.0]) * d)
    z = (T.mean(0) - expected) / np.sqrt(T.var(0, ddof=1) / n)
    from scipy.stats import norm
    assert np.all(2 * norm.sf(np.abs(z)) > ALPHA / 3), (T.mean(0), expected)
    # A shadow ray that misses the slab sees no medium: exactly 1.
    side = shadow_transmittance(scene, np.tile([20.0, 0, 2], (4, 1)), np.zeros((4, 3)),
                                np.tile([0.0, 0, -1], (4, 1)), np.full(4, 4.0), np.full(4, -1),
                                np.zeros(4, np.int64), RandomStream(sample_keys(3, np.arange(4))), 10)
    assert np.all(side == 1.0)


LIGHT_WALL = """
    <shape type="rectangle">
        <transform name="to_world"><scale value="6"/><translate value="0, 0, -3"/></transform>
        <emitter type="area"><rgb name="radiance" value="1, 2, 3"/></emitter>
    </shape>"""


@pytest.mark.statistical(assertions=1)
@pytest.mark.parametrize("integrator", VOLUMETRIC)
def test_emitter_seen_through_absorbing_slab(tmp_path, integrator):
    """Albedo 0: a camera ray crossing the slab (thickness d, along d_z) keeps exp(-sigma_t d / |d_z|)."""
    d = 0.8
    scene = write_scene(tmp_path, SLAB.format(albedo=0, half=d / 2) + LIGHT_WALL)
    sigma = np.array([0.5, 1.0, 2.0])
    result = render(scene, integrator, spp=32, seed=21, processes=1)
    expected = footprint_average(scene, lambda hit, w: np.array([1.0, 2.0, 3.0])
                                 * np.exp(-sigma * d / np.abs(w[:, 2:3])), sub=4)
    assert_matches(result, expected)


@pytest.mark.statistical(assertions=1)
def test_point_light_over_plane_in_absorbing_medium(tmp_path):
    """Camera, plane and point light all inside one absorbing medium (the sensor's)."""
    sigma, rho, intensity, h = 0.3, 0.5, 10.0, 1.0
    body = f"""
    <medium type="homogeneous" id="smoke"><float name="sigma_t" value="{sigma}"/>
        <float name="albedo" value="0"/></medium>
    <emitter type="point"><point name="position" value="0, {h}, 0"/>
        <float name="intensity" value="{intensity}"/></emitter>
    <shape type="rectangle">
        <transform name="to_world"><scale value="10"/><rotate x="1" angle="-90"/></transform>
        <bsdf type="diffuse"><float name="reflectance" value="{rho}"/></bsdf>
    </shape>"""
    scene = write_scene(tmp_path, body, fov=60, origin="0, 2, 3", target="0, 0, 0",
                        medium='<ref id="smoke"/>')
    result = render(scene, "volpath", spp=16, seed=22, processes=1)

    def radiance_at(hit, w):
        r2 = hit.p[:, 0] ** 2 + hit.p[:, 2] ** 2 + h ** 2
        L = rho / np.pi * intensity * h / r2 ** 1.5 * np.exp(-sigma * (np.sqrt(r2) + hit.t))
        return np.where(hit.valid, L, 0.0)[:, None] * np.ones(3)

    assert_matches(result, footprint_average(scene, radiance_at, sub=4))


@pytest.mark.statistical(assertions=1)
@pytest.mark.parametrize("integrator", VOLUMETRIC)
def test_volumetric_furnace_is_le_over_one_minus_rho(tmp_path, integrator):
    """Albedo-1 medium (hg) filling an emitting diffuse sphere, camera inside the medium.

    The sphere's normals point inwards (flip_normals), so its inside is its *exterior*
    side: the medium is given as ``exterior``, which checks the sign of medium tracking.
    """
    rho, Le = 0.5, 1.0
    body = f"""
    <medium type="homogeneous" id="fog"><float name="sigma_t" value="1.5"/>
        <float name="albedo" value="1"/><phase type="hg"><float name="g" value="0.5"/></phase>
    </medium>
    <shape type="sphere">
        <boolean name="flip_normals" value="true"/>
        <bsdf type="diffuse"><float name="reflectance" value="{rho}"/></bsdf>
        <emitter type="area"><float name="radiance" value="{Le}"/></emitter>
        <ref id="fog" name="exterior"/>
    </shape>"""
    scene = write_scene(tmp_path, body, fov=90, origin="0, 0, 0", target="0, 0, -1", size=8,
                        medium='<ref id="fog"/>')
    result = render(scene, integrator, spp=32, seed=23, processes=1)
    assert_matches(result, np.full_like(result.mean, Le / (1 - rho)))


# -- against Mitsuba's volpath (committed references) -----------------------------------------

@pytest.mark.statistical(assertions=2)
@pytest.mark.parametrize("scene,integrator", [("lecture-media-1", "volpath"),
                                              ("lecture-media-4", "volpath"),
                                              ("lecture-media-2", "volpath_phase")])
def test_lecture_scene_agrees_with_mitsuba_volpath(scene, integrator):
    comparison = compare(scene, integrator, spp=16, alpha=ALPHA, convergence=False,
                         bounces=False, processes=2)
    assert comparison.mean.agree, comparison.report()
    if integrator == "volpath":
        assert comparison.variance is not None and comparison.variance.agree, comparison.report()


@pytest.mark.statistical(assertions=1)
def test_volpath_converges_on_the_lecture_scene():
    law, _ = check_convergence("lecture-media-3", "volpath", alpha=ALPHA, processes=2,
                               ladder=(1, 4, 16), replicas=1)
    assert law.passed, verdict_line(law)


# -- the scene description (its errors are cases of tests/test_scene_errors.py) -------------


def test_media_on_shapes_and_sensor_load_by_ref_and_nested(tmp_path):
    body = """
    <medium type="homogeneous" id="fog"><rgb name="sigma_t" value="0.5, 1, 0.25"/>
        <float name="scale" value="4"/><float name="albedo" value="0.5"/></medium>
    <shape type="sphere"><bsdf type="null"/><ref id="fog" name="interior"/>
        <medium type="homogeneous" name="exterior"><phase type="hg"><float name="g" value="-0.3"/></phase></medium>
    </shape>
    <shape type="cube"/>"""
    scene = write_scene(tmp_path, body, medium='<ref id="fog"/>')
    assert len(scene.media) == 2 and scene.camera_medium == 0
    np.testing.assert_allclose(scene.media[0].sigma_t, [2, 4, 1])
    np.testing.assert_allclose(scene.media[1].sigma_t, 1.0)    # Mitsuba's defaults
    np.testing.assert_allclose(scene.media[1].albedo, 0.75)
    assert scene.media[1].phase.g == -0.3 and scene.media[0].phase.kind == "isotropic"
    assert list(scene.shape_interior) == [0, -1] and list(scene.shape_exterior) == [1, -1]


def test_surface_integrators_refuse_media(tmp_path):
    scene = write_scene(tmp_path, SLAB.format(albedo=0.5, half=0.4) + LIGHT_WALL)
    with pytest.raises(ValueError, match="use volpath or volpath_phase"):
        render(scene, "path", spp=1)


# -- against a live Mitsuba ------------------------------------------------------------------

@pytest.mark.parametrize("g", [0.0, 0.7, -0.4])
def test_hg_value_matches_mitsuba(mi, g):
    phase = mi.load_dict({"type": "hg", "g": g})
    wi = np.array([0.3, -0.5, 0.812404])
    wi /= np.linalg.norm(wi)
    mei = mi.MediumInteraction3f()
    mei.wi = mi.Vector3f(*wi)
    mei.sh_frame = mi.Frame3f(mei.wi)
    ours = HenyeyGreensteinPhase(g) if g else IsotropicPhase()
    for wo in np.random.default_rng(2).normal(size=(20, 3)):
        wo /= np.linalg.norm(wo)
        value, pdf = phase.eval_pdf(mi.PhaseFunctionContext(None), mei, mi.Vector3f(*wo))
        expected = float(np.ravel(value)[0])
        assert ours.eval(wi[None], wo[None])[0] == pytest.approx(expected, rel=2e-5)
        assert float(pdf) == pytest.approx(expected, rel=2e-5)


@pytest.mark.mitsuba
@pytest.mark.statistical(assertions=2)
def test_camera_in_medium_agrees_with_live_mitsuba_volpath():
    """The camera's own medium (Mitsuba's batch sensor would drop it: the reference is
    rendered by the moments method), coloured sigma_t, exterior medium of a flipped cube."""
    from mitsuba_refs.reference.render import render_reference
    from mitsuba_refs.stats import compare_means, compare_variances
    path = str(Path(__file__).parent / "data" / "camera_in_medium.xml")
    reference = render_reference(path, {}, "volpath", 256, 1)
    assert reference.metadata["method"] == "moments"
    ours = render(load_scene(path), "volpath", spp=64, seed=24, processes=1)
    mean = compare_means(ours.mean, ours.variance, 64, reference.mean, reference.var,
                         reference.n, alpha=ALPHA, options=MeanTestOptions(tile=8))
    assert mean.agree, verdict_line(mean)
    variance = compare_variances(ours.variance, 64, reference.var, reference.n, alpha=ALPHA,
                                 options=VarianceTestOptions(tile=8))
    assert variance.agree, verdict_line(variance)


VOLPATHMIS_BODY = """
    <integrator type="volpathmis"><integer name="max_depth" value="8"/></integrator>
    <medium type="homogeneous" id="tinted">
        <rgb name="sigma_t" value="1, 0.2, 0.6"/><float name="scale" value="2"/>
        <rgb name="albedo" value="0.5, 0.8, 0.95"/>
        <phase type="hg"><float name="g" value="0.4"/></phase>
    </medium>""" + medium_ball_on_floor("tinted", 0.9, 3, "1, 2, 1.5", 10, 0.3)


def test_a_volpathmis_file_renders_with_volpathmis_compared_by_its_mean(tmp_path):
    """A file naming Mitsuba's volpathmis renders with the tracer's volpathmis, its parameters
    kept, and is compared with Mitsuba's volpathmis, mean only (weighted per path there, per
    flight here)."""
    from mitsuba_refs.reference.render import MEAN_ONLY, integrator_dict
    from mitsuba_refs.verdicts.estimators import SAME_ESTIMATOR, reference_integrator
    scene = write_scene(tmp_path, VOLPATHMIS_BODY)
    assert scene.integrator.name == "volpathmis" and scene.integrator.params == {"max_depth": 8}
    assert reference_integrator("volpathmis") == "volpathmis"
    assert "volpathmis" in MEAN_ONLY and "volpathmis" not in SAME_ESTIMATOR
    assert integrator_dict("volpathmis", {"max_depth": 8}) == {"type": "volpathmis", "max_depth": 8}


def test_spectral_mis_weights_are_bounded_and_unbiased():
    """Free flights from the channels' mixture (sigma_t = 10, 2, 10): every weight is at most 3
    in every channel, where volpath's green weight grows as 0.1 exp(8 t); both estimate the
    same expectations, from stratified numbers: the transmittance to the surface, and the
    in-scattered integral of sigma_s T over [0, s]."""
    from types import SimpleNamespace

    from pathtracer.media.homogeneous import MIXTURE, sample_free_flight
    medium = SimpleNamespace(is_homogeneous=True, sigma_t=np.array([10.0, 2.0, 10.0]),
                             sigma_s=np.array([8.0, 1.8, 5.0]))
    scene = SimpleNamespace(media=[medium])
    count, s = 300_000, 0.8
    u = (np.arange(count) + 0.5) / count
    expected_tr = np.exp(-medium.sigma_t * s)
    expected_scatter = medium.sigma_s / medium.sigma_t * (1 - expected_tr)
    one_channel = np.minimum((np.random.default_rng(2).random(count) * 3).astype(int), 2)
    for mis in (False, True):
        channel = np.full(count, MIXTURE) if mis else one_channel
        flight = sample_free_flight(scene, np.zeros(count, np.int64), channel, np.full(count, s), u)
        scatter = np.where(flight.scattered[:, None], flight.weight, 0.0).mean(axis=0)
        through = np.where(flight.scattered[:, None], 0.0, flight.weight).mean(axis=0)
        np.testing.assert_allclose(through, expected_tr, rtol=0.02)
        np.testing.assert_allclose(scatter, expected_scatter, rtol=0.02)
        largest = flight.weight.max(axis=0)
        if mis:
            assert np.all(largest <= 3.0 + 1e-12)
        else:
            assert largest[1] > 50    # green, drawn with red or blue: 0.1 exp(8 t) and 1 / T_c


@pytest.mark.mitsuba
@pytest.mark.statistical(assertions=1)
def test_volpathmis_has_the_mean_of_live_mitsuba_volpathmis(tmp_path):
    """Mitsuba's volpathmis (spectral MIS over the channels' free-flight pdfs, per path) and
    ours (per flight) are two estimators of one radiance: ours has the mean of Mitsuba's in a
    medium whose sigma_t differs by channel (5x).
    Mitsuba's side: 16 renders of 64 spp with their own seeds (the renders' spread gives the
    variance; the box filter keeps pixels independent)."""
    import mitsuba as mi

    from mitsuba_refs.reference.variant import set_variant
    from mitsuba_refs.stats import compare_means
    scene = write_scene(tmp_path, VOLPATHMIS_BODY, origin="0, 0.6, 4", size=16)
    set_variant("scalar_rgb")
    reference = mi.load_file(str(tmp_path / "scene.xml"))
    assert str(reference.integrator()).startswith("VolumetricMisPathIntegrator")
    renders = np.stack([np.array(mi.render(reference, spp=64, seed=1 + k)) for k in range(16)])
    ref_mean, ref_var = renders.mean(axis=0), renders.var(axis=0, ddof=1) * 64
    ours = render(scene, spp=64, seed=41, processes=1)
    mean = compare_means(ours.mean, ours.variance, 64, ref_mean, ref_var, 16 * 64,
                         alpha=ALPHA, options=MeanTestOptions(tile=4))
    assert mean.agree, verdict_line(mean)


@pytest.mark.parametrize("integrator", VOLUMETRIC)
def test_image_does_not_depend_on_batching(integrator):
    """Paths cross different numbers of null boundaries, yet each draws its numbers at
    fixed counters: the same seed gives the same image whatever the batch size."""
    scene = load_scene("lecture-media-1", width=8, height=8)
    one = render(scene, integrator, spp=2, seed=5, processes=1)
    other = render(scene, integrator, spp=2, seed=5, processes=1, batch_size=37)
    np.testing.assert_array_equal(one.mean, other.mean)
    np.testing.assert_array_equal(one.variance, other.variance)


def test_shadow_rays_cross_null_and_thin_dielectric_but_not_glass(tmp_path):
    """Mitsuba's eval_null_transmission: 1 through null, (1 - r) through a thin pane
    (r = 2R / (1 + R), R = 0.04 at normal incidence for eta 1.5), 0 through a dielectric."""
    panes = "".join(f"""
    <shape type="rectangle">
        <transform name="to_world"><translate value="{x}, 0, 0"/></transform>
        {bsdf}
    </shape>""" for x, bsdf in ((0, '<bsdf type="null"/>'),
                                (3, '<bsdf type="thindielectric"><float name="int_ior" value="1.5"/>'
                                    '<float name="ext_ior" value="1"/></bsdf>'),
                                (6, '<bsdf type="dielectric"/>')))
    scene = write_scene(tmp_path, panes)
    start = np.array([[0.0, 0, 1], [3, 0, 1], [6, 0, 1], [3, 0, 1]])
    wo = np.tile([0.0, 0, -1], (4, 1))
    dist = np.array([2.0, 2.0, 2.0, 0.5])     # the last one stops before the pane
    T = shadow_transmittance(scene, start, np.zeros((4, 3)), wo, dist, np.full(4, -1),
                             np.zeros(4, np.int64), RandomStream(sample_keys(1, np.arange(4))), 0)
    r = 2 * 0.04 / 1.04
    np.testing.assert_allclose(T, [[1] * 3, [1 - r] * 3, [0] * 3, [1] * 3], rtol=1e-12)
