"""The ceiling of experiments/numpy_ceiling.py is a correct renderer: its Cornell box agrees with
Mitsuba's ``path``, so the rate it reaches is that of a renderer that does the whole work."""
import json

import pytest

from experiments.numpy_ceiling import DiffuseBox, main, render_ceiling
from mitsuba_refs.reference.cache import get_reference
from mitsuba_refs.report.wording import verdict_line
from mitsuba_refs.stats import MeanTestOptions, compare_means
from pathtracer import load_scene
from tests.budget import ALPHA

BOX = {"width": 64, "height": 64}


@pytest.mark.statistical(assertions=1)
def test_ceiling_agrees_with_mitsuba_on_the_cornell_box():
    """The committed Mitsuba reference (4096 spp) against the ceiling at 64 spp, seed 0: the
    suite's tiled mean test at its per-assertion alpha."""
    reference = get_reference("cornell-box", BOX, "path", render=False)
    mean, variance = render_ceiling(load_scene("cornell-box", **BOX), spp=64, seed=0)
    agreement = compare_means(mean, variance, 64, reference.mean, reference.var, reference.n, alpha=ALPHA,
                              options=MeanTestOptions(tile=8))
    assert agreement.agree, verdict_line(agreement)


def test_the_agreement_test_has_the_power_to_reject_a_3_percent_bias():
    """The same comparison rejects the ceiling's image darkened by 3 % (p ~ 1e-12 at these
    seeds; 2 % is at the edge, p ~ 1e-6 against an alpha of 1.8e-6): the agreement above
    rules out biases of that size."""
    mean, variance = render_ceiling(load_scene("cornell-box", **BOX), spp=64, seed=0)
    reference = get_reference("cornell-box", BOX, "path", render=False)
    agreement = compare_means(mean * 0.97, variance, 64, reference.mean, reference.var,
                              reference.n, alpha=ALPHA, options=MeanTestOptions(tile=8))
    assert not agreement.agree


def test_ceiling_lights_are_the_scene_emitters():
    """The ceiling samples the Cornell box's one area light (two triangles, 0.46 x 0.38)."""
    box = DiffuseBox(load_scene("cornell-box", **BOX))
    assert box.is_light.sum() == 2
    assert box.light_area == pytest.approx(0.46 * 0.38, rel=1e-9)


def test_ceiling_refuses_scenes_it_does_not_render():
    """Only diffuse BSDFs: anything else is refused, not rendered wrongly."""
    with pytest.raises(ValueError, match="diffuse"):
        DiffuseBox(load_scene("cornell-caustics", width=8, height=8))


def test_alternation_script_writes_its_rates(tmp_path, capsys):
    """``python -m experiments.numpy_ceiling`` alternates the ceiling and our ``path`` (Mitsuba left
    out here) and writes every round's rate."""
    out = tmp_path / "ceiling.json"
    main(["--resolution", "16", "--spp", "2", "--rounds", "2", "--no-mitsuba", "--core", "-1",
          "--json", str(out)])
    report = json.loads(out.read_text())
    assert set(report["rates"]) == {"ceiling", "path"}
    assert all(len(r) == 2 and min(r) > 0 for r in report["rates"].values())
    assert "path / ceiling" in capsys.readouterr().out
