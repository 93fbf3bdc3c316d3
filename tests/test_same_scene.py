"""Both renderers render the same light transport, film and framing of a user's scene file.

The tracer's loader is the one source of truth: a literal ``max_depth`` in the file's
``<integrator>``, a ``$param`` filled by ``-D``, and an override (``--max-depth``,
``options=``) must reach the Mitsuba reference exactly as they reach the tracer; so must
``--resolution`` / ``--spp``, whatever the file says. The scene (tests/data/literal_depth.xml)
writes its depth, film size and sample count literally, as most upstream scenes do.

Tests marked ``mitsuba`` render with a live Mitsuba (tiny films, a few hundred samples).
"""
import re
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from mitsuba_refs.reference.batch import SampleStatistics, copies_per_call
from mitsuba_refs.reference.cache import _identity, reference_key, reference_stem
from mitsuba_refs.report.wording import verdict_line
from pathtracer import SceneError, load_scene
from pathtracer.render.driver import integrator_for
from pathtracer.scene.load import parse_resolution
from pathtracer.scene.settings import scene_settings
from pathtracer.sensors.perspective_sensor import x_fov_from
from tests.budget import ALPHA

SCENE = Path(__file__).resolve().parent / "data" / "literal_depth.xml"
TRANSPORT = ("max_depth", "rr_depth", "hide_emitters")


def variant_of_scene(tmp_path, old, new, name="variant.xml"):
    """A copy of the test scene with one piece of text replaced (same folder layout)."""
    text = SCENE.read_text()
    assert old in text
    path = tmp_path / name
    path.write_text(text.replace(old, new))
    return path


def tracer_transport(path, params=None, **options):
    """max_depth, rr_depth, hide_emitters the tracer renders ``path`` with."""
    integrator = integrator_for(load_scene(path, **(params or {})), "path", **options)
    return {k: getattr(integrator, k) for k in TRANSPORT}


def reference_transport(path, params=None, **options):
    """The same three as the Mitsuba reference's integrator dictionary has them
    (Mitsuba's defaults where the dictionary leaves one out)."""
    nested = _identity(path, params or {}, "path", 16, 1, options or None)["mitsuba_integrator"]
    assert nested["type"] == "path"
    return {"max_depth": nested.get("max_depth", -1), "rr_depth": nested.get("rr_depth", 5),
            "hide_emitters": nested.get("hide_emitters", False)}


def test_literal_integrator_options_reach_both_sides(tmp_path):
    path = variant_of_scene(tmp_path, '<integer name="max_depth" value="2"/>',
                            '<integer name="max_depth" value="2"/><integer name="rr_depth" value="3"/>'
                            '<boolean name="hide_emitters" value="true"/>')
    want = {"max_depth": 2, "rr_depth": 3, "hide_emitters": True}
    assert tracer_transport(path) == want
    assert reference_transport(path) == want
    assert tracer_transport(SCENE)["max_depth"] == reference_transport(SCENE)["max_depth"] == 2


def test_param_and_default_reach_both_sides(tmp_path):
    path = variant_of_scene(tmp_path, '<integer name="max_depth" value="2"/>',
                            '<integer name="max_depth" value="$depth"/>')
    path.write_text(path.read_text().replace('<default name="albedo" value="0.8"/>',
                                             '<default name="albedo" value="0.8"/>'
                                             '<default name="depth" value="4"/>'))
    assert tracer_transport(path)["max_depth"] == reference_transport(path)["max_depth"] == 4
    given = {"depth": "3"}
    assert tracer_transport(path, given)["max_depth"] == reference_transport(path, given)["max_depth"] == 3


def test_override_reaches_both_sides():
    assert tracer_transport(SCENE, max_depth=5, rr_depth=7) == \
        reference_transport(SCENE, max_depth=5, rr_depth=7) == \
        {"max_depth": 5, "rr_depth": 7, "hide_emitters": False}


def test_undeclared_define_is_an_error_on_both_sides():
    """-D max_depth on a file whose depth is literal would reach one side only: refused."""
    with pytest.raises(SceneError, match=r"literal_depth.xml:\d+: <scene>: parameter\(s\) max_depth "
                                         r"not declared.*--max-depth"):
        load_scene(SCENE, max_depth=3)
    with pytest.raises(SceneError, match="max_depth not declared"):
        reference_key(SCENE, {"max_depth": 3}, "path", 16, 1)


def test_undeclared_define_exits_2_from_both_command_lines(tmp_path, capsys):
    from mitsuba_refs.cli.main import main as refs_main
    from pathtracer.cli import main as tracer_main
    assert tracer_main(["render", str(SCENE), "-D", "max_depth=3", "-o", str(tmp_path / "a.exr")]) == 2
    assert refs_main(["compare", str(SCENE), "-D", "max_depth=3", "--out", str(tmp_path)]) == 2
    lines = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert len(lines) == 2 and all("max_depth not declared" in line for line in lines)


def test_resolution_and_spp_override_literal_and_param_films(tmp_path):
    scene = load_scene(SCENE, resolution=(16, 9), sample_count=3)
    assert (scene.camera.width, scene.camera.height, scene.spp) == (16, 9, 3)
    # fov_axis "smaller" keeps its meaning at the new aspect, as Mitsuba's sensor does
    assert scene.camera.x_fov == pytest.approx(x_fov_from(45.0, "smaller", 16 / 9))
    assert scene.camera.x_fov != pytest.approx(load_scene(SCENE).camera.x_fov)
    param_film = variant_of_scene(tmp_path, '<integer name="width" value="32"/>',
                                  '<integer name="width" value="$w"/>')
    param_film.write_text(param_film.read_text().replace(
        '<default name="albedo" value="0.8"/>',
        '<default name="albedo" value="0.8"/><default name="w" value="40"/>'))
    settings = scene_settings(param_film, resolution=(12, 20), sample_count=5, w=50)
    assert settings.resolution == (12, 20) and settings.spp == 5
    assert settings.camera.x_fov == pytest.approx(x_fov_from(45.0, "smaller", 12 / 20))
    assert scene_settings(param_film, w=50).resolution == (50, 24)
    with pytest.raises(SceneError, match="resolution must be positive"):
        load_scene(SCENE, resolution=(0, 4))


def test_resolution_and_options_are_part_of_the_reference_identity():
    plain = reference_key(SCENE, {}, "path", 16, 1)
    small = reference_key(SCENE, {}, "path", 16, 1, resolution=(16, 9))
    deeper = reference_key(SCENE, {}, "path", 16, 1, options={"max_depth": 3})
    assert len({plain, small, deeper}) == 3
    assert _identity(SCENE, {}, "path", 16, 1, None, (16, 9))["resolution"] == [16, 9]
    assert "resolution" not in _identity(SCENE, {}, "path", 16, 1)
    assert "__16x9__" in reference_stem(SCENE, {}, "path", 16, 1, resolution=(16, 9))
    assert "__set-max_depth-3__" in reference_stem(SCENE, {}, "path", 16, 1, {"max_depth": 3})


def test_resolution_option_of_the_command_lines(tmp_path, capsys):
    from pathtracer.cli import main as tracer_main
    out = tmp_path / "small.exr"
    assert tracer_main(["render", str(SCENE), "--resolution", "8x6", "--spp", "2", "--processes", "1",
                        "--no-progress", "-o", str(out)]) == 0
    assert re.search(r"8x6 at 2 spp", capsys.readouterr().out)
    with pytest.raises(SystemExit) as exit_info:
        tracer_main(["render", str(SCENE), "--resolution", "8by6", "-o", str(out)])
    assert exit_info.value.code == 2
    assert parse_resolution("64x48") == (64, 48)
    with pytest.raises(ValueError, match="WIDTHxHEIGHT"):
        parse_resolution("64")


def test_sample_statistics_merge_equals_one_pass():
    rng = np.random.default_rng(3)
    samples = rng.exponential(size=(3, 37, 4, 3))
    acc = SampleStatistics()
    for begin, end in ((0, 5), (5, 6), (6, 30), (30, 37)):
        acc.add(samples[:, begin:end])
    assert acc.n == 37
    np.testing.assert_allclose(acc.mean, samples.mean(axis=1), rtol=1e-12)
    np.testing.assert_allclose(acc.variance(), samples.var(axis=1, ddof=1), rtol=1e-10)
    constant = SampleStatistics()
    for _ in range(3):
        constant.add(np.full((2, 5, 2, 3), 0.1))
    assert not constant.variance().any()       # exactly zero where all samples agree
    for spp, size in ((4096, (64, 64)), (100, (64, 64)), (3, (512, 512)), (1, (8, 8))):
        k, calls = copies_per_call(spp, *size)
        assert k * calls >= spp and k * (calls - 1) < spp and k * size[0] * size[1] <= max(
            1 << 18, size[0] * size[1])


# ------------------------------------------------------------------ live Mitsuba

@pytest.fixture
def mitsuba_variant(mi):
    """scalar_rgb: the variant a user without LLVM gets, where the fast reference path
    matters; it needs no JIT compilation, so these tests take seconds."""
    from mitsuba_refs.reference.variant import set_variant
    return set_variant("scalar_rgb")[0]


def our_render(path, resolution, spp, seed, **options):
    from pathtracer import render
    result = render(load_scene(path, resolution=resolution), "path", spp=spp, seed=seed,
                    processes=1, progress=False, **options)
    return result.mean, result.variance


@pytest.mark.mitsuba
@pytest.mark.statistical(assertions=1)
def test_literal_depth_agrees_live_at_a_non_square_override(mitsuba_variant):
    """The issue's wrong verdict: a literal max_depth 2 reached the tracer but not the
    reference (judged 23 % too dark). Now both render depth 2, at an override film whose
    aspect (24x10) differs from the file's 32x24, so the framing (fov_axis "smaller") is
    tested too. The reference at unlimited depth, what was rendered before, must disagree."""
    from mitsuba_refs.reference.render import render_reference
    from mitsuba_refs.stats import compare_means
    size, spp_ref, spp = (24, 10), 1024, 64
    ref = render_reference(SCENE, {}, "path", spp_ref, 5, variant=mitsuba_variant, resolution=size)
    assert ref.metadata["mitsuba_integrator"] == {"type": "path", "max_depth": 2}
    assert (ref.metadata["width"], ref.metadata["height"]) == size and ref.mean.shape == (10, 24, 3)
    mean, var = our_render(SCENE, size, spp, 9)
    verdict = compare_means(mean, var, spp, ref.mean, ref.var, ref.n, alpha=ALPHA)
    assert verdict.agree, verdict_line(verdict)
    old = render_reference(SCENE, {}, "path", 256, 6, variant=mitsuba_variant, resolution=size,
                           options={"max_depth": -1})
    assert not compare_means(mean, var, spp, old.mean, old.var, old.n, alpha=ALPHA).agree


@pytest.mark.mitsuba
@pytest.mark.parametrize("size", [(20, 10), (10, 20)])
def test_override_keeps_fov_axis_meaning_in_mitsuba(tmp_path, mitsuba_variant, size):
    """Mitsuba's own sensor, made from the edited scene description, has the tracer's
    horizontal field of view at the new aspect for every fov_axis (exact, no sampling)."""
    import mitsuba as mi

    from mitsuba_refs.reference.render import load_mitsuba_scene
    for axis in ("x", "y", "smaller", "larger", "diagonal"):
        path = variant_of_scene(tmp_path, 'value="smaller"', f'value="{axis}"', f"{axis}.xml")
        mi_scene = load_mitsuba_scene(path, {}, size)
        sensor = mi_scene.sensors()[0]
        assert tuple(int(v) for v in sensor.film().crop_size()) == size
        theirs = float(np.ravel(np.array(mi.traverse(sensor)["x_fov"]))[0])
        ours = scene_settings(path, resolution=size).camera.x_fov
        assert theirs == pytest.approx(ours, rel=1e-5), axis


@pytest.mark.mitsuba
def test_batch_method_matches_moment_wrapper_live(mitsuba_variant):
    """The fast reference (single samples of a batch of camera copies) has the mean and the
    per-sample variance of the rgb_moments wrapper it replaces (independent seeds)."""
    from mitsuba_refs.reference.render import render_reference
    spp, size = 256, (16, 12)
    fast = render_reference(SCENE, {}, "path", spp, 21, variant=mitsuba_variant, resolution=size,
                            method="batch")
    slow = render_reference(SCENE, {}, "path", spp, 22, variant=mitsuba_variant, resolution=size,
                            method="moments")
    assert fast.n == slow.n == spp and fast.metadata["method"] == "batch"
    threshold = stats.norm.isf(ALPHA / 2)
    z_mean = (fast.mean.sum() - slow.mean.sum()) / np.sqrt((fast.var.sum() + slow.var.sum()) / spp)
    assert abs(z_mean) < threshold
    # per-sample variances: the mean over pixels of their difference, with its standard error
    diff = (fast.var - slow.var).ravel()
    z_var = diff.mean() / (diff.std(ddof=1) / np.sqrt(diff.size))
    assert abs(z_var) < threshold
