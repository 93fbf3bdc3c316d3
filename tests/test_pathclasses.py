"""Heckbert path classes: the regex -> DFA compiler, the class-splitting path tracer, and the
classes of light tracing and BDPT (automata read from the light end and joined)."""
import numpy as np
import pytest

from mitsuba_refs.report.wording import verdict_line
from pathtracer import load_scene, render
from pathtracer.core.pathclasses import PathRegexError, compile_class, compile_joined, enumerate_paths, is_partition
from pathtracer.integrators import make_integrator
from pathtracer.integrators.path_letters import bsdf_letter, describe_letters
from pathtracer.integrators.pathclass import PathClassIntegrator
from pathtracer.render.classes import render_classes

PARTITION = ["LE", "LDE", "LD.+E", "LS.*E", "LG.*E"]


@pytest.mark.parametrize("expression, inside, outside", [
    ("LDE", ["LDE"], ["LE", "LDDE", "LSE", "LGE"]),
    ("LDD+E", ["LDDE", "LDDDDE"], ["LDE", "LSDE", "LDSE"]),
    ("LS+DE", ["LSDE", "LSSSDE"], ["LDE", "LSE", "LDSDE"]),
    ("LS*E", ["LE", "LSE", "LSSSE"], ["LDE", "LSDE"]),
    ("L(D|S)*E", ["LE", "LDSDSE", "LSSE"], ["LGE", "LDGE"]),
    ("L.*E", ["LE", "LGDSE"], ["LEE", "DE"]),
    ("L[DG]?S E", ["LSE", "LDSE", "LGSE"], ["LSSE", "LE"]),
    ("LDS*E", ["LDE", "LDSSE"], ["LSDE"]),
])
def test_classes_match_heckbert_strings(expression, inside, outside):
    cls = compile_class(expression)
    for path in inside:
        assert cls.matches(path), (expression, path)
    for path in outside:
        assert not cls.matches(path), (expression, path)


def test_dfa_reads_paths_from_the_eye():
    """The automaton is of the reversed expression: E first, L last."""
    cls = compile_class("LS+DE")
    state = cls.step(np.array([cls.start]), "E")
    for letter in "DSS":
        state = cls.step(state, letter)
    assert cls.accept[cls.step(state, "L")].all()


@pytest.mark.parametrize("bad", ["", "L(DE", "LD)E", "LXE", "*LE", "L[]E"])
def test_malformed_expressions_are_reported(bad):
    with pytest.raises(PathRegexError):
        compile_class(bad)


def test_partition_checker():
    assert is_partition(PARTITION)[0]
    assert is_partition(["LE", "L.E", "L..E", "L...+E"])[0]
    ok, why = is_partition(["LE", "LDE", "L.+E"])
    assert not ok and "LDE" in why


def test_bsdf_letters_and_glossy_folding():
    scene = load_scene("veach-mis", width=8, height=6)
    letters = {bsdf_letter(b) for b in scene.bsdfs}
    assert letters == {"D", "G"}
    folded = {bsdf_letter(b, 0.07) for b in scene.bsdfs}
    assert folded == {"D", "S"}          # alpha 0.01, 0.05 -> S; 0.1, 0.3 -> D
    assert all("->" in line for line in describe_letters(scene))
    caustics = load_scene("cornell-caustics", width=8, height=8)
    assert {bsdf_letter(b) for b in caustics.bsdfs} == {"D", "S"}


@pytest.mark.parametrize("scene_name", ["cornell-caustics", "veach-mis"])
def test_partition_sums_to_the_path_image(scene_name):
    """Same seed: 'L.*E' is the path image bit for bit, and a partition adds up to it."""
    scene = load_scene(scene_name, width=16, height=12)
    full = render(scene, "path", spp=4, seed=5, processes=1, progress=False)
    result = render_classes(scene, ["L.*E"] + PARTITION, spp=4, seed=5, processes=1)
    assert np.array_equal(result["mean"][0], full.mean)
    summed = result["mean"][1:].sum(axis=0)
    assert np.allclose(summed, full.mean, rtol=1e-12, atol=1e-12)
    assert result["mean"][1:].min() >= 0


def test_bounce_classes_partition_the_path_image():
    scene = load_scene("cornell-box", width=12, height=12)
    full = render(scene, "path", spp=3, seed=2, processes=1, progress=False)
    result = render_classes(scene, ["LE", "L.E", "L..E", "L...+E"], spp=3, seed=2, processes=2,
                            batch_size=64)
    assert np.allclose(result["mean"].sum(axis=0), full.mean, rtol=1e-12, atol=1e-12)
    depth2 = render(scene, "path", spp=3, seed=2, processes=1, progress=False, max_depth=2)
    assert np.allclose(result["mean"][:2].sum(axis=0), depth2.mean, rtol=1e-12, atol=1e-12)


def test_single_class_through_the_ordinary_renderer():
    scene = load_scene("cornell-caustics", width=12, height=12)
    caustics = render(scene, PathClassIntegrator("LS+DE"), spp=4, seed=1, processes=1, progress=False)
    split = render_classes(scene, ["LS+DE"], spp=4, seed=1)
    assert np.array_equal(caustics.mean, split["mean"][0])
    assert caustics.options["classes"] == ["LS+DE"]


# ---------------------------------------------------------------------------------------
# light tracing and BDPT: the class automaton read from the light end, and joined

def test_joined_class_accepts_exactly_the_paths_of_the_class():
    """For every split of every path into a light prefix (L first) and a camera prefix
    (E first), the two automata's states join to the class's verdict on the whole path."""
    for expression in ["LS+DE", "LDD+E", "LS*E", "L[DG]?S E", "LD.+E", "L(D|S)*E"]:
        joined = compile_joined(expression)
        for path in enumerate_paths(4):
            for cut in range(1, len(path)):
                light, camera = joined.start, joined.camera.start
                for letter in path[:cut]:
                    light = joined.light_step(light, letter)
                for letter in reversed(path[cut:]):
                    camera = joined.camera_step(camera, letter)
                assert joined.accepts(light, camera) == joined.camera.matches(path), (expression, path, cut)


@pytest.mark.parametrize("integrator", ["light", "bdpt"])
def test_light_and_bdpt_classes_partition_the_render(integrator):
    """Same seed, same random numbers: 'L.*E' is the render bit for bit and the partition's
    class images add up to it (glass and a mirror: S vertices on both subpaths)."""
    scene = load_scene("cornell-caustics", width=8, height=8)
    full = render(scene, make_integrator(integrator, replicas=2), spp=4, seed=3, processes=1)
    everything = render(scene, make_integrator(integrator, replicas=2, paths="L.*E"), spp=4, seed=3,
                        processes=1)
    assert np.array_equal(everything.mean, full.mean)
    parts = [render(scene, make_integrator(integrator, replicas=2, paths=p), spp=4, seed=3, processes=1)
             for p in PARTITION]
    np.testing.assert_allclose(sum(p.mean for p in parts), full.mean, rtol=1e-12, atol=1e-15)
    assert all(p.mean.min() >= 0 for p in parts) and parts[PARTITION.index("LS.*E")].mean.max() > 0
    assert parts[0].options["paths"] == "LE"


#: (integrator, class, what it is compared with): the class images of light tracing and BDPT
#: against the MIS path tracer's. The caustics (LS+DE) reach the path tracer only when a
#: BSDF-sampled ray happens to hit the light through the glass: its estimate is heavy-tailed
#: and its variance estimate unreliable at test spp (64 spp gave 0.0060 against 0.0039 at
#: 256 spp), so light tracing's caustics are compared with BDPT's instead. Light tracing
#: cannot join the camera at a mirror (LD*S+E is 0 for it), BDPT can.
CLASS_CASES = [("light", "LE", "path"), ("light", "LDE", "path"), ("light", "LDD+E", "path"),
               ("bdpt", "LDE", "path"), ("bdpt", "LDD+E", "path"), ("bdpt", "LD*S+E", "path"),
               ("light", "LS+DE", "bdpt")]


@pytest.mark.statistical(assertions=1)
def test_light_and_bdpt_class_images_agree_with_the_path_tracer():
    """Each class image of ``light`` (32 spp) and ``bdpt`` (16 spp) has the mean of the same
    class from ``path --paths`` (64 spp) on the glass-and-mirror box. One assertion of the
    suite's budget: the len(CLASS_CASES) comparisons are tested at ALPHA / len(CLASS_CASES)
    each (Bonferroni). Splatted pixels are correlated: no whole-image components."""
    from mitsuba_refs.stats import compare_means
    from tests.budget import ALPHA
    scene = load_scene("cornell-caustics", width=32, height=32)
    classes = sorted({c for _, c, other in CLASS_CASES if other == "path"})
    path = render_classes(scene, classes, spp=64, seed=11)
    images = {("path", c): (path["mean"][k], path["variance"][k], 64) for k, c in enumerate(classes)}
    renders = {(i, c) for i, c, _ in CLASS_CASES} | {(o, c) for _, c, o in CLASS_CASES if o != "path"}
    for integrator, expression in sorted(renders):
        spp = 32 if integrator == "light" else 16
        r = render(scene, make_integrator(integrator, paths=expression), spp=spp, seed=12, processes=1)
        images[integrator, expression] = (r.mean, r.variance, r.spp)
    failures = []
    for integrator, expression, other in CLASS_CASES:
        verdict = compare_means(*images[integrator, expression], *images[other, expression],
                                alpha=ALPHA / len(CLASS_CASES), image_components=False)
        if not verdict.agree:
            failures.append(f"{integrator} {expression} vs {other}: {verdict_line(verdict)}")
    assert not failures, "\n".join(failures)


@pytest.mark.parametrize("integrator", ["light", "bdpt"])
def test_cli_renders_a_class_with_light_and_bdpt(tmp_path, integrator):
    """``--integrator light|bdpt --paths`` renders the class: the image of the same render
    through the library (float32 in the EXR); a bad expression is one line and exit code 2."""
    from pathtracer.cli import main
    from pathtracer.io.output import read_exr
    out = tmp_path / "class.exr"
    assert main(["render", "cornell-caustics", "-D", "width=8", "-D", "height=8", "--spp", "2",
                 "--seed", "4", "--integrator", integrator, "--paths", "LD+E", "--replicas", "2",
                 "--processes", "1", "--no-progress", "-o", str(out)]) == 0
    scene = load_scene("cornell-caustics", width=8, height=8)
    expected = render(scene, make_integrator(integrator, paths="LD+E", replicas=2), spp=2, seed=4,
                      processes=1)
    assert expected.mean.max() > 0
    np.testing.assert_allclose(read_exr(out).mean, expected.mean, rtol=1e-6, atol=1e-7)
    assert main(["render", "cornell-caustics", "--integrator", integrator, "--paths", "L(S",
                 "-o", str(tmp_path / "bad.exr")]) == 2
