"""Area lights with a textured radiance: the texture's own position sampling, next-event
estimates against the integral they estimate, pdfs of sampled and hit points, refusals.

Without Mitsuba (deterministic: stratified grids of random numbers, no statistical
assertions): a bitmap's ``sample_position`` puts into each texel the mass its
``pdf_position`` gives it; next-event estimation from a point recovers the irradiance
integrated over the light by the midpoint rule; the pdf a sample reports is the one
``pdf_emitter_direction`` computes where a ray along it hits. Against Mitsuba: the
``lights-cameras`` scene (tests/test_agreement.py, committed reference) and the live
comparisons at the end.
"""
import numpy as np
import pytest

from mitsuba_refs.report.wording import verdict_line
from mitsuba_refs.stats import compare_means
from mitsuba_refs.verdicts.compare import compare
from pathtracer import load_scene, render
from pathtracer.emitters.scene_emitters import (
    emitted_radiance,
    emitter_position_at,
    pdf_emitter_direction,
    sample_emitter,
    sample_emitter_position,
)
from pathtracer.scene.errors import SceneError
from pathtracer.shapes.intersect import Hit, intersect, texture_uv
from pathtracer.textures import BitmapTexture, Checkerboard
from tests.budget import ALPHA
from tests.test_textures import _exr

TEXELS = np.random.default_rng(7).random((3, 4, 3)) * [1.0, 0.6, 0.3]


def stratified(count):
    """A count x count grid of points in the unit square (one per cell centre)."""
    g = (np.arange(count) + 0.5) / count
    x, y = np.meshgrid(g, g)
    return np.column_stack((x.ravel(), y.ravel()))


@pytest.mark.parametrize("filter_type", ["nearest", "bilinear"])
@pytest.mark.parametrize("wrap_mode", ["repeat", "clamp", "mirror"])
def test_bitmap_positions_follow_their_density(filter_type, wrap_mode):
    texture = BitmapTexture(TEXELS, filter_type, wrap_mode)
    uv, pdf = texture.sample_position(stratified(400))
    assert np.all((uv >= 0) & (uv <= 1)) and np.all(pdf > 0)
    np.testing.assert_allclose(pdf, texture.pdf_position(uv), rtol=1e-12)
    # The density integrates to 1, and each of 8 x 6 bins gets the mass the density gives it.
    grid = stratified(600)
    density = texture.pdf_position(grid)
    assert density.mean() == pytest.approx(1.0, abs=2e-3)
    bins = (np.minimum((grid * [8, 6]).astype(int), [7, 5]) @ [1, 8])
    expected = np.bincount(bins, density, 48) / len(grid)
    counted = np.bincount(np.minimum((uv * [8, 6]).astype(int), [7, 5]) @ [1, 8], minlength=48) / len(uv)
    np.testing.assert_allclose(counted, expected, atol=3e-3)


SCENE = """<scene version="3.0.0">
  <sensor type="perspective"><float name="fov" value="40"/>
    <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/>
      <rfilter type="box"/></film></sensor>
  <shape type="{shape}"><transform name="to_world"><scale x="0.8" y="0.5"/><rotate x="1" angle="80"/>
      <translate y="1"/></transform>
    <emitter type="area">{radiance}</emitter></shape>
</scene>"""
CHECKER = ('<texture type="checkerboard" name="radiance"><rgb name="color0" value="1, 0.5, 0.2"/>'
           '<rgb name="color1" value="0.1, 0.2, 0.9"/><transform name="to_uv"><scale x="3" y="2"/>'
           '</transform></texture>')


def load(tmp_path, radiance, shape="rectangle", transform=None):
    _exr(tmp_path, TEXELS, "light.exr")
    path = tmp_path / "scene.xml"
    text = SCENE.format(shape=shape, radiance=radiance)
    if transform is not None:
        text = text.replace('<scale x="0.8" y="0.5"/>', transform)
    path.write_text(text)
    return load_scene(str(path))


def bitmap(filter_type="bilinear", wrap="repeat"):
    return (f'<texture type="bitmap" name="radiance"><string name="filename" value="light.exr"/>'
            f'<string name="filter_type" value="{filter_type}"/><string name="wrap_mode" '
            f'value="{wrap}"/></texture>')


def reference_hits(count=6):
    p = np.column_stack((np.linspace(-0.6, 0.6, count), np.zeros(count), np.linspace(-0.3, 0.5, count)))
    n = np.tile([0.0, 1.0, 0.0], (count, 1))
    return Hit(np.ones(count, bool), np.zeros(count), p, n, n, np.zeros(count, np.int32),
               np.zeros(count, np.int64), np.zeros((count, 2)))


def irradiance_by_quadrature(scene, texture, points, steps=400):
    """The irradiance at ``points`` (normal +y) from the light, by the midpoint rule over its
    uv square: the rectangle's point of uv (u, v) is to_world (2u - 1, 2v - 1, 0)."""
    m = scene.emitters[0]
    uv = stratified(steps)
    local = np.column_stack((2 * uv - 1, np.zeros(len(uv)), np.ones(len(uv))))
    to_world = np.array(scene_to_world(scene, m.shape))
    x = local @ to_world.T
    normal = to_world[:3, 2] / np.linalg.norm(to_world[:3, 2])
    area = 4 * np.linalg.norm(np.cross(to_world[:3, 0], to_world[:3, 1]))
    radiance = texture.eval(uv)
    out = []
    for p in points:
        d = x[:, :3] - p
        r2 = np.sum(d * d, axis=1)
        w = d / np.sqrt(r2)[:, None]
        cos_p, cos_l = np.maximum(w[:, 1], 0), np.maximum(-w @ normal, 0)
        out.append((radiance * (cos_p * cos_l / r2)[:, None]).mean(axis=0) * area)
    return np.array(out)


def scene_to_world(scene, shape):
    """The light rectangle's to_world, recovered from its two triangles' corners."""
    begin = scene.shape_prim[shape, 0]
    tri = scene.tri_p[begin:begin + 2].reshape(-1, 3)
    uv = scene.tri_uv[begin:begin + 2].reshape(-1, 2)
    local = np.column_stack((2 * uv - 1, np.ones(len(uv))))          # (x, y, 1) per corner
    solve, *_ = np.linalg.lstsq(local, tri, rcond=None)               # x e0 + y e1 + origin
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 3] = solve[0], solve[1], solve[2]
    m[:3, 2] = np.cross(solve[0], solve[1])
    return m


@pytest.mark.parametrize("radiance", [bitmap("bilinear"), bitmap("nearest", "clamp"), CHECKER])
def test_next_event_estimates_the_irradiance_integral(tmp_path, radiance):
    scene = load(tmp_path, radiance)
    light = scene.emitters[0]
    assert light.textured and light.by_texture
    hits = reference_hits()
    u = stratified(300)
    estimate = []
    for k in range(len(hits.p)):
        one = Hit(*(np.repeat(getattr(hits, f)[k:k + 1], len(u), axis=0) for f in
                    ("valid", "t", "p", "n", "sh_n", "shape", "prim", "uv")))
        s = sample_emitter(scene, one, np.zeros(len(u)), u, test_visibility=False)
        estimate.append((s.weight * np.maximum(s.wo[:, 1:2], 0)).mean(axis=0))
    expected = irradiance_by_quadrature(scene, light.radiance, hits.p)
    np.testing.assert_allclose(np.array(estimate), expected, rtol=0.02, atol=1e-4)


def test_sampled_pdf_is_the_pdf_of_the_hit(tmp_path):
    scene = load(tmp_path, bitmap("bilinear", "mirror"))
    hits = reference_hits(1)
    count = 2000
    u = np.random.default_rng(3).random((count, 2))
    one = Hit(*(np.repeat(getattr(hits, f), count, axis=0) for f in
                ("valid", "t", "p", "n", "sh_n", "shape", "prim", "uv")))
    s = sample_emitter(scene, one, np.zeros(count), u, test_visibility=False)
    live = s.pdf > 0
    assert live.mean() > 0.5
    hit = intersect(scene, one.p[live] + 1e-6 * s.wo[live], s.wo[live])
    assert hit.valid.all()
    np.testing.assert_allclose(hit.t + 1e-6, s.dist[live], rtol=1e-6)
    pdf = pdf_emitter_direction(scene, one.p[live], hit, s.wo[live])
    np.testing.assert_allclose(pdf, s.pdf[live], rtol=1e-6)


def test_rays_that_hit_the_light_see_the_texture(tmp_path):
    scene = load(tmp_path, CHECKER)
    texture = scene.emitters[0].radiance
    assert isinstance(texture, Checkerboard)
    rng = np.random.default_rng(5)
    o = np.column_stack((rng.uniform(-0.5, 0.5, 300), np.zeros(300), rng.uniform(-0.3, 0.3, 300)))
    d = np.tile([0.0, 1.0, 0.0], (300, 1))
    hit = intersect(scene, o, d)
    assert hit.valid.all()
    seen = emitted_radiance(scene, hit, -d)
    np.testing.assert_allclose(seen, texture.eval(texture_uv(scene, hit, np.arange(300))))
    assert len(np.unique(seen[:, 0])) == 2                 # both colours of the checkerboard
    back = intersect(scene, o + [0, 2, 0], -d)
    np.testing.assert_array_equal(emitted_radiance(scene, back, d), 0.0)   # one-sided


@pytest.mark.parametrize("radiance", [bitmap("bilinear"), CHECKER])
def test_light_paths_start_where_the_texture_puts_them(tmp_path, radiance):
    """The points where light paths start (light tracing, BDPT): each carries the radiance and
    the area density that a ray hitting it there finds, and their emission over density
    estimates the light's power per steradian, the radiance integrated over its area (the
    midpoint rule over its uv square)."""
    scene = load(tmp_path, radiance)
    light = scene.emitters[0]
    count = 200 ** 2
    position = sample_emitter_position(scene, np.zeros(count), stratified(200))
    live = position.pdf > 0
    assert live.all()
    hit = intersect(scene, position.p - 1e-4 * position.n, position.n)   # from just behind
    assert hit.valid.all() and np.all(hit.t < 2e-4)
    at_hit = emitter_position_at(scene, hit)
    np.testing.assert_allclose(at_hit.pdf, position.pdf, rtol=1e-9)
    np.testing.assert_allclose(at_hit.emission, position.emission, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(emitted_radiance(scene, hit, position.n), position.emission,
                               rtol=1e-9, atol=1e-12)
    to_world = scene_to_world(scene, light.shape)
    area = 4 * np.linalg.norm(np.cross(to_world[:3, 0], to_world[:3, 1]))
    power = light.radiance.eval(stratified(400)).mean(axis=0) * area
    estimate = (position.emission / position.pdf[:, None]).mean(axis=0)
    np.testing.assert_allclose(estimate, power, rtol=0.01)


def test_a_textured_radiance_on_a_sphere_is_refused(tmp_path):
    with pytest.raises(SceneError, match="textured radiance on a sphere is not supported"):
        load(tmp_path, bitmap(), shape="sphere", transform="")


LIVE = """<scene version="3.0.0">
  <integrator type="{integrator}"><integer name="max_depth" value="3"/></integrator>
  <sensor type="{sensor}">{sensor_extra}
    <transform name="to_world"><lookat origin="0, 1.2, 3.5" target="0, 0.5, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="16"/>
      <rfilter type="box"/></film>
    <sampler type="independent"><integer name="sample_count" value="16"/></sampler>
  </sensor>
  <shape type="rectangle"><transform name="to_world"><scale value="3"/><rotate x="1" angle="-90"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.6"/></bsdf></shape>
  <shape type="sphere"><point name="center" x="0.5" y="0.4" z="0.3"/><float name="radius" value="0.4"/>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.5, 0.7, 0.4"/></bsdf></shape>
  {light}
</scene>"""
BITMAP_LIGHT = """<shape type="rectangle"><transform name="to_world"><scale x="1.2" y="0.9"/>
    <rotate x="1" angle="60"/><translate y="1.4" z="-0.8"/></transform>
    <emitter type="area"><texture type="bitmap" name="radiance"><string name="filename" value="light.exr"/>
      <string name="wrap_mode" value="clamp"/><transform name="to_uv"><scale x="1.5"/></transform></texture>
    </emitter></shape>"""
ATTRIBUTE_LIGHT = """<shape type="ply"><string name="filename" value="{ply}"/>
    <transform name="to_world"><scale value="0.6"/><rotate x="1" angle="70"/>
      <translate x="-0.4" y="1.2" z="-0.5"/></transform>
    <emitter type="area"><texture type="mesh_attribute" name="radiance"><string name="name" value="vertex_color"/>
      <float name="scale" value="4"/></texture></emitter></shape>"""


@pytest.mark.mitsuba
@pytest.mark.statistical(assertions=2)
@pytest.mark.parametrize("case", ["bitmap-orthographic", "attribute-bsdf"])
def test_agrees_with_live_mitsuba(tmp_path, monkeypatch, case):
    """A clamped, to_uv-scaled bitmap radiance seen by an orthographic camera (``path``: mean
    and variance); a vertex-coloured emitting mesh, with BSDF sampling alone
    (``path_bsdf``): Mitsuba 3.9.1 crashes (segmentation fault, scalar_rgb) when next-event
    estimation samples an area light whose radiance is a ``mesh_attribute``."""
    from tests.test_mesh_attribute import GRID
    load(tmp_path, CHECKER)   # writes light.exr
    if case == "bitmap-orthographic":
        text = LIVE.format(integrator="path", sensor="orthographic", light=BITMAP_LIGHT,
                           sensor_extra="").replace('<lookat', '<scale x="1.8" y="1.8"/><lookat')
        integrator = "path"
    else:
        text = LIVE.format(integrator="path", sensor="perspective", light=ATTRIBUTE_LIGHT.format(ply=GRID),
                           sensor_extra='<float name="fov" value="50"/>')
        integrator = "path_bsdf"
    path = tmp_path / f"{case}.xml"
    path.write_text(text)
    monkeypatch.setenv("MITSUBA_REFS_CACHE", str(tmp_path / "cache"))  # not the committed folder
    comparison = compare(str(path), integrator, spp=16, alpha=ALPHA, convergence=False,
                         bounces=False, processes=2)
    assert comparison.mean.agree, comparison.report()
    assert comparison.variance is not None and comparison.variance.agree, comparison.report()


PROJECTOR = """<emitter type="projector"><texture type="bitmap" name="irradiance">
      <string name="filename" value="light.exr"/><string name="filter_type" value="nearest"/></texture>
    <float name="scale" value="6"/><float name="fov" value="45"/>
    <transform name="to_world"><lookat origin="-1.2, 2, 1.8" target="0.2, 0, -0.3" up="0, 1, 0"/></transform>
  </emitter>"""


def light_path_scene(tmp_path, integrator):
    """The live scene lit by the bitmap area light and a bitmap projector, pinhole camera."""
    load(tmp_path, CHECKER)   # writes light.exr
    path = tmp_path / f"light-paths-{integrator}.xml"
    path.write_text(LIVE.format(integrator=integrator, sensor="perspective", light=BITMAP_LIGHT + PROJECTOR,
                                sensor_extra='<float name="fov" value="50"/>'))
    return path


@pytest.mark.statistical(assertions=1)
@pytest.mark.parametrize("integrator", ["light", "bdpt"])
def test_light_paths_from_textured_lights_agree_with_path_tracing(tmp_path, integrator):
    """Light tracing and BDPT start paths on the bitmap area light (points drawn by the
    texture) and on the bitmap projector (directions through image positions drawn by it):
    their images against our ``path`` at 4x the samples (``path`` itself is compared with
    Mitsuba on such lights in tests/test_agreement.py and above)."""
    scene = load_scene(str(light_path_scene(tmp_path, integrator)))
    reference = render(scene, "path", spp=256, seed=31, processes=2)
    ours = render(scene, integrator, spp=64, seed=32, processes=2)
    verdict = compare_means(ours.mean, ours.variance, ours.spp, reference.mean,
                            reference.variance, reference.spp, alpha=ALPHA)
    assert verdict.agree, verdict_line(verdict)


@pytest.mark.mitsuba
@pytest.mark.statistical(assertions=2)
def test_light_tracing_from_textured_lights_agrees_with_live_mitsuba(tmp_path, monkeypatch):
    """Our ``light`` against Mitsuba 3.9.1's ``ptracer`` on the same scene: mean and variance
    (across replicas)."""
    path = light_path_scene(tmp_path, "ptracer")
    monkeypatch.setenv("MITSUBA_REFS_CACHE", str(tmp_path / "cache"))  # not the committed folder
    comparison = compare(str(path), "light", spp=64, alpha=ALPHA, convergence=False,
                         bounces=False, processes=2)
    assert comparison.mean.agree, comparison.report()
    assert comparison.variance is not None and comparison.variance.agree, comparison.report()
