"""Differences of convention (mitsuba_refs/stats/conventions.py, verdicts/conventions.py).

The transforms and estimates are checked on synthetic images (noise from seeded generators);
the naming end to end on Mitsuba's own images given a convention, through ``check --images``
as a user's files would be. A named convention claims that the corrected image agrees with the
reference at the test's level: that claim is the statistical assertion of a naming test (a
correct correction fails it with probability at most ``ALPHA``).
"""
from __future__ import annotations

import json
import math
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from mitsuba_refs.cli.main import main
from mitsuba_refs.external.check import check
from mitsuba_refs.stats import conventions as conv
from mitsuba_refs.stats.mean import compare_means
from mitsuba_refs.verdicts.conventions import (
    ConventionFinding,
    ConventionHint,
    MeanTestSetup,
    corrections,
    find_convention,
)
from tests.budget import ALPHA

SIZE = 32
SPP = 64
REF_SPP = 4096


# ---- transforms ----------------------------------------------------------------------------

def test_srgb_and_gamma_decode_invert_their_encodings_and_slopes_are_derivatives():
    x = np.linspace(0.0, 3.0, 301)
    np.testing.assert_allclose(conv.srgb_decode(conv.srgb_encode(x)), x, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(conv.gamma_decode(conv.gamma_encode(x)), x, rtol=1e-12, atol=1e-15)
    # sRGB is linear below 0.0031308 (encoded 0.04045) and a 2.4 power above.
    assert conv.srgb_encode(0.001) == pytest.approx(0.01292)
    assert conv.srgb_encode(1.0) == pytest.approx(1.0)
    y, h = np.linspace(0.1, 0.9, 9), 1e-6
    for decode, slope in ((conv.srgb_decode, conv.srgb_decode_slope),
                          (conv.gamma_decode, conv.gamma_decode_slope)):
        numeric = (decode(y + h) - decode(y - h)) / (2 * h)
        np.testing.assert_allclose(slope(y), numeric, rtol=1e-6)


def test_shifted_moves_pixels_and_says_which_hold_a_moved_value():
    image = np.arange(12.0).reshape(3, 4, 1)
    right, valid = conv.shifted(image, 0, 1)
    np.testing.assert_array_equal(right[:, 1:, 0], image[:, :-1, 0])
    assert not valid[:, 0].any() and valid[:, 1:].all() and not right[:, 0].any()
    up, valid = conv.shifted(image, -1, 0)
    np.testing.assert_array_equal(up[:-1, :, 0], image[1:, :, 0])
    assert not valid[-1].any() and valid[:-1].all()
    back, _ = conv.shifted(conv.shifted(image, 1, -1)[0], -1, 1)
    np.testing.assert_array_equal(back[:-1, 1:], image[:-1, 1:])


def test_half_shifted_averages_each_pixel_with_its_neighbour_and_quarters_the_variance():
    mean = np.arange(12.0).reshape(3, 4, 1)
    variance = np.full((3, 4, 1), 8.0)
    moved, moved_variance, valid = conv.half_shifted(mean, variance, 0, 1)    # half right
    np.testing.assert_array_equal(moved[:, 1:], (mean[:, 1:] + mean[:, :-1]) / 2)
    np.testing.assert_array_equal(moved_variance[:, 1:], 4.0)
    assert not valid[:, 0].any() and valid[:, 1:].all()
    # A linear ramp moved by half a pixel is the ramp at the pixels' edges: exact.
    ramp = np.tile(np.arange(8.0), (2, 1))[..., None]
    down, _, valid = conv.half_shifted(ramp.transpose(1, 0, 2), ramp.transpose(1, 0, 2), 1, 0)
    np.testing.assert_allclose(down[1:, :, 0], (np.arange(8.0)[1:] - 0.5)[:, None] * np.ones((1, 2)))


def test_flipped_and_masked():
    image = np.arange(12.0).reshape(2, 3, 2)
    np.testing.assert_array_equal(conv.flipped(image, True), image[::-1])
    np.testing.assert_array_equal(conv.flipped(image, False), image[:, ::-1])
    mask = np.array([[True, False, False], [False, False, True]])
    out = conv.masked(image, mask)
    assert not out[0, 0].any() and not out[1, 2].any() and np.array_equal(out[0, 1], image[0, 1])
    assert conv.masked(image, None) is image


def test_clamp_ceiling_needs_several_pixels_at_one_largest_value():
    rng = np.random.default_rng(3)
    image = rng.uniform(0.0, 0.9, (16, 16, 3))
    assert math.isnan(conv.clamp_ceiling(image))                  # one largest value: noise
    image[:2, :2] = 1.0                                            # 12 pixel-channels at 1
    assert conv.clamp_ceiling(image) == 1.0
    image[0, 0, 0] = 1.5
    assert math.isnan(conv.clamp_ceiling(image))                  # the largest is alone again
    reference = np.full((2, 2, 3), 0.5)
    reference[1, 1] = 2.0
    mask = conv.clamp_mask(np.minimum(reference, 1.0), reference - 0.2, 1.0, np.full((2, 2, 3), 0.3))
    np.testing.assert_array_equal(mask, [[False, False], [False, True]])


def test_tile_chi_square_and_explains():
    assert conv.tile_chi_square(np.zeros((4, 4, 3))) == 0.0
    z = np.zeros((2, 2, 3))
    z[0, 0] = [3.0, 4.0, 0.0]
    assert conv.tile_chi_square(z) == pytest.approx(12.5)
    assert conv.explains(40.0, 0.9, 4.0) and conv.explains(4.0, 0.5, 4.0)
    assert not conv.explains(3.9, 0.5, 4.0)           # not far above the noise to begin with
    assert not conv.explains(40.0, 11.0, 4.0) and not conv.explains(40.0, math.inf, 4.0)


# ---- synthetic renders --------------------------------------------------------------------

def _scene():
    """Expected image: a gradient with a bright square (a light) and coloured halves."""
    y, x = np.mgrid[0:SIZE, 0:SIZE] / SIZE
    base = 0.2 + 0.5 * x[..., None] * np.array([1.0, 0.7, 0.4]) + 0.2 * y[..., None]
    base[4:10, 12:20] = [6.0, 5.0, 4.0]
    return base


def _render(expected, spp, rng):
    """A render's mean and per-sample variance: per-sample sd 0.8 x the value (noise of the
    mean drawn exactly; the sample variance within 10 %, as a chi-square with many dof)."""
    sd = 0.8 * expected
    mean = expected + rng.standard_normal(expected.shape) * sd / math.sqrt(spp)
    variance = sd ** 2 * rng.uniform(0.9, 1.1, expected.shape)
    return mean, variance


def _reference(rng):
    mean, variance = _render(_scene(), REF_SPP, rng)
    return SimpleNamespace(mean=mean, var=variance, n=REF_SPP, metadata={})


def _found(test_mean, test_variance, reference, alpha=ALPHA):
    verdict = compare_means(test_mean, test_variance, SPP, reference.mean, reference.var,
                            reference.n, alpha=alpha)
    setup = MeanTestSetup.of(verdict, reference, SPP, heavy_tail_guard=False)

    def moments_of(transform):
        return (test_mean, test_variance) if transform is None else transform(test_mean, test_variance)

    return verdict, find_convention(moments_of, verdict, setup)


def test_channel_gains_are_fitted_on_tiles_and_their_spread_measured():
    rng = np.random.default_rng(11)
    reference = _reference(rng)
    mean, variance = _render(_scene(), SPP, rng)
    white = conv.channel_gains(mean * [1.1, 1.0, 0.85], variance * np.square([1.1, 1.0, 0.85]),
                               SPP, reference.mean, reference.var, reference.n)
    np.testing.assert_allclose(white.gains, [1.1, 1.0, 0.85], rtol=0.02)
    assert white.spread_z > 10 and white.spread == pytest.approx(1.1 / 0.85 - 1, rel=0.03)
    grey = conv.channel_gains(mean * 1.05, variance * 1.05 ** 2, SPP, reference.mean,
                              reference.var, reference.n)
    np.testing.assert_allclose(grey.gains, 1.05, rtol=0.02)
    assert grey.spread_z < 5            # one global factor: not a white balance


def test_every_convention_offers_its_correction():
    rng = np.random.default_rng(5)
    reference = _reference(rng)
    mean, variance = _render(_scene(), SPP, rng)
    clamped = np.minimum(mean * [1.2, 1.0, 0.8], 2.0)     # the light square only
    verdict = compare_means(clamped, variance, SPP, reference.mean, reference.var, reference.n,
                            alpha=ALPHA)
    setup = MeanTestSetup.of(verdict, reference, SPP, heavy_tail_guard=False)
    offered = [c.convention for c in corrections(clamped, variance, setup)]
    assert offered.count("factor") == 6 and offered.count("shift") == 4
    assert {"channel_gains", "srgb", "gamma", "clamp", "flip_vertical", "flip_horizontal"} <= set(offered)
    plain = [c.convention for c in corrections(mean * 1.05, variance, setup)]
    assert "channel_gains" not in plain and "clamp" not in plain


def _edge_filled_shift(image):
    """The image moved one pixel right, its first column repeated (a film has something there)."""
    moved, valid = conv.shifted(image, 0, 1)
    return np.where(valid[..., None], moved, image)


#: name -> (what the renderer did to (mean, per-sample variance), the value to be named).
INJECTED = {
    "factor": (lambda m, v: (m / math.pi, v / math.pi ** 2), 1 / math.pi),
    "srgb": (lambda m, v: (conv.srgb_encode(m),
                           v / np.square(conv.srgb_decode_slope(conv.srgb_encode(m)))), None),
    "flip_vertical": (lambda m, v: (m[::-1], v[::-1]), None),
    "shift": (lambda m, v: (_edge_filled_shift(m), _edge_filled_shift(v)), (0, 1)),
}


@pytest.mark.statistical(assertions=1)
@pytest.mark.parametrize("name", list(INJECTED))
def test_an_injected_convention_is_named_on_synthetic_renders(name):
    rng = np.random.default_rng(21)
    reference = _reference(rng)
    inject, value = INJECTED[name]
    verdict, finding = _found(*inject(*_render(_scene(), SPP, rng)), reference)
    assert not verdict.agree
    assert finding is not None and finding.convention == name, finding
    if value is not None:
        np.testing.assert_allclose(finding.value, value, rtol=1e-9)
    assert finding.p_value > ALPHA and finding.chi_square_before > 4 * max(finding.chi_square_after, 1)


@pytest.mark.parametrize("bias", [
    lambda m: m * 1.05,                                     # a light 5 % too bright
    lambda m: np.where(np.arange(SIZE)[None, :, None] < SIZE // 2, m * 0.8, m),   # one wall
    lambda m: m * [1.0, 1.0, 1.0] + 0.05,                   # an offset, no factor at all
])
def test_a_plain_bias_is_not_named_a_convention(bias):
    rng = np.random.default_rng(31)
    reference = _reference(rng)
    mean, variance = _render(_scene(), SPP, rng)
    verdict, finding = _found(bias(mean), variance, reference)
    assert not verdict.agree and finding is None, finding


def test_the_hint_says_the_convention_and_keeps_its_numbers():
    finding = ConventionFinding("factor", 1 / math.pi, 0.41, 5920.0, 0.91)
    hint = ConventionHint(finding)
    assert str(hint).startswith("convention: the image is 1/pi times Mitsuba's (light or BSDF units")
    assert "divided by 1/pi it agrees (p = 0.41" in hint and hint.causes == ("convention_factor",)
    assert hint.finding["value"] == pytest.approx(1 / math.pi)
    import pickle
    again = pickle.loads(pickle.dumps(hint))
    assert again == hint and again.finding == hint.finding and again.causes == hint.causes
    shift = ConventionHint(ConventionFinding("shift", (0, -1), 0.2, 50.0, 1.0, 0.03, ("clamp",)))
    assert "moved one pixel left" in shift and "3.0% of the pixels left out" in shift
    assert "corrected as clamp it agrees too" in shift
    half = ConventionHint(ConventionFinding("half_shift", (0.5, 0.0), 0.3, 30.0, 0.9, 0.02))
    assert "moved half a pixel down" in half and "against Mitsuba's moved alike it agrees" in half
    filtered = ConventionHint(ConventionFinding("filter", "tent", 0.2, 10.0, 0.7, 0.0,
                                                ("filter (gaussian)",)))
    assert "a tent filter fits best" in filtered and filtered.finding["value"] == "tent"
    assert "corrected as filter (gaussian) it agrees too" in filtered
    fov = ConventionHint(ConventionFinding("fov_axis", "diagonal", 0.5, 80.0, 0.9))
    assert "another field-of-view axis" in fov and "fov measured along diagonal" in fov


def test_another_filter_or_fov_axis_is_tried_only_for_a_file_that_reads_no_other_file():
    from mitsuba_refs.settings import Settings
    from mitsuba_refs.verdicts.convention_references import effective_axis, filtered_references, fov_axis_references
    # The mesh scene reads a PLY file: a copy elsewhere could not, so no filter is tried
    # (and nothing is rendered).
    film = SimpleNamespace(mean=np.zeros((64, 64, 3)))
    assert filtered_references("mesh", {}, Settings(reference="path"), film) == []
    assert fov_axis_references("mesh", {}, Settings(reference="path"), film) == []
    assert [effective_axis(a, 64, 48) for a in ("smaller", "larger", "x", "diagonal")] == \
        ["y", "x", "x", "diagonal"]
    assert effective_axis("smaller", 32, 32) == "x"


# ---- end to end: Mitsuba's images through check --images ------------------------------------

@pytest.fixture(scope="module")
def mitsuba_replicas():
    """Eight 8-spp renders of the Cornell box at max_depth 3 by Mitsuba itself (seeds 8192 k:
    scalar_rgb seeds its blocks from seed x width x height)."""
    mi = pytest.importorskip("mitsuba")
    mi.set_variant("scalar_rgb")
    scene = mi.load_file(str(Path(__file__).resolve().parent.parent
                             / "pathtracer/data/scenes/cornell-box.xml"),
                         width=64, height=64, max_depth=3, spp=8)
    return [np.array(mi.render(scene, seed=8192 * (k + 1), spp=8), dtype=np.float64)
            for k in range(8)]


def _pfms(folder, images):
    folder.mkdir(parents=True, exist_ok=True)
    for k, image in enumerate(images):
        path = folder / f"replica-{k}.pfm"
        with open(path, "wb") as out:
            out.write(b"PF\n64 64\n-1.0\n")
            out.write(np.ascontiguousarray(image[::-1], dtype="<f4").tobytes())
        path.with_name(path.name + ".json").write_text(json.dumps({"spp": 8}))
    return str(folder / "replica-*.pfm")


@pytest.mark.mitsuba
@pytest.mark.statistical(assertions=1)
def test_check_images_names_srgb_output_first_among_the_hints(mitsuba_replicas, tmp_path, capsys):
    pattern = _pfms(tmp_path / "srgb", [conv.srgb_encode(image) for image in mitsuba_replicas])
    out = tmp_path / "results.json"
    code = main(["check", "cornell-box", "-D", "max_depth=3", "--images", pattern,
                 "--no-convergence", "--alpha", str(ALPHA), "--json", str(out)])
    text = capsys.readouterr().out
    assert code == 1
    causes = [line for line in text.splitlines() if "likely cause:" in line]
    assert causes and "convention: the output is sRGB-encoded" in causes[0], text
    record = json.loads(out.read_text())["results"][0]
    assert record["convention"]["convention"] == "srgb"
    assert record["convention"]["p_value"] > ALPHA and record["hints"][0].startswith("convention:")


@pytest.mark.mitsuba
@pytest.mark.statistical(assertions=1)
def test_check_images_names_one_bounce_too_few(mitsuba_replicas, tmp_path):
    mi = pytest.importorskip("mitsuba")
    scene = mi.load_file(str(Path(__file__).resolve().parent.parent
                             / "pathtracer/data/scenes/cornell-box.xml"),
                         width=64, height=64, max_depth=2, spp=8)
    shorter = [np.array(mi.render(scene, seed=8192 * (k + 9), spp=8)) for k in range(8)]
    result = check("cornell-box", images=_pfms(tmp_path / "depth2", shorter),
                   params={"max_depth": 3}, convergence=False, alpha=ALPHA)
    assert not result.agree and result.hints[0].finding["convention"] == "bounces", result.report()
    assert "max_depth = 2" in result.hints[0]


@pytest.mark.mitsuba
def test_check_images_does_not_name_a_light_five_percent_too_bright(mitsuba_replicas, tmp_path):
    """Power (+5 % is ~10 standard errors here), and no convention claimed for a plain bias."""
    result = check("cornell-box", images=_pfms(tmp_path / "bright", [1.05 * image for image in mitsuba_replicas]),
                   params={"max_depth": 3}, convergence=False, alpha=ALPHA)
    assert not result.agree
    assert not any(getattr(hint, "finding", None) for hint in result.hints), result.report()
    assert not any(str(hint).startswith("convention:") for hint in result.hints)


@pytest.mark.mitsuba
@pytest.mark.statistical(assertions=1)
def test_check_command_names_a_factor_of_one_half():
    """``--command``: Mitsuba run as an external renderer whose image is half of Mitsuba's (a
    one-sided light where Mitsuba's is two-sided); named from the runs' own images."""
    pytest.importorskip("mitsuba")
    renderer = Path(__file__).resolve().parent / "external" / "mitsuba_scaled_renderer.py"
    command = (f"{sys.executable} {renderer} {{scene}} --spp {{spp}} --seed {{seed}} "
               "--max-depth {max_depth} --width {width} --height {height} --factor 0.5 --out {out}")
    result = check("cornell-box", command=command, params={"max_depth": 3}, convergence=False,
                   alpha=ALPHA, output_suffix=".pfm", jobs=2)
    assert not result.agree, result.report()
    assert result.hints[0].finding["convention"] == "factor", result.report()
    assert result.hints[0].finding["value"] == pytest.approx(0.5)
    assert "the image is 1/2 times Mitsuba's" in result.hints[0]


def test_references_a_convention_cannot_have_leave_it_untried():
    from mitsuba_refs.errors import ReferenceUnavailable
    from mitsuba_refs.verdicts import convention_references as verdicts

    def unavailable(*args, log=None):
        raise ReferenceUnavailable("no Mitsuba here and nothing cached")

    lines = []
    result = SimpleNamespace(scene="cornell-box", params={})
    assert verdicts.optional(unavailable, result, None, None, lines.append) == []
    assert lines == ["conventions: not tried (no Mitsuba here and nothing cached)"]
    assert verdicts.may_render(SimpleNamespace(mean=np.zeros((128, 128, 3))))
    assert not verdicts.may_render(SimpleNamespace(mean=np.zeros((256, 256, 3))))


# ---- pixel samples at the centre, half a pixel measured exactly ----------------------------

def test_centre_corrections_mix_the_box_and_centre_images_with_both_noises():
    """A render whose first sample of ``k`` sits at the pixel centre expects
    ``(1 - 1/k) B + (1/k) C``; the mixed reference's variance of the mean is the sum of the
    parts' (C's over its own count)."""
    from mitsuba_refs.verdicts.conventions import _centre_corrections
    rng = np.random.default_rng(8)
    box = SimpleNamespace(mean=rng.random((4, 4, 3)), var=rng.random((4, 4, 3)), n=4096,
                          metadata={"rfilter": {"type": "box"}})
    centre = SimpleNamespace(mean=rng.random((4, 4, 3)), var=rng.random((4, 4, 3)), n=128,
                             metadata={"rfilter": {"type": "box", "radius": 0.5}})
    first, every = _centre_corrections(box, centre, 8)
    assert (first.convention, first.value, every.value) == ("centre_samples", 0.125, 1.0)
    np.testing.assert_allclose(first.reference.mean, 0.875 * box.mean + 0.125 * centre.mean)
    np.testing.assert_allclose(first.reference.var / first.reference.n,
                               0.875 ** 2 * box.var / 4096 + 0.125 ** 2 * centre.var / 128)
    np.testing.assert_allclose(every.reference.mean, centre.mean)
    assert len(_centre_corrections(box, centre, 1)) == 1        # 1 spp: the first is every one


def test_half_shift_copies_move_the_principal_point_the_other_way(monkeypatch):
    """Mitsuba's image moved half a pixel down is its film moved half a pixel up: the copy's
    principal_point_offset_y is +0.5 / height (pixel p then sees p + 1/2, tests/test_camera.py)."""
    from mitsuba_refs.verdicts import convention_references as refs
    copies = []
    monkeypatch.setattr(refs, "_copied_references", lambda c, *args: copies.extend(c) or [])
    film = SimpleNamespace(mean=np.zeros((48, 64, 3)))
    refs.half_shift_references("smallpt", {}, None, film, (1, 0))
    refs.half_shift_references("smallpt", {}, None, film, (0, -1))
    down, left = (copy.read_text() for _, copy in copies)
    assert f'name="principal_point_offset_y" value="{-0.5 / 48!r}"' in down
    assert 'name="principal_point_offset_x" value="0.0"' in down
    assert f'name="principal_point_offset_x" value="{0.5 / 64!r}"' in left
    assert refs.half_shift_references("mesh", {}, None, film, (1, 0)) == []   # reads a PLY


@pytest.mark.mitsuba
@pytest.mark.statistical(assertions=1)
def test_check_images_names_half_a_pixel_down_against_the_moved_reference(tmp_path):
    """Half a pixel down (twice-size renders averaged over 2 x 2 pixels one small pixel
    lower): the neighbours' average misses at the light's horizontal edges; Mitsuba's
    reference with its principal point moved names it."""
    pytest.importorskip("mitsuba")
    from experiments.conventions import half_down, mitsuba_replicas, write_replicas
    images = half_down(mitsuba_replicas("cornell-box", "twice the size", 14))
    result = check("cornell-box", images=write_replicas(tmp_path, images),
                   params={"max_depth": 3}, convergence=False, alpha=ALPHA)
    assert not result.agree, result.report()
    assert result.hints[0].finding["convention"] == "half_shift", result.report()
    assert result.hints[0].finding["value"] == [0.5, 0.0]
    assert "moved half a pixel down" in result.hints[0]


@pytest.mark.mitsuba
@pytest.mark.statistical(assertions=1)
def test_check_images_names_every_sample_at_the_pixel_centre(tmp_path):
    """A renderer without antialiasing (every sample through the pixel centre): 9 % darker
    on the Cornell box (the centres miss the light's partly covered pixels), named against
    Mitsuba's own image of the pixel centres."""
    pytest.importorskip("mitsuba")
    from experiments.conventions import centre_replicas, write_replicas
    images = centre_replicas("cornell-box", "every sample at centre", 14)
    result = check("cornell-box", images=write_replicas(tmp_path, images),
                   params={"max_depth": 3}, convergence=False, alpha=ALPHA)
    assert not result.agree, result.report()
    assert result.hints[0].finding["convention"] == "centre_samples", result.report()
    assert result.hints[0].finding["value"] == 1.0
    assert "every pixel sample at the pixel centre" in result.hints[0]
