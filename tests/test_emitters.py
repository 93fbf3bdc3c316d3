"""Light sampling: chi-square goodness of fit of next-event directions against their pdf.

For every kind of area light (rectangle, disk, sphere seen from outside and
from inside, a mesh), the constant environment and an image (``envmap``), directions drawn by
``sample_emitter`` from a reference point must follow
``pdf_emitter_direction`` (the density MIS uses for the same light); samples
on the back of a one-sided light are invalid (pdf 0), and their share must
match the missing mass of the pdf. Also: the weight equals Le / pdf.
"""
from pathlib import Path

import numpy as np
import pytest

from pathtracer import load_scene
from pathtracer.emitters.scene_emitters import pdf_emitter_direction, sample_emitter
from pathtracer.scene.load import builtin_scene_path
from pathtracer.shapes.intersect import Hit, intersect
from tests.chi2 import chi2_sphere

pytestmark = pytest.mark.statistical(assertions=1)

SCENE = """<scene version="3.0.0">
  <sensor type="perspective"><float name="fov" value="40"/>
    <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="32"/>
      <rfilter type="box"/></film></sensor>
  {light}
</scene>"""

ENVMAP_IMAGE = Path(builtin_scene_path("envmap")).parent / "envmap-sky.exr"
AREA = '<emitter type="area"><rgb name="radiance" value="2, 3, 4"/></emitter>'
LIGHTS = {
    "rectangle": f"""<shape type="rectangle"><transform name="to_world">
        <scale x="0.7" y="0.3"/><rotate x="1" angle="130"/><rotate z="1" angle="20"/>
        <translate value="0.2, 1.5, -0.3"/></transform>{AREA}</shape>""",
    "disk": f"""<shape type="disk"><transform name="to_world">
        <scale x="0.5" y="0.8"/><rotate x="1" angle="100"/><translate value="-0.3, 1.2, 0.4"/>
        </transform>{AREA}</shape>""",
    "sphere-outside": f"""<shape type="sphere"><point name="center" value="0.3, 2, 0.1"/>
        <float name="radius" value="0.6"/>{AREA}</shape>""",
    "sphere-inside": f"""<shape type="sphere"><point name="center" value="0.2, -0.1, 0.3"/>
        <float name="radius" value="3"/><boolean name="flip_normals" value="true"/>{AREA}</shape>""",
    "cube": f"""<shape type="cube"><transform name="to_world"><scale x="0.3" y="0.5" z="0.2"/>
        <rotate y="1" angle="35"/><translate value="0.1, 1.4, 0.2"/></transform>{AREA}</shape>""",
    "environment": '<emitter type="constant"><rgb name="radiance" value="2, 3, 4"/></emitter>',
    "envmap": f"""<emitter type="envmap"><string name="filename" value="{ENVMAP_IMAGE}"/>
        <transform name="to_world"><rotate x="1" angle="70"/></transform></emitter>""",
}
REFERENCE_POINT = np.array([0.05, -0.2, 0.1])


def reference_hits(count):
    """Reference points as a batch of hits (normal +y, only p and n matter)."""
    p = np.tile(REFERENCE_POINT, (count, 1))
    n = np.tile([0.0, 1.0, 0.0], (count, 1))
    zeros = np.zeros(count)
    return Hit(np.ones(count, bool), zeros, p, n, n, np.zeros(count, np.int32),
               np.zeros(count, np.int64), np.zeros((count, 2)))


@pytest.fixture(params=sorted(LIGHTS))
def light_scene(request, tmp_path):
    path = tmp_path / f"{request.param}.xml"
    path.write_text(SCENE.format(light=LIGHTS[request.param]))
    return request.param, load_scene(str(path))


def test_light_sampling_follows_its_pdf(light_scene):
    name, scene = light_scene

    def sample(u):
        ls = sample_emitter(scene, reference_hits(len(u)), u[:, 2], u[:, :2], test_visibility=False)
        return ls.wo, ls.pdf > 0

    def pdf(v):
        origins = np.tile(REFERENCE_POINT, (len(v), 1))
        return pdf_emitter_direction(scene, origins, intersect(scene, origins, v), v)

    # Bin around the direction to the light's centre, rings concentrated near it.
    probe = sample(np.random.default_rng(1).random((4096, 3)))[0]
    axis = probe.mean(axis=0)
    axis /= np.linalg.norm(axis)
    lowest = float(np.min(probe @ axis))
    if name in ("environment", "envmap", "sphere-inside"):
        edges = None
    else:
        edges = np.concatenate(([-1.0], np.linspace(max(lowest - 0.02, -1.0), 1.0, 13)[:-1], [1.0]))
        edges = np.unique(np.clip(edges, -1, 1))
    result = chi2_sphere(sample, pdf, n_samples=200_000, axis=axis, z_edges=edges, seed=5)
    assert result.passed, result


@pytest.mark.parametrize("name", ["rectangle", "sphere-outside", "cube"])
def test_light_sample_weight_is_radiance_over_pdf(name, tmp_path):
    path = tmp_path / "light.xml"
    path.write_text(SCENE.format(light=LIGHTS[name]))
    scene = load_scene(str(path))
    u = np.random.default_rng(2).random((5000, 3))
    ls = sample_emitter(scene, reference_hits(len(u)), u[:, 2], u[:, :2], test_visibility=False)
    ok = ls.pdf > 0
    assert ok.mean() > (0.05 if name == "cube" else 0.3)   # a cube shows one face here
    np.testing.assert_allclose(ls.weight[ok] * ls.pdf[ok, None], np.tile([2.0, 3.0, 4.0], (ok.sum(), 1)),
                               rtol=1e-9)
    assert np.all(ls.weight[~ok] == 0)
