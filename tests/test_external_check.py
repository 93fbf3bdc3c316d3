"""``mitsuba-refs check``: the command template, the runs and their faults, images rendered
elsewhere, the ``mitsuba_refs.testing`` API and its pytest plugin.

The renderer of the fault tests is ``tests/external/constant_renderer.py`` (standard library,
milliseconds a run); the images of the agreement tests are our own renders written to files,
as a user's cluster job would leave them. Real renderers run in test_external_renderers.py.
"""
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from mitsuba_refs.cli.main import main
from mitsuba_refs.errors import RefsInputError
from mitsuba_refs.external.check import check
from mitsuba_refs.external.renders import check_independent
from mitsuba_refs.external.template import CommandTemplate
from mitsuba_refs.testing import Disagreement, SuiteBudget, assert_agrees
from pathtracer import load_scene, render
from pathtracer.io.output import write_exr
from tests.budget import ALPHA

pytest_plugins = ["pytester"]

ROOT = Path(__file__).resolve().parent.parent
FAKE = f"{sys.executable} {ROOT / 'tests/external/constant_renderer.py'}"
SCENE = "cornell-box"
SIZE = (64, 64)


def fake(extra="", width="{width}"):
    """A template running the constant renderer."""
    return f"{FAKE} --width {width} --height {{height}} --seed {{seed}} --out {{out}} {extra} # {{spp}}"


def run_check(capsys, *args):
    code = main(["check", SCENE, "--no-convergence", "--out", "out/test-check", *args])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


# ---- the template -----------------------------------------------------------------------

def test_template_fills_quoted_values_and_keeps_literal_braces():
    template = CommandTemplate.parse("r --json '{{\"a\": 1}}' {scene} -n {spp} -s {seed} -o {out} {defines}")
    command = template.fill({"scene": "my scene.xml", "spp": 4, "seed": 7, "out": "/tmp/x.exr",
                             "defines": {"width": 64, "name": "two words"}})
    assert command == ("r --json '{\"a\": 1}' 'my scene.xml' -n 4 -s 7 -o /tmp/x.exr "
                       "-D width=64 -D 'name=two words'")
    assert not template.takes_max_depth and not template.writes_variance
    assert CommandTemplate.parse("r {spp} {seed} {out} {max_depth}").takes_max_depth


@pytest.mark.parametrize("text, message", [
    ("r {spp} {seed} {out} {sample_count}", "unknown placeholder {sample_count}"),
    ("r {spp} {out}", "must use {seed}"),
    ("r {spp} {seed} {out:>5}", "may not carry a format"),
    ("r {spp} {seed} {out", "literal braces"),
    ("   ", "empty"),
])
def test_bad_template_is_a_usage_error_before_anything_runs(capsys, text, message):
    code, out, err = run_check(capsys, "--command", text)
    assert code == 2 and out == ""
    assert message in err and len(err.strip().splitlines()) == 1


# ---- runs that fail ---------------------------------------------------------------------

def test_failing_command_names_its_exit_code_and_last_stderr_line(capsys):
    code, _, err = run_check(capsys, "--command", fake("--exit 3"))
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert "exited with code 3" in err and "constant_renderer: failing on purpose" in err


def test_command_writing_no_image(capsys):
    code, _, err = run_check(capsys, "--command", "true {spp} {seed} {out}")
    assert code == 2 and "wrote no image to" in err and err.count("\n") == 1


def test_timeout_kills_the_whole_process_group(capsys):
    marker = 97.25      # the sleep of the renderer and of the child it starts
    code, _, err = run_check(capsys, "--command", fake(f"--sleep {marker}"), "--timeout", "1.5", "--jobs", "1")
    assert code == 2 and "timed out after 1.5 s" in err and "process group" in err
    left = subprocess.run(["pgrep", "-f", f"time.sleep\\({marker}\\)"], capture_output=True, text=True)
    assert left.stdout == "", "a child of the timed-out run outlived its check"


def test_image_of_the_wrong_size(capsys):
    code, _, err = run_check(capsys, "--command", fake("--noise 1", width="32"))
    assert code == 2 and "wrote a 32x64 image; the scene's film is 64x64" in err


def test_renderer_ignoring_its_seed_is_refused(capsys):
    ignoring = f"{FAKE} --width {{width}} --height {{height}} --seed 5 --noise 1 --out {{out}} # {{spp}} {{seed}}"
    code, _, err = run_check(capsys, "--command", ignoring)
    assert code == 2 and "identical images" in err and "ignores {seed}" in err


@pytest.mark.parametrize("value, what", [("nan", "NaN"), ("inf", "Inf"), ("-0.5", "negative")])
def test_impossible_values_disagree_saying_what_was_wrong(capsys, value, what):
    code, out, err = run_check(capsys, "--command", fake(f"--value {value}"))
    assert code == 1, err
    assert "DISAGREES" in out and what in out and "impossible values" in out


def test_replicas_sharing_their_noise_are_refused():
    rng = np.random.default_rng(1)
    shared = rng.random((1, 32, 32, 3))
    independent = rng.random((8, 32, 32, 3))
    check_independent(independent)                           # near 0: accepted
    leaky = independent.copy()
    leaky[3] = 0.3 * leaky[3] + 0.7 * leaky[5]               # replica 4 mostly copies replica 6
    with pytest.raises(RefsInputError, match="images 4 and 6 are not independent"):
        check_independent(leaky)
    del shared


def test_ctrl_c_kills_every_run_and_leaves_no_temporary_files(tmp_path):
    marker = 96.75
    env = dict(os.environ, TMPDIR=str(tmp_path))
    process = subprocess.Popen(
        [sys.executable, "-m", "mitsuba_refs.cli.main", "check", SCENE, "--no-convergence",
         "--out", str(tmp_path / "out"), "--command", fake(f"--sleep {marker}")],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.monotonic() + 60
    while subprocess.run(["pgrep", "-f", f"time.sleep\\({marker}\\)"], capture_output=True).returncode:
        assert time.monotonic() < deadline and process.poll() is None, process.communicate()
        time.sleep(0.05)
    process.send_signal(signal.SIGINT)
    out, err = process.communicate(timeout=60)
    assert process.returncode == 130, err
    assert err.strip().splitlines()[-1] == "mitsuba-refs: interrupted"
    left = subprocess.run(["pgrep", "-f", f"sleep.*{marker}"], capture_output=True, text=True)
    assert left.stdout == ""
    assert not list(tmp_path.glob("mitsuba-refs-check-*"))


# ---- images rendered elsewhere ----------------------------------------------------------

@pytest.fixture(scope="module")
def rendered(tmp_path_factory):
    """Our path tracer's renders as files: one with variance channels at 64 spp, and the
    convergence ladder 4, 16, 64 with equal work (16, 4 and 1 images)."""
    folder = tmp_path_factory.mktemp("images")
    scene = load_scene(SCENE, width=SIZE[0], height=SIZE[1])
    files = []
    for spp, count in ((4, 16), (16, 4), (64, 1)):
        for k in range(count):
            result = render(scene, "path", spp=spp, seed=50_000 + 1000 * spp + k, progress=False)
            files.append(write_exr(folder / f"render-{spp:03d}-{k:02d}.exr", result))
    return folder, files


@pytest.mark.statistical(assertions=3)
def test_images_with_variance_channels_agree_in_mean_variance_and_convergence(rendered):
    folder, _ = rendered
    result = check(SCENE, images=str(folder / "render-*.exr"), same_estimator=True, alpha=ALPHA)
    assert result.agree, result.report()
    assert result.variance is not None and result.variance.agree
    assert result.ladder == (4, 16, 64) and result.convergence.passed
    # The same images through the API: the same, deterministic, verdicts (no new risk).
    again = assert_agrees(SCENE, images=str(folder / "render-*.exr"), same_estimator=True,
                          alpha=ALPHA)
    assert again.mean.p_value == result.mean.p_value


def test_images_scaled_by_5_percent_raise_a_disagreement(rendered, tmp_path):
    """Power: +5 % is many standard errors at 64 spp (p ~ 1e-30), not a false-failure risk."""
    _, files = rendered
    brighter = tmp_path / "brighter.exr"
    from pathtracer.io.output import read_exr
    result = read_exr(files[-1])
    result.mean = result.mean * 1.05
    write_exr(brighter, result)
    with pytest.raises(Disagreement) as raised:
        assert_agrees(SCENE, images=[brighter], convergence=False, alpha=ALPHA, out_dir=tmp_path)
    text = str(raised.value)
    assert "DISAGREES" in text and "picture (mean)" in text, text
    assert raised.value.result.mean.rel_bias_ci[0] > 0.03, text


def test_name_heads_the_verdicts_records_and_pictures(rendered, tmp_path, capsys):
    """``--name``: the report, the JSON and JUnit records and the picture files speak of the
    renderer by it, and the record keeps what was judged (power, as above: +5 %)."""
    _, files = rendered
    from pathtracer.io.output import read_exr
    result = read_exr(files[-1])
    result.mean = result.mean * 1.05
    write_exr(tmp_path / "brighter.exr", result)
    code = main(["check", SCENE, "--no-convergence", "--name", "my tracer", "--images",
                 str(tmp_path / "brighter.exr"), "--out", str(tmp_path / "out"),
                 "--json", str(tmp_path / "r.json"), "--junit", str(tmp_path / "j.xml")])
    assert code == 1
    assert "my tracer" in capsys.readouterr().out
    record = json.loads((tmp_path / "r.json").read_text())["results"][0]
    assert (record["renderer"], record["integrator"]) == ("my tracer", "my tracer")
    assert record["command"] == f"images: {tmp_path / 'brighter.exr'}"
    assert all("my_tracer" in Path(path).name for path in record["pictures"].values())
    assert "::my tracer" in (tmp_path / "j.xml").read_text()


def test_variance_without_same_estimator_says_its_real_reason(rendered):
    """Not "Mitsuba has no run of this estimator" (it has: the file's path), but the missing
    --same-estimator; the ratio is still printed. Deterministic words, no statistical risk."""
    folder, _ = rendered
    result = check(SCENE, images=str(folder / "render-064-*.exr"), convergence=False,
                   alpha=ALPHA)
    line = next(line for line in result.report().splitlines() if "variance:" in line)
    assert "not applicable: --same-estimator was not given" in line, line
    assert "the per-sample variance is" in line and "no run of this estimator" not in line, line


@pytest.mark.statistical(assertions=2)
def test_stratified_images_pass_convergence_and_lose_only_the_variance_verdict(rendered, tmp_path):
    """Images of a renderer whose error falls as N^-1 (RMSE, the rate of jittered samples on a
    smooth 2-D integrand): our renders with their deviation from the reference shrunk by
    (spp / 4)^-1/2, as stratified samples would, and
    their variance channels kept. The convergence verdict passes and says so, the variance
    verdict is "not applicable" (not a disagreement), and the mean test, which took the
    overstated per-sample variance, is conservative, which a note says. Two assertions at
    ALPHA: the mean agrees; the faster fall is seen (MSE slope -2 against -1, from 16, 4 and 1
    images at 4, 16, 64 spp: measured -2.32 [-2.62, -2.02], faster p = 2.3e-8, below the level
    1.75e-6; a shrink of (spp / 4)^-1/4, slope -1.69 [-1.92, -1.45], gave only 3.5e-6)."""
    from mitsuba_refs.reference.cache import get_reference
    from mitsuba_refs.verdicts.scenes import default_params
    from pathtracer.io.output import read_exr
    _, files = rendered
    reference = get_reference(SCENE, default_params(SCENE), "path", render=False)
    for file in files:
        image = read_exr(file)
        shrink = (image.spp / 4) ** -0.5
        image.mean = (reference.mean + (image.mean - reference.mean) * shrink).astype(np.float32)
        write_exr(tmp_path / file.name, image)
    result = check(SCENE, images=str(tmp_path / "render-*.exr"), same_estimator=True, alpha=ALPHA)
    report = result.report()
    law = result.convergence
    assert result.mean.agree and law is not None and law.passed and law.faster, report
    assert result.variance is None and result.agree, report
    assert "not applicable: the renderer's samples are not independent within a pixel" in report
    assert "error (RMSE) falls as N^-" in report and "faster than independent samples" in report
    assert any("overstates the noise of stratified samples" in note for note in result.notes)
    from mitsuba_refs.report.verdicts import verdict_entries
    entries = verdict_entries(result)
    assert entries["variance"]["status"] == "not compared" and not entries["variance"]["applicable"]
    assert entries["convergence"]["faster"] and entries["convergence"]["agree"]


def _pfm(path, image, spp):
    height, width, _ = image.shape
    with open(path, "wb") as out:
        out.write(f"PF\n{width} {height}\n-1.0\n".encode())
        out.write(np.ascontiguousarray(image[::-1], dtype="<f4").tobytes())
    Path(f"{path}.json").write_text(json.dumps({"spp": spp}))


def test_eight_replicas_without_variance_give_mean_and_variance(tmp_path):
    """Mean-only PFMs with sidecars: the variance comes from their spread."""
    scene = load_scene(SCENE, width=SIZE[0], height=SIZE[1])
    for k in range(8):
        result = render(scene, "path", spp=8, seed=70_000 + k, progress=False)
        _pfm(tmp_path / f"replica-{k}.pfm", result.mean, 8)
    result = check(SCENE, images=str(tmp_path / "replica-*.pfm"), same_estimator=True,
                   convergence=False, alpha=ALPHA)
    assert result.spp == 64 and result.variance is not None
    # The variance of 8-spp replicas' spread is the per-sample variance: near Mitsuba's.
    assert 0.8 < result.variance.ratio < 1.25, result.report()
    (tmp_path / "replica-7.pfm").unlink()
    with pytest.raises(RefsInputError, match=">= 8 independent replicas"):
        check(SCENE, images=str(tmp_path / "replica-*.pfm"), convergence=False)


def test_bad_image_sets_are_refused_in_one_line(rendered, tmp_path, capsys):
    folder, files = rendered
    twin = tmp_path / "twin.exr"
    twin.write_bytes(files[-1].read_bytes())
    cases = [
        ([str(files[-1]), str(twin)], "are identical"),
        ([str(tmp_path / "none-*.exr")], "no file matches"),
        ([str(tmp_path / "missing.exr")], "missing.exr"),
    ]
    small = tmp_path / "small.pfm"
    _pfm(small, np.ones((8, 8, 3)), 4)
    cases.append(([str(small)], "the image is 8x8, the scene's film is 64x64"))
    nospp = tmp_path / "nospp.pfm"
    _pfm(nospp, np.ones((64, 64, 3)), 4)
    Path(f"{nospp}.json").unlink()
    cases.append(([str(nospp)], "no sample count"))
    for images, message in cases:
        code = main(["check", SCENE, "--out", str(tmp_path / "out"), "--images", *images])
        err = capsys.readouterr().err
        assert code == 2 and message in err and len(err.strip().splitlines()) == 1, (images, err)


# ---- the suite budget and the pytest plugin ----------------------------------------------

def test_suite_budget_splits_over_checks_and_verdicts():
    budget = SuiteBudget(1e-3, 5)
    assert budget.alpha == pytest.approx(1e-3 / 15)
    assert "shared by 5 check(s)" in budget.describe()


def test_pytest_plugin_counts_the_checks_and_sets_their_level(pytester, rendered):
    """Three checks share the budget 9 ALPHA, so each verdict runs at ALPHA. The inner check
    judges the 64-spp image of the images test above: the same verdict, no new risk."""
    folder, _ = rendered
    budget = 9 * ALPHA
    pytester.makepyfile(f"""
        import pytest

        def test_level(mitsuba_refs):
            assert mitsuba_refs.alpha == pytest.approx({ALPHA!r})

        @pytest.mark.mitsuba_refs(checks=2)
        def test_images(mitsuba_refs):
            result = mitsuba_refs.assert_agrees({SCENE!r}, images={str(folder / 'render-064-*.exr')!r},
                                                convergence=False)
            assert result.mean.alpha == pytest.approx({ALPHA!r})
    """)
    outcome = pytester.runpytest("--mitsuba-refs-budget", repr(budget), "-p", "no:cacheprovider")
    outcome.assert_outcomes(passed=2)
    outcome.stdout.fnmatch_lines([f"*suite false-failure budget {budget:g} shared by 3 check(s)*"])


def test_bounces_always_needs_max_depth_in_the_command(capsys):
    code = main(["check", SCENE, "--bounces", "always", "--out", "out/test-check",
                 "--command", fake()])
    err = capsys.readouterr().err
    assert code == 2 and "--bounces always needs {max_depth}" in err and err.count("\n") == 1
