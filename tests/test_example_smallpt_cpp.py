"""The example external renderer, examples/smallpt-cpp: a C++ smallpt that users copy.

Built here with the system C++ compiler (skipped without one), it must render the
built-in ``smallpt`` scene's expected image: the same as our ``smallpt`` integrator's
(at unlimited depth and at max_depth 1, 2, 3) and Mitsuba's committed ``path_bsdf``
reference. Its two injected bugs must be rejected against that reference. The helpers
(build, PFM reader, renders, comparisons) are examples/smallpt-cpp/verify.py's, which
runs the same comparisons with more samples.

Cost: about 15 s of one core (build 2 s, C++ renders 8 s, ours 4 s).
"""
import importlib.util
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from mitsuba_refs.report.wording import verdict_line
from tests.budget import ALPHA

ROOT = Path(__file__).resolve().parent.parent
pytestmark = pytest.mark.skipif(shutil.which("c++") is None, reason="no C++ compiler (c++) on PATH")


def _load_verify():
    spec = importlib.util.spec_from_file_location("smallpt_cpp_verify", ROOT / "examples/smallpt-cpp/verify.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


verify = _load_verify()

#: C++ samples per pixel for the unlimited-depth renders: enough that both bugs are
#: rejected against the 4096-spp reference with p < 1e-15 (roulette: -2 % bias).
SPP = 256
#: Our renders and the max_depth renders (8 x 8 tiles then hold 4096 samples).
OURS_SPP = 64


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    return tmp_path_factory.mktemp("smallpt-cpp")


@pytest.fixture(scope="module")
def binary(workdir):
    return verify.build(workdir)


@pytest.fixture(scope="module")
def reference():
    return verify.mitsuba_reference("path_bsdf")


@pytest.fixture(scope="module")
def correct(binary, workdir):
    return verify.render_cpp(binary, workdir, SPP, seed=1)


def run(binary, *args):
    return subprocess.run([str(binary), *map(str, args)], capture_output=True, text=True)


# ---- command line ---------------------------------------------------------------------

@pytest.mark.parametrize("args", [
    ["--bug", "no-such-bug"],
    ["--spp", "0"],
    ["--spp", "12x"],
    ["--width", "-3"],
    ["--max-depth", "-2"],
    ["--seed", "-1"],
    ["--threads", "0"],
    ["--frobnicate", "1"],
    ["--variance", "v.pfm", "--spp", "1"],
])
def test_bad_arguments_exit_2_with_one_line(binary, tmp_path, args):
    base = {"--width": 4, "--height": 3, "--spp": 2, "--seed": 0, "--out": tmp_path / "a.pfm"}
    argv = [str(a) for kv in base.items() for a in kv]
    result = run(binary, *argv, *args)      # a repeated option: the last one counts
    assert result.returncode == 2
    assert len(result.stderr.strip().splitlines()) == 1, result.stderr
    assert not (tmp_path / "a.pfm").exists()


@pytest.mark.parametrize("missing", ["--width", "--height", "--spp", "--seed", "--out"])
def test_missing_option_exits_2(binary, tmp_path, missing):
    base = {"--width": 4, "--height": 3, "--spp": 2, "--seed": 0, "--out": tmp_path / "a.pfm"}
    del base[missing]
    result = run(binary, *[a for kv in base.items() for a in kv])
    assert result.returncode == 2 and len(result.stderr.strip().splitlines()) == 1


def test_unwritable_output_exits_1(binary, tmp_path):
    result = run(binary, "--width", 4, "--height", 3, "--spp", 2, "--seed", 0,
                 "--out", tmp_path / "no-such-folder" / "a.pfm")
    assert result.returncode == 1
    assert len(result.stderr.strip().splitlines()) == 1 and "no-such-folder" in result.stderr


def test_pfm_layout_threads_and_seeds(binary, tmp_path):
    one = verify.render_cpp(binary, tmp_path, 64, seed=7, width=8, height=6)
    data = (tmp_path / "correct-d-1-s7-n64-t1-mean.pfm").read_bytes()
    header = b"PF\n8 6\n-1.0\n"
    assert data.startswith(header) and len(data) == len(header) + 8 * 6 * 3 * 4
    assert one[0].shape == (6, 8, 3) and np.all(one[0] >= 0) and np.all(one[1] >= 0)
    # The light, seen directly, is the brightest thing in the image, in its top row (row 0
    # here, the last row of the file).
    assert np.unravel_index(one[0].argmax(), one[0].shape)[0] == 0 and one[0].max() > 2
    # The red wall is on the left (Mitsuba's look-at frame: camera +x is the image's left).
    left, right = one[0][1:, 0], one[0][1:, -1]
    assert left[:, 0].mean() > 1.5 * left[:, 2].mean() and right[:, 2].mean() > 1.5 * right[:, 0].mean()
    three = verify.render_cpp(binary, tmp_path, 64, seed=7, width=8, height=6, threads=3)
    assert all(np.array_equal(a, b) for a, b in zip(one, three))
    other = verify.render_cpp(binary, tmp_path, 64, seed=8, width=8, height=6)
    assert not np.array_equal(one[0], other[0])


# ---- statistics -------------------------------------------------------------------------

@pytest.mark.statistical(assertions=1)
def test_agrees_with_our_smallpt(correct):
    """Against Mitsuba it is judged by ``mitsuba-refs check`` (tests/test_external_renderers.py)."""
    ours = verify.render_ours(OURS_SPP, seed=2)
    against_ours = verify.against_ours(correct, SPP, ours, OURS_SPP, ALPHA)
    assert against_ours.agree, verdict_line(against_ours)


@pytest.mark.parametrize("bug", ["roulette", "fresnel-split"])
def test_injected_bug_is_rejected(binary, workdir, reference, bug):
    """Power, not a false-failure risk: fixed seeds, p ~ 1e-16 (roulette) and 1e-31."""
    image = verify.render_cpp(binary, workdir, SPP, seed=1, bug=bug)
    result = verify.against_mitsuba(image, SPP, reference, ALPHA)
    assert not result.agree, verdict_line(result)
    assert result.rel_bias_ci[1] < 0, verdict_line(result)     # both bugs lose energy


@pytest.mark.statistical(assertions=1)
@pytest.mark.parametrize("max_depth", [1, 2, 3])
def test_max_depth_agrees_with_our_smallpt(binary, workdir, max_depth):
    cpp = verify.render_cpp(binary, workdir, OURS_SPP, seed=10 + max_depth, max_depth=max_depth)
    ours = verify.render_ours(OURS_SPP, seed=20 + max_depth, max_depth=max_depth)
    result = verify.against_ours(cpp, OURS_SPP, ours, OURS_SPP, ALPHA)
    assert result.agree, verdict_line(result)
