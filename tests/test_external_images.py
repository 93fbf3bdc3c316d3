"""The readers of images written by other renderers (mitsuba_refs/external/images.py).

Every reader is checked against files other programs wrote: the fixtures in
tests/data/images (Mitsuba 3, the OpenEXR package, Pillow; tools/images/make_fixtures.py),
whose pixels tests/image_pattern.py recomputes, and, where Mitsuba is installed, files
mi.Bitmap writes during the test. The pattern differs left from right and top from bottom,
so a value compared within its format's precision also checks the orientation. The faults
are files cut short, mislabelled or inconsistent, each refused in one line naming the file.
"""
from __future__ import annotations

import json
import shutil
import signal
from pathlib import Path

import numpy as np
import OpenEXR
import pytest

from mitsuba_refs.external import images
from mitsuba_refs.external.images import ExternalImage, ImageError, image_faults, read_image
from pathtracer.core import interrupts
from tests.image_pattern import HEIGHT, WIDE_WIDTH, WIDTH, grey_pattern, pattern, variance_pattern
from tests.interrupting import swallowing_reader

FIXTURES = Path(__file__).resolve().parent / "data" / "images"
#: Half floats keep 11 significant bits: relative error at most 2^-11.
HALF_RELATIVE = 2.0 ** -11


def _float32(values):
    return np.asarray(values, dtype=np.float32).astype(np.float64)


def _within_rgbe(decoded, expected):
    """RGBE keeps an 8-bit mantissa per channel under the pixel's common exponent: within
    1/256 of the pixel's largest channel."""
    largest = expected.max(axis=-1, keepdims=True)
    return bool(np.all(np.abs(decoded - expected) <= largest / 256 * (1 + 1e-12)))


def _fixture(tmp_path, name, rename=None):
    """A copy of a fixture in tmp_path (so that a sidecar or a cut can go beside it)."""
    copy = tmp_path / (rename or name)
    shutil.copyfile(FIXTURES / name, copy)
    return copy


def _write_exr(path, channels, **attributes):
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage} | attributes
    with OpenEXR.File(header, {name: np.ascontiguousarray(c, np.float32) for name, c in channels.items()}) as exr:
        exr.write(str(path))
    return path


def _rgb(image, prefix=""):
    return {f"{prefix}{name}": image[:, :, c] for c, name in enumerate("RGB")}


def _refused(path, match, **kwargs):
    """The ImageError of reading ``path``: one line, starting with the path, matching ``match``."""
    with pytest.raises(ImageError, match=match) as caught:
        read_image(path, **kwargs)
    message = str(caught.value)
    assert "\n" not in message and message.startswith(f"{path}: ")
    return message


# --- the pattern tells orientations apart --------------------------------------------------

def test_the_pattern_differs_under_every_flip_beyond_the_coarsest_tolerance():
    for width in (WIDTH, WIDE_WIDTH):
        image = pattern(width, HEIGHT)
        for flipped in (image[::-1], image[:, ::-1], image[::-1, ::-1], image[:, :, ::-1]):
            assert not _within_rgbe(flipped, image)


# --- files other programs wrote ------------------------------------------------------------

EXACT_FLOAT32 = ["mitsuba_float32.exr", "mitsuba_rgba.exr", "mitsuba.pfm", "openexr_tiled.exr",
                 "openexr_extra_channels.exr", "openexr_data_window.exr", "openexr_multipart.exr",
                 "openexr_variance.exr", "openexr_layer.exr"]


@pytest.mark.parametrize("name", EXACT_FLOAT32)
def test_float32_files_read_exactly_right_way_up(name):
    image = read_image(FIXTURES / name)
    assert isinstance(image, ExternalImage) and image.size == (WIDTH, HEIGHT)
    assert image.format == name.rpartition(".")[2]
    assert image.mean.dtype == np.float64 and image.mean.shape == (HEIGHT, WIDTH, 3)
    np.testing.assert_array_equal(image.mean, _float32(pattern()))
    assert image_faults(image) == []            # the data window's -1 border is cropped off


@pytest.mark.parametrize("name", ["mitsuba_float16.exr", "openexr_half.exr"])
def test_half_files_read_within_half_precision(name):
    image = read_image(FIXTURES / name)
    np.testing.assert_array_equal(image.mean, pattern().astype(np.float16).astype(np.float64))
    np.testing.assert_allclose(image.mean, pattern(), rtol=HALF_RELATIVE, atol=0)


@pytest.mark.parametrize("name, width", [("mitsuba_flat.hdr", WIDTH), ("mitsuba_rle.hdr", WIDE_WIDTH)])
def test_rgbe_files_read_within_their_mantissa(name, width):
    image = read_image(FIXTURES / name)
    assert image.format == "hdr" and image.size == (width, HEIGHT)
    assert image.attributes["FORMAT"] == "32-bit_rle_rgbe"
    assert _within_rgbe(image.mean, pattern(width, HEIGHT))


def test_rgbe_decodes_the_middle_of_the_truncated_interval():
    # Mitsuba's writer truncates the mantissa: decoding (m + 0.5) leaves errors of both signs
    # that average out, decoding m (Mitsuba's reader) would leave all of them negative.
    image = read_image(FIXTURES / "mitsuba_rle.hdr")
    error = image.mean - pattern(WIDE_WIDTH, HEIGHT)
    assert np.count_nonzero(error > 0) > 0.3 * error.size and np.count_nonzero(error < 0) > 0.3 * error.size


def test_grey_pfm_from_pillow_is_the_same_grey_in_red_green_and_blue():
    image = read_image(FIXTURES / "pillow_grey.pfm")
    for channel in range(3):
        np.testing.assert_array_equal(image.mean[:, :, channel], _float32(grey_pattern()))
    assert image.variance is None and image.attributes == {"scale": -1.0}


def test_variance_channels_are_read_with_the_header_sample_count_and_seed():
    image = read_image(FIXTURES / "openexr_variance.exr")
    np.testing.assert_array_equal(image.variance, _float32(variance_pattern()))
    assert (image.spp, image.seed) == (64, 7)
    assert image.attributes["spp"] == 64 and "compression" not in image.attributes


def test_one_layer_is_the_colour_and_text_spp_a_number():
    image = read_image(FIXTURES / "openexr_layer.exr")      # Beauty.*, depth.Z and var.*
    np.testing.assert_array_equal(image.variance, _float32(variance_pattern()))
    assert (image.spp, image.seed) == (32, None)


def test_mitsuba_metadata_gives_spp_and_seed_and_files_without_any_give_none():
    assert (read_image(FIXTURES / "mitsuba_float32.exr").spp, read_image(FIXTURES / "mitsuba_float32.exr").seed) \
        == (16, 3)
    plain = read_image(FIXTURES / "mitsuba_rgba.exr")
    assert (plain.spp, plain.seed, plain.variance) == (None, None, None)
    assert plain.attributes["generatedBy"].startswith("Mitsuba")


def test_a_multi_part_file_reads_part_0_and_says_so():
    image = read_image(FIXTURES / "openexr_multipart.exr")
    assert image.attributes["note"] == "multi-part file: part 0 ('beauty') read, the other parts ignored"


def test_big_endian_pfm_and_its_scale_magnitude(tmp_path):
    data = (FIXTURES / "mitsuba.pfm").read_bytes()
    header = b"PF\n7 5\n-1\n"
    assert data.startswith(header)
    floats = np.frombuffer(data[len(header):], "<f4")
    big_endian = tmp_path / "big.pfm"
    big_endian.write_bytes(b"PF\n7 5\n1.0\n" + floats.astype(">f4").tobytes())
    np.testing.assert_array_equal(read_image(big_endian).mean, _float32(pattern()))
    scaled = tmp_path / "scaled.pfm"
    scaled.write_bytes(b"PF\n7 5\n-0.25\n" + data[len(header):])
    np.testing.assert_array_equal(read_image(scaled).mean, _float32(pattern()) * 0.25)


def test_exposure_and_colour_correction_lines_divide_the_values(tmp_path):
    data = (FIXTURES / "mitsuba_flat.hdr").read_bytes()
    marked = tmp_path / "exposed.hdr"
    marked.write_bytes(data.replace(b"FORMAT=32-bit_rle_rgbe\n",
                                    b"FORMAT=32-bit_rle_rgbe\nEXPOSURE=0.5\nSOFTWARE=x\nEXPOSURE= 4\n", 1))
    image = read_image(marked)
    np.testing.assert_array_equal(image.mean, read_image(FIXTURES / "mitsuba_flat.hdr").mean / 2)
    assert image.attributes["EXPOSURE"] == 2.0 and image.attributes["SOFTWARE"] == "x"
    marked.write_bytes(data.replace(b"FORMAT=32-bit_rle_rgbe\n", b"COLORCORR=1 2 0.5\nFORMAT=32-bit_rle_rgbe\n", 1))
    np.testing.assert_array_equal(read_image(marked).mean,
                                  read_image(FIXTURES / "mitsuba_flat.hdr").mean / np.array([1, 2, 0.5]))
    marked.write_bytes(data.replace(b"FORMAT=32-bit_rle_rgbe\n", b"EXPOSURE=-1\n", 1))
    _refused(marked, "header line 'EXPOSURE=-1' does not hold 1 positive number")


def test_the_format_comes_from_the_bytes_not_the_name(tmp_path):
    image = read_image(_fixture(tmp_path, "mitsuba.pfm", rename="render.exr"))
    assert image.format == "pfm"


# --- a live Mitsuba writes, the readers read ----------------------------------------------

def test_files_mitsuba_writes_now_read_back(mi, tmp_path):
    colour = pattern(WIDE_WIDTH, HEIGHT).astype(np.float32)
    bitmap = mi.Bitmap(colour)
    bitmap.metadata()["spp"] = 8
    for suffix in ("exr", "pfm"):
        bitmap.write(str(tmp_path / f"live.{suffix}"))
        image = read_image(tmp_path / f"live.{suffix}", spp=8)
        np.testing.assert_array_equal(image.mean, colour.astype(np.float64))
    assert read_image(tmp_path / "live.exr").spp == 8
    for width in (WIDTH, WIDE_WIDTH):                          # flat and run-length scanlines
        part = np.ascontiguousarray(colour[:, :width])
        mi.Bitmap(part).write(str(tmp_path / "live.hdr"))
        ours = read_image(tmp_path / "live.hdr").mean
        assert _within_rgbe(ours, part.astype(np.float64))
        # Mitsuba decodes m * 2^(e - 136): ours is half a mantissa unit above, the same in all
        # three channels of a pixel (they share e), a power of two.
        theirs = np.array(mi.Bitmap(str(tmp_path / "live.hdr")), dtype=np.float64)
        step = ours - theirs
        assert np.all(step == step[:, :, :1]) and np.all(np.log2(step) == np.round(np.log2(step)))
    (tmp_path / "scaled.pfm").write_bytes(b"PF\n2 1\n-2.5\n" + np.arange(6, dtype="<f4").tobytes())
    np.testing.assert_array_equal(read_image(tmp_path / "scaled.pfm").mean,
                                  np.array(mi.Bitmap(str(tmp_path / "scaled.pfm")), dtype=np.float64))


# --- files refused -----------------------------------------------------------------------

def test_missing_empty_folder_and_non_image_files_are_refused(tmp_path):
    _refused(tmp_path / "absent.exr", "no such file")
    (tmp_path / "empty.exr").write_bytes(b"")
    _refused(tmp_path / "empty.exr", r"empty file \(0 bytes\)")
    _refused(tmp_path, "is a folder")
    (tmp_path / "notes.exr").write_text("spp=64\n")
    message = _refused(tmp_path / "notes.exr", "not an image in a format read here")
    assert "OpenEXR, PFM or Radiance HDR" in message


def test_a_truncated_pfm_says_how_many_bytes_it_lacks(tmp_path):
    data = (FIXTURES / "mitsuba.pfm").read_bytes()
    (tmp_path / "cut.pfm").write_bytes(data[:-20])
    _refused(tmp_path / "cut.pfm", "truncated: 7x5 RGB float32 pixels are 420 bytes, the file has 400")
    (tmp_path / "long.pfm").write_bytes(data + b"\0")
    _refused(tmp_path / "long.pfm", "too long: .* are 420 bytes, the file has 421")
    (tmp_path / "header.pfm").write_bytes(b"PF\n7 ")
    _refused(tmp_path / "header.pfm", "malformed PFM header")
    (tmp_path / "zero.pfm").write_bytes(b"PF\n0 5\n-1\n")
    _refused(tmp_path / "zero.pfm", "width '0' is not a positive whole number")


@pytest.mark.parametrize("name", ["mitsuba_float32.exr", "openexr_tiled.exr"])
def test_a_truncated_exr_is_one_line_wherever_it_is_cut(tmp_path, name, capsys):
    data = (FIXTURES / name).read_bytes()
    for length in (6, 40, len(data) // 2, len(data) - 1):
        (tmp_path / name).write_bytes(data[:length])
        _refused(tmp_path / name, "truncated")
    assert "Warning" not in capsys.readouterr().out     # OpenEXR's printed warning is in the message


def test_exr_without_colour_is_refused_naming_its_channels(tmp_path):
    _refused(FIXTURES / "openexr_luminance.exr", r"no R, G, B channels \(luminance only\): the file has Y$")
    two = _write_exr(tmp_path / "two.exr", _rgb(pattern(), "diffuse.") | _rgb(pattern(), "specular."))
    _refused(two, r"several layers with R, G, B \(diffuse, specular\)")


def test_an_incomplete_variance_is_refused_naming_what_is_missing(tmp_path):
    channels = _rgb(pattern()) | _rgb(variance_pattern(), "var.")
    del channels["var.B"]
    _refused(_write_exr(tmp_path / "var.exr", channels), "has var.R, var.G but not var.B")


def test_a_data_window_short_of_the_display_window_is_refused(tmp_path):
    inner = (np.array([1, 0], np.int32), np.array([WIDTH - 1, HEIGHT - 1], np.int32))
    display = (np.array([0, 0], np.int32), np.array([WIDTH - 1, HEIGHT - 1], np.int32))
    path = _write_exr(tmp_path / "window.exr", _rgb(pattern()[:, 1:]), dataWindow=inner, displayWindow=display)
    _refused(path, r"the data window \(1, 0\)-\(6, 4\) does not cover the display window \(0, 0\)-\(6, 4\)")


def _radiance(tmp_path, header: bytes, resolution: bytes = b"-Y 5 +X 7"):
    pixels = (FIXTURES / "mitsuba_flat.hdr").read_bytes().partition(b"+X 7\n")[2]
    path = tmp_path / "picture.hdr"
    path.write_bytes(b"#?RADIANCE\n" + header + b"\n\n" + resolution + b"\n" + pixels)
    return path


def test_radiance_xyze_and_other_orientations_are_refused(tmp_path):
    _refused(_radiance(tmp_path, b"FORMAT=32-bit_rle_xyze"), "XYZ pixels .* not supported")
    message = _refused(_radiance(tmp_path, b"FORMAT=32-bit_rle_rgbe", b"+Y 5 +X 7"),
                       "resolution line '[+]Y 5 [+]X 7' is not the standard orientation")
    assert "-Y <height> +X <width>" in message
    _refused(_radiance(tmp_path, b"FORMAT=32-bit_rle_rgbe", b"-X 7 +Y 5"), "not the standard orientation")
    assert read_image(_radiance(tmp_path, b"SOFTWARE=t")).size == (WIDTH, HEIGHT)   # no FORMAT line: RGBE


def test_cut_or_padded_radiance_scanlines_are_refused(tmp_path):
    for name in ("mitsuba_flat.hdr", "mitsuba_rle.hdr"):
        data = (FIXTURES / name).read_bytes()
        (tmp_path / name).write_bytes(data[:-3])
        _refused(tmp_path / name, "truncated")
        (tmp_path / name).write_bytes(data + b"\0\0\0\0")
        _refused(tmp_path / name, "after the last of 5 scanlines|flat RGBE pixels are 140 bytes, the file has 144")
    data = (FIXTURES / "mitsuba_rle.hdr").read_bytes()
    start = data.index(b"+X 40\n") + len(b"+X 40\n")
    assert data[start:start + 4] == bytes([2, 2, 0, 40])
    (tmp_path / "width.hdr").write_bytes(data[:start + 3] + bytes([41]) + data[start + 4:])
    _refused(tmp_path / "width.hdr", "scanline 0 says it is 41 pixels wide, the picture is 40")
    data = (FIXTURES / "mitsuba_flat.hdr").read_bytes()
    start = data.index(b"+X 7\n") + len(b"+X 7\n")
    (tmp_path / "old.hdr").write_bytes(data[:start] + bytes([1, 1, 1, 3]) + data[start + 4:])
    _refused(tmp_path / "old.hdr", "old-style Radiance run-length encoding")


def test_a_damaged_second_part_is_told_in_the_note(tmp_path):
    data = (FIXTURES / "openexr_multipart.exr").read_bytes()
    (tmp_path / "cut.exr").write_bytes(data[:-1])            # the end of part 1's pixels
    image = read_image(tmp_path / "cut.exr")
    np.testing.assert_array_equal(image.mean, _float32(pattern()))
    assert image.attributes["note"].startswith("multi-part file: part 0 ('beauty') read, the other parts ignored; "
                                               "OpenEXR said: ")


# --- sample count and seed from the header, a sidecar and the caller ---------------------

def test_a_sidecar_gives_spp_and_seed(tmp_path):
    image_path = _fixture(tmp_path, "mitsuba.pfm", rename="render.pfm")
    (tmp_path / "render.pfm.json").write_text(json.dumps({"spp": 64, "seed": 3, "renderer": "other"}))
    image = read_image(image_path, spp=64)
    assert (image.spp, image.seed) == (64, 3)
    assert read_image(_fixture(tmp_path, "mitsuba.pfm", rename="bare.pfm"), spp=12).spp == 12


def test_sources_that_disagree_are_refused_naming_both_values(tmp_path):
    image_path = _fixture(tmp_path, "mitsuba_float32.exr")          # header: spp 16, seed 3
    sidecar = tmp_path / "mitsuba_float32.exr.json"
    sidecar.write_text('{"spp": 32}')
    _refused(image_path, f"spp disagrees: 16 in the header's spp but 32 in {sidecar}'s spp")
    sidecar.write_text('{"sample_count": 16, "seed": 4}')
    _refused(image_path, f"seed disagrees: 3 in the header's seed but 4 in {sidecar}'s seed")
    sidecar.unlink()
    _refused(image_path, "spp disagrees: 16 in the header's spp but 8 in the spp= argument", spp=8)


def test_a_malformed_sidecar_is_refused_naming_it_and_the_line(tmp_path):
    image_path = _fixture(tmp_path, "mitsuba.pfm")
    sidecar = tmp_path / "mitsuba.pfm.json"
    sidecar.write_text('{\n  "spp": 64,\n  "seed": 3,,\n}\n')
    _refused(image_path, f"sidecar {sidecar}, line 3 column .*not valid JSON")
    sidecar.write_text("[64, 3]")
    _refused(image_path, "holds a JSON list, not an object")
    sidecar.write_text('{"spp": "many"}')
    _refused(image_path, "spp 'many' in .* is not a whole number")
    sidecar.write_text('{"spp": 0}')
    _refused(image_path, "spp 0 in .* is not a sample count")


# --- faults in the values ----------------------------------------------------------------

def test_image_faults_count_and_place_nan_inf_and_negative_values(tmp_path):
    mean, variance = pattern(), variance_pattern()
    mean[1, 3, 1] = mean[4, 6, 0] = np.nan           # first NaN: x = 3, y = 1, G
    mean[2, 0, 2] = np.inf
    mean[3, 5, 0] = -np.inf
    mean[0, 6, 0] = -0.5                             # Inf is not also counted as negative
    variance[4, 2, 2] = -1e-3
    variance[0, 1, 0] = np.nan
    path = _write_exr(tmp_path / "faulty.exr", _rgb(mean) | _rgb(variance, "var."))
    assert image_faults(read_image(path)) == [
        f"{path}: 2 NaN values in the mean, the first at pixel (3, 1) channel G",
        f"{path}: 2 Inf values in the mean, the first at pixel (0, 2) channel B",
        f"{path}: 1 negative value in the mean, the first at pixel (6, 0) channel R",
        f"{path}: 1 NaN value in the variance, the first at pixel (1, 0) channel R",
        f"{path}: 1 negative value in the variance, the first at pixel (2, 4) channel B",
    ]


# --- Ctrl-C during an EXR read -----------------------------------------------------------

def test_keyboard_interrupt_during_an_exr_read_propagates(monkeypatch):
    def interrupted(path):
        raise KeyboardInterrupt
    monkeypatch.setattr(images, "read_channels", interrupted)
    with pytest.raises(KeyboardInterrupt):
        read_image(FIXTURES / "mitsuba_float32.exr")


@pytest.mark.parametrize("interrupt", [True, False])
def test_an_interrupt_openexr_swallowed_is_still_an_interrupt(monkeypatch, interrupt):
    previous = signal.getsignal(signal.SIGINT)
    signal.signal(signal.SIGINT, interrupts.remember)
    monkeypatch.setattr(images, "read_channels", swallowing_reader(interrupt))
    try:
        if interrupt:
            with pytest.raises(KeyboardInterrupt):
                read_image(FIXTURES / "mitsuba_float32.exr")
        else:
            _refused(FIXTURES / "mitsuba_float32.exr", "not a readable OpenEXR file.*initialization failed")
    finally:
        signal.signal(signal.SIGINT, previous)
