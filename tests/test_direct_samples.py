"""``direct`` with ``emitter_samples`` N and ``bsdf_samples`` M (Mitsuba's multi-sample MIS)."""
from __future__ import annotations

import numpy as np
import pytest

from pathtracer import load_scene, make_integrator, render
from pathtracer.scene.errors import SceneError

SMALL = dict(width=16, height=12)


def image_mean(result):
    """Mean over the image and its standard error (pixels are independent)."""
    n_pixels = result.mean.shape[0] * result.mean.shape[1]
    se = np.sqrt(result.variance.sum(axis=(0, 1)) / result.spp) / n_pixels
    return result.mean.mean(axis=(0, 1)), se


def direct(scene, spp=16, seed=1, **counts):
    return render(scene, make_integrator("direct", **counts), spp=spp, seed=seed, processes=1,
                  progress=False)


def test_default_counts_are_one_each():
    scene = load_scene("quad-light", **SMALL)
    default = direct(scene, spp=2)
    explicit = direct(scene, spp=2, emitter_samples=1, bsdf_samples=1)
    np.testing.assert_array_equal(default.mean, explicit.mean)
    assert make_integrator("direct", shading_samples=3).options()["bsdf_samples"] == 3


@pytest.mark.parametrize("counts", [dict(emitter_samples=3, bsdf_samples=2),
                                    dict(emitter_samples=0, bsdf_samples=2),
                                    dict(emitter_samples=2, bsdf_samples=0)])
def test_any_counts_estimate_the_same_mean_with_an_area_light(counts):
    scene = load_scene("quad-light", **SMALL)
    reference, se_ref = image_mean(direct(scene, spp=32, seed=2))
    mean, se = image_mean(direct(scene, spp=32, seed=3, **counts))
    z = np.abs(mean - reference) / np.sqrt(se ** 2 + se_ref ** 2)
    assert np.all(z < 4), (mean, reference, z)


def test_point_light_samples_are_not_divided_by_their_count():
    """Mitsuba 3.9.1 weights each sample of a Dirac light by 1, not 1/N: N light
    samples count a point light N times. The light sample is deterministic, so
    the image is exactly N times the N = 1 image."""
    scene = load_scene("point-light", **SMALL)
    one = direct(scene, spp=2, emitter_samples=1)
    three = direct(scene, spp=2, emitter_samples=3)
    np.testing.assert_allclose(three.mean, 3 * one.mean, rtol=1e-12, atol=0)


def test_invalid_counts(tmp_path):
    with pytest.raises(ValueError, match="at least one"):
        make_integrator("direct", emitter_samples=0, bsdf_samples=0)
    with pytest.raises(ValueError, match="either shading_samples"):
        make_integrator("direct", shading_samples=2, emitter_samples=1)
    path = tmp_path / "s.xml"
    path.write_text('<scene version="3.0.0"><integrator type="direct">\n'
                    '<integer name="emitter_samples" value="-1"/></integrator>'
                    '<sensor type="perspective"><film type="hdrfilm"><rfilter type="box"/></film>'
                    '</sensor></scene>')
    with pytest.raises(SceneError, match=r's.xml:2: <integrator type="direct">: emitter_samples'):
        load_scene(str(path))


MITSUBA_SCENE = """<scene version="3.0.0">
    <integrator type="direct"><integer name="emitter_samples" value="{n}"/>
        <integer name="bsdf_samples" value="{m}"/></integrator>
    <sensor type="perspective"><float name="fov" value="40"/>
        <transform name="to_world"><lookat origin="0,-2,2" target="0,0,0" up="0,0,1"/></transform>
        <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/>
            <rfilter type="box"/></film>
        <sampler type="independent"><integer name="sample_count" value="64"/></sampler></sensor>
    <shape type="rectangle"><transform name="to_world"><scale value="3"/></transform>
        <bsdf type="roughconductor"><float name="alpha" value="0.3"/></bsdf></shape>
    <shape type="rectangle"><transform name="to_world"><scale value="0.3"/><rotate x="1" angle="180"/>
        <translate z="1"/></transform><emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>
    <emitter type="point"><point name="position" x="0.5" y="0" z="0.5"/>
        <rgb name="intensity" value="0.2"/></emitter>
</scene>"""


@pytest.mark.mitsuba
@pytest.mark.parametrize("n, m", [(3, 2), (0, 2), (2, 0)])
def test_matches_mitsuba(tmp_path, n, m, mi):
    """Area light + point light over a glossy plane: image means agree with Mitsuba's."""
    path = tmp_path / "direct.xml"
    path.write_text(MITSUBA_SCENE.format(n=n, m=m))
    theirs = np.asarray(mi.render(mi.load_file(str(path)), seed=5), dtype=float).mean(axis=(0, 1))
    ours, se = image_mean(render(load_scene(str(path)), seed=4, processes=1, progress=False))
    # Both are the same estimator with the same sample count: their standard errors agree.
    z = np.abs(ours - theirs[:3]) / (np.sqrt(2) * se)
    assert np.all(z < 4), (ours, theirs, z)


def test_references_render_the_files_sample_counts(tmp_path):
    """mitsuba-refs renders a direct reference with the counts the tracer's direct uses: the
    file's when its integrator is direct, else 1 each (mitsuba-data's scenes/hello.xml, with
    4 emitter and 0 BSDF samples and point lights, was 4.01x too bright against a 1/1
    reference)."""
    from mitsuba_refs.reference.render import integrator_dict
    from pathtracer.scene.types import IntegratorSpec
    file_direct = IntegratorSpec("direct", {"emitter_samples": 4, "bsdf_samples": 0})
    assert integrator_dict("direct", {}, file_direct) == {
        "type": "direct", "emitter_samples": 4, "bsdf_samples": 0}
    assert integrator_dict("direct", {}, IntegratorSpec("direct", {"shading_samples": 3})) == {
        "type": "direct", "emitter_samples": 3, "bsdf_samples": 3}
    for other in (None, IntegratorSpec("path", {"max_depth": 3})):
        assert integrator_dict("direct", {}, other) == {
            "type": "direct", "emitter_samples": 1, "bsdf_samples": 1}
