"""The light tracer's own pieces: camera importance and connection, rays leaving the lights,
the adjoint BSDF, replica renders and the refusals.

Its agreement with Mitsuba's ``ptracer`` (mean, variance across replicas, convergence) runs
in test_agreement.py / test_convergence.py (tests/scenes.py: ``LIGHT_SCENES`` and the
``caustics`` feature scene), its closed forms in test_analytic.py.
"""
import numpy as np
import pytest

from mitsuba_refs.report.wording import verdict_line
from pathtracer import load_scene, render
from pathtracer.bsdfs.dielectric import Dielectric
from pathtracer.bsdfs.roughdielectric import RoughDielectric
from pathtracer.bsdfs.shading import importance_scale
from pathtracer.cli import main
from pathtracer.core.sampling import square_to_uniform_sphere
from pathtracer.emitters.scene_emitters import EmitterPosition, emitted_towards, pdf_emitter_ray, sample_emitter_ray
from pathtracer.sensors.importance import connect_to_camera, pdf_camera
from pathtracer.sensors.perspective import camera_rays
from tests.chi2 import chi2_sphere

LIGHTS = {
    "area": """<shape type="rectangle"><transform name="to_world"><scale value="0.3"/>
                 <rotate x="1" angle="90"/><translate value="0, 2, 0"/></transform>
                 <emitter type="area"><rgb name="radiance" value="5, 4, 3"/></emitter></shape>""",
    "point": """<emitter type="point"><point name="position" value="0, 2, 0"/>
                  <rgb name="intensity" value="5, 4, 3"/></emitter>""",
    "spot": """<emitter type="spot"><transform name="to_world">
                 <lookat origin="0, 2, 0" target="0.5, 0, 0.2" up="0, 0, 1"/></transform>
                 <float name="cutoff_angle" value="30"/><float name="beam_width" value="20"/>
                 <rgb name="intensity" value="5, 4, 3"/></emitter>""",
    "projector": """<emitter type="projector"><transform name="to_world">
                 <lookat origin="0, 2, 0" target="0.5, 0, 0.2" up="0, 0, 1"/></transform>
                 <float name="fov" value="50"/><rgb name="irradiance" value="5, 4, 3"/></emitter>""",
}
SCENE = """<scene version="3.0.0">
  <sensor type="perspective"><float name="fov" value="40"/>
    <transform name="to_world"><lookat origin="0, 1, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/>
      <rfilter type="box"/></film></sensor>
  <shape type="rectangle"><transform name="to_world"><rotate x="1" angle="-90"/></transform></shape>
  {light}
</scene>"""


def light_scene(tmp_path, kind):
    path = tmp_path / f"{kind}.xml"
    path.write_text(SCENE.format(light=LIGHTS[kind]))
    return load_scene(str(path))


def camera_basis(camera):
    """(linear part of to_world, unit forward axis) of a camera."""
    linear = camera.to_world[:3, :3]
    forward = linear[:, 2] / np.linalg.norm(linear[:, 2])
    return linear, forward


def test_connect_to_camera_inverts_camera_rays():
    """A point on the ray of (pixel, u_film) connects back to that pixel and film position."""
    camera = load_scene("cornell-lights", width=20, height=15).camera    # 4:3, fov on one axis
    rng = np.random.default_rng(1)
    pixel = rng.integers(0, 20 * 15, 4000)
    u_film = rng.random((4000, 2))
    rays = camera_rays(camera, pixel, u_film)
    points = rays.o + rays.d * rng.uniform(0.1, 5.0, 4000)[:, None]
    connection = connect_to_camera(camera, points)
    np.testing.assert_array_equal(connection.pixel, pixel)
    np.testing.assert_allclose(connection.film, np.stack((pixel % 20, pixel // 20), 1) + u_film,
                               atol=1e-8)
    np.testing.assert_allclose(connection.wi, -rays.d, atol=1e-12)
    origin = camera.to_world[:3, 3]
    np.testing.assert_allclose(connection.dist, np.linalg.norm(points - origin, axis=1))
    _, forward = camera_basis(camera)
    behind = origin - forward * 2.0
    outside = origin + forward + np.cross(forward, [0.0, 1.0, 0.0]) * 5.0
    far = connect_to_camera(camera, np.array([behind, outside]))
    np.testing.assert_array_equal(far.pixel, [-1, -1])
    np.testing.assert_array_equal(far.importance, [0.0, 0.0])


def test_camera_importance_integrates_to_one_over_the_image_and_one_over_wh_per_pixel():
    """Midpoint quadrature of We over the sphere in (cos theta, phi) around the optical
    axis (a parameterisation unrelated to the film plane's)."""
    camera = load_scene("cornell-lights", width=4, height=3).camera
    cos_t = 1.0 - (np.arange(800) + 0.5) / 800 * 0.3            # the field of view is inside
    phi = (np.arange(800) + 0.5) / 800 * 2 * np.pi
    c, p = np.meshgrid(cos_t, phi, indexing="ij")
    s = np.sqrt(1 - c * c)
    d_cam = np.stack((s * np.cos(p), s * np.sin(p), c), -1).reshape(-1, 3)
    cell = 0.3 / 800 * 2 * np.pi / 800
    we = pdf_camera(camera, d_cam)
    assert abs(we.sum() * cell - 1.0) < 2e-3
    # one pixel: the directions whose film position lands in pixel (column 1, row 2)
    linear, _ = camera_basis(camera)
    connection = connect_to_camera(camera, camera.to_world[:3, 3] + d_cam @ linear.T)
    in_pixel = connection.pixel == 2 * 4 + 1
    assert abs(we[in_pixel].sum() * cell * 12 - 1.0) < 5e-3


@pytest.mark.statistical(assertions=1)
def test_camera_ray_directions_follow_pdf_camera():
    """Chi-square: the directions of camera rays through uniform pixels and film samples
    have the solid-angle density ``pdf_camera`` (= We)."""
    camera = load_scene("cornell-lights", width=16, height=12).camera
    linear, forward = camera_basis(camera)
    inverse = np.linalg.inv(linear).T

    def sample(u):
        pixel = np.minimum((u[:, 2] * 192).astype(np.int64), 191)
        return camera_rays(camera, pixel, u[:, :2]).d

    def pdf(d):
        local = d @ inverse
        return pdf_camera(camera, local / np.linalg.norm(local, axis=1, keepdims=True))

    edges = np.concatenate(([-1.0], np.linspace(0.86, 1.0, 15)))
    result = chi2_sphere(sample, pdf, axis=forward, z_edges=edges, res=(0, 24), seed=3)
    assert result.passed, result.message


@pytest.mark.statistical(assertions=1)
@pytest.mark.parametrize("kind", sorted(LIGHTS))
def test_emitter_ray_directions_follow_pdf_emitter_ray(tmp_path, kind):
    """Chi-square of the directions leaving each kind of light against ``pdf_emitter_ray``;
    every ray's weight is ``Le cos / (p_pos p_dir)`` (``I falloff / (p_pos p_dir)``)."""
    scene = light_scene(tmp_path, kind)

    def sample(u):
        ray = sample_emitter_ray(scene, np.zeros(len(u)), u[:, 1:], u[:, :2])
        return ray.d

    ray = sample_emitter_ray(scene, np.zeros(1), np.full((1, 2), 0.5), np.full((1, 2), 0.5))
    normal = ray.position.n[0]

    def pdf(d):
        n = len(d)
        position = EmitterPosition(np.zeros((n, 3)), np.tile(normal, (n, 1)),
                                   np.zeros(n, dtype=np.int64), np.ones(n), np.zeros(n, bool),
                                   np.ones((n, 3)))
        return pdf_emitter_ray(scene, position, d)

    axis = np.array([0.5, -2.0, 0.2]) if kind in ("spot", "projector") else np.array([0.0, -1.0, 0.0])
    axis /= np.linalg.norm(axis)           # the spot's and projector's axis; the area light's normal
    # rings of equal width inside the cone (the spot's edge on a ring edge), or around the
    # projector's frustum (half-angle 33.4 degrees at its corners)
    cone = {"spot": 30, "projector": 36}.get(kind)
    edges = np.concatenate(([-1.0], np.linspace(np.cos(np.radians(cone)), 1.0, 13))) \
        if cone else None
    result = chi2_sphere(sample, pdf, axis=axis, res=(12, 16), z_edges=edges, seed=5)
    assert result.passed, result.message

    u = np.random.default_rng(2).random((1000, 4))
    ray = sample_emitter_ray(scene, np.zeros(1000), u[:, :2], u[:, 2:])
    emitted = emitted_towards(scene, ray.position, ray.d)
    cos = np.maximum(np.sum(ray.d * ray.position.n, axis=1), 0.0) if kind == "area" else 1.0
    expected = emitted * (cos / (ray.position.pdf * pdf_emitter_ray(scene, ray.position, ray.d)))[:, None]
    np.testing.assert_allclose(ray.weight, expected, rtol=1e-10)
    area = scene.shape_area[scene.emitters[0].shape] if kind == "area" else None
    np.testing.assert_allclose(ray.position.pdf, 1.0 / area if area else 1.0)


def test_adjoint_rough_dielectric_is_the_reversed_bsdf():
    """f*(wi, wo) = f(wo, wi): without the radiance's 1/eta^2 the rough dielectric is
    reciprocal (eval includes |cos wo|, hence the ratios)."""
    bsdf = RoughDielectric("ggx", alpha_u=0.3, int_ior=1.5, ext_ior=1.0)
    rng = np.random.default_rng(4)
    wi, wo = square_to_uniform_sphere(rng.random((4000, 2))), square_to_uniform_sphere(rng.random((4000, 2)))
    adjoint = bsdf.eval(wi, wo)[:, 0] * importance_scale(bsdf, wi, wo) / np.abs(wo[:, 2])
    reversed_ = bsdf.eval(wo, wi)[:, 0] / np.abs(wi[:, 2])
    crossing = wi[:, 2] * wo[:, 2] < 0
    assert crossing.sum() > 1000 and (reversed_[crossing] > 0).sum() > 300
    np.testing.assert_allclose(adjoint, reversed_, rtol=1e-9, atol=1e-12)


def test_adjoint_refraction_weight_has_no_eta_squared():
    """Smooth glass: a sampled refraction carries T eta_ti^2 for radiance, T for importance."""
    glass = Dielectric(int_ior=1.5, ext_ior=1.0)
    wi = np.tile([0.0, 0.6, 0.8], (4, 1))
    bs = glass.sample(wi, np.full(4, 0.99), np.zeros((4, 2)))      # u1 > F: refraction
    assert np.all(bs.wo[:, 2] < 0)
    np.testing.assert_allclose(bs.weight[:, 0], 1 / 1.5 ** 2)
    np.testing.assert_allclose(bs.weight[:, 0] * bs.eta ** 2, 1.0)  # what sample_bsdf(adjoint) gives


def test_light_render_is_the_same_for_any_number_of_processes():
    scene = load_scene("cornell-box", width=8, height=8)
    one = render(scene, "light", spp=8, seed=5, processes=1, batch_size=128)
    two = render(scene, "light", spp=8, seed=5, processes=2, batch_size=128)
    np.testing.assert_array_equal(one.mean, two.mean)
    np.testing.assert_array_equal(one.variance, two.variance)
    assert one.options["replicas"] == 8 and one.variance.any()


def test_replicas_divide_spp():
    from pathtracer.render.splats import replica_count
    assert [replica_count(spp, 8) for spp in (1, 4, 6, 16, 64, 7)] == [1, 4, 6, 8, 8, 7]
    single = render(load_scene("cornell-box", width=8, height=8), "light", spp=1, seed=1, processes=1)
    assert not single.variance.any()    # one replica: no spread to measure


def test_light_tracing_refuses_environment_lights_and_wide_filters():
    with pytest.raises(ValueError, match="light tracing does not support envmap emitters yet"):
        render(load_scene("envmap", width=8, height=8), "light", spp=1, processes=1)
    filtered = load_scene("quad-light-filtered", width=8, height=6, rfilter="tent")
    with pytest.raises(ValueError, match="box filter only; the film has tent"):
        render(filtered, "light", spp=1, processes=1)


def test_cli_renders_light_and_refuses_in_one_line(tmp_path, capsys):
    out = tmp_path / "light.exr"
    assert main(["render", "cornell-box", "-D", "width=8", "-D", "height=8", "--spp", "4",
                 "--integrator", "light", "--processes", "1", "-o", str(out)]) == 0
    assert out.exists()
    capsys.readouterr()
    assert main(["render", "envmap", "-D", "width=8", "-D", "height=8", "--spp", "1",
                 "--integrator", "light", "-o", str(tmp_path / "env.exr")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "does not support envmap" in err


def test_mitsuba_ptracer_in_a_file_renders_with_light(tmp_path):
    path = tmp_path / "ptracer.xml"
    path.write_text(SCENE.format(light=LIGHTS["area"]).replace(
        "<scene version=\"3.0.0\">", "<scene version=\"3.0.0\"><integrator type=\"ptracer\">"
        "<integer name=\"max_depth\" value=\"3\"/></integrator>"))
    scene = load_scene(str(path))
    assert (scene.integrator.name, scene.integrator.params) == ("light", {"max_depth": 3})
    assert render(scene, spp=2, seed=1, processes=1).integrator == "light"


@pytest.mark.statistical(assertions=1)
def test_path_tracing_misses_the_point_light_caustic_that_light_tracing_finds():
    """The caustics experiment's verdict: against Mitsuba's ptracer reference, path tracing
    with shadow rays converges to an image without the caustic (a shadow ray cannot pass
    the glass), and the mean test says so."""
    from mitsuba_refs.reference.cache import get_reference
    from mitsuba_refs.stats import compare_means
    from tests.budget import ALPHA
    params = {"width": 32, "height": 32, "light": "point"}
    reference = get_reference("caustics", params, "light", render=False)
    ours = render(load_scene("caustics", **params), "path", spp=64, seed=21, processes=1)
    verdict = compare_means(ours.mean, ours.variance, ours.spp, reference.mean, reference.var,
                            reference.n, alpha=ALPHA)
    assert not verdict.agree, verdict_line(verdict)
