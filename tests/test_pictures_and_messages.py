"""Issue 44's pictures and messages: the variance figure's colour-bar labels clear of the next
panel, the convergence legend in the plot's own quantity (RMSE), the per-bounce line saying its
verdict once, images rendered elsewhere told why convergence and bounces did not run, and a
failing assert_agrees naming its pictures and its seconds without an out_dir."""
from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
import pytest

from mitsuba_refs.cli.main import main
from mitsuba_refs.report import diagnostics
from mitsuba_refs.report.diagnostics import band_label, fit_label
from mitsuba_refs.report.verdicts import bounces_entry, convergence_entry
from mitsuba_refs.report.wording import bounce_verdict
from mitsuba_refs.testing import Disagreement, assert_agrees
from pathtracer import load_scene, render
from pathtracer.io.output import read_exr, write_exr
from tests.budget import ALPHA

SCENE = "cornell-box"


def test_convergence_legend_speaks_of_the_rmse_and_the_renders():
    law = SimpleNamespace(slope=-1.034, slope_ci=(-1.2, -0.9))
    assert fit_label(law) == "fit: RMSE ∝ N^-0.517 [-0.600, -0.450]"
    assert band_label(np.array([1, 4, 16, 64]), np.array([2048, 512, 128, 32])) == \
        "range over the renders (2048 at N=1 to 32 at N=64)"
    assert band_label(np.array([1, 4]), np.array([8, 8])) == "range over 8 renders per N"


def test_variance_figure_keeps_colour_bar_labels_clear_of_the_next_panel(monkeypatch, tmp_path):
    figures = []
    monkeypatch.setattr(diagnostics, "_save", lambda fig, path: figures.append(fig) or str(path))
    rng = np.random.default_rng(3)
    variance = rng.uniform(0.01, 2.0, (32, 32, 3))
    agreement = SimpleNamespace(tile_log_ratio=rng.normal(0, 0.2, (4, 4)), tile=8, agree=True,
                                p_value=0.5, ratio=1.0, ratio_ci=(0.9, 1.1), worst_tile=(0, 0),
                                shape=(32, 32))
    monkeypatch.setattr(diagnostics, "variance_verdict", lambda a: "variance agrees")
    diagnostics.plot_variance_comparison(tmp_path / "v.png", variance, variance * 1.1, agreement, "t")
    figure = figures[0]
    renderer = figure.canvas.get_renderer()
    figure.draw(renderer)
    panels, bars = figure.axes[:3], figure.axes[3:]     # colour bars are added after the panels
    for bar, next_panel in zip(bars, panels[1:]):
        label = bar.yaxis.label.get_window_extent(renderer)
        y_label = next_panel.yaxis.label.get_window_extent(renderer)
        ticks = next_panel.yaxis.get_tightbbox(renderer)
        assert label.x1 < min(y_label.x0, ticks.x0), "a colour bar's label runs into the next panel"
    tile_ticks = [t for t in panels[2].get_yticks() if -0.5 <= t <= 3.5]
    assert all(float(t).is_integer() for t in tile_ticks)


def test_the_bounce_line_says_disagree_and_its_p_value_once():
    class Mean:
        def __init__(self, agree, p):
            self.agree, self.p_value = agree, p

    lines = {1: "agree (p=0.5)", 2: "disagree (p=1.2e-06): image 1.10x too bright"}
    depth, text = bounce_verdict({1: Mean(True, 0.5), 2: Mean(False, 1.2e-06)},
                                 line=lambda m: lines[2 if not m.agree else 1])
    assert depth == 2
    assert text.startswith("direct light (bounce 2) disagrees (p=1.2e-06): image 1.10x too bright")
    assert text.count("p=1.2e-06") == 1 and "disagree (p=" not in text


def test_reasons_given_by_the_check_replace_the_option_names():
    images = SimpleNamespace(convergence=None, bounce_results=None, mean=SimpleNamespace(agree=False),
                             not_run={"convergence": "not run: the images have 1 sample count(s)",
                                      "bounces": "not run: images rendered elsewhere cannot be rendered again"})
    assert "1 sample count" in json.dumps(convergence_entry(images))
    assert "rendered elsewhere" in json.dumps(bounces_entry(images))
    ours = SimpleNamespace(convergence=None, bounce_results=None, mean=SimpleNamespace(agree=False))
    assert "--no-convergence" in json.dumps(convergence_entry(ours))
    assert "--bounces never" in json.dumps(bounces_entry(ours))


@pytest.fixture(scope="module")
def brighter(tmp_path_factory):
    """One 64-spp render of ours, 5 % too bright: a disagreement far beyond chance (p ~ 1e-30)."""
    folder = tmp_path_factory.mktemp("brighter")
    result = render(load_scene(SCENE, width=64, height=64), "path", spp=64, seed=77_000, progress=False)
    path = write_exr(folder / "plain.exr", result)
    result = read_exr(path)
    result.mean = result.mean * 1.05
    return write_exr(folder / "brighter.exr", result)


def test_images_are_told_why_convergence_and_bounces_did_not_run(brighter, tmp_path, capsys):
    code = main(["check", SCENE, "--images", str(brighter), "--out", str(tmp_path / "out"),
                 "--json", str(tmp_path / "r.json")])
    assert code == 1
    record = json.loads((tmp_path / "r.json").read_text())["results"][0]
    text = json.dumps(record)
    assert "--no-convergence" not in text and "--bounces never" not in text, text
    assert "rendered elsewhere" in text and "sample count" in text


def test_a_failing_assert_agrees_names_its_pictures_and_seconds(brighter, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(Disagreement) as raised:
        assert_agrees(SCENE, images=[brighter], convergence=False, alpha=ALPHA)
    text = str(raised.value)
    assert "picture (mean): out/assert_agrees/" in text, text
    assert (tmp_path / raised.value.result.pictures["mean"]).is_file()
    assert raised.value.result.seconds > 0 and "(0.0 s)" not in text
