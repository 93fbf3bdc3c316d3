"""The one tonemap of the PNG previews and the figures (pathtracer.core.tonemap)."""
import numpy as np

from pathtracer.core.tonemap import auto_scale, to_8bit, tonemap
from pathtracer.io.output import write_png


def test_tonemap_is_the_srgb_curve_of_the_clipped_scaled_image():
    x = np.array([0.0, 0.001, 0.0031308, 0.2, 0.5, 1.0, 3.0])
    srgb = tonemap(x, 1.0)
    assert np.allclose(srgb[:3], 12.92 * x[:3])
    assert np.allclose(srgb[3:5], 1.055 * x[3:5] ** (1 / 2.4) - 0.055)
    assert srgb[-2] == srgb[-1] and np.isclose(srgb[-1], 1.0) and np.all(np.diff(srgb) >= 0)
    assert np.allclose(tonemap(x, 4.0), tonemap(4.0 * x, 1.0))


def test_broken_values_still_display_and_auto_scale_maps_the_99th_percentile_to_white():
    assert np.allclose(tonemap(np.array([np.nan, np.inf, -np.inf, -1.0]), 1.0), [0.0, 1.0, 0.0, 0.0])
    image = np.linspace(0.0, 2.0, 1001)
    scale = auto_scale(np.append(image, [np.nan, np.inf]))
    assert np.isclose(scale * np.percentile(image, 99), 1.0)
    assert auto_scale(np.zeros(4)) == 1.0 and auto_scale(np.array([np.nan])) == 1.0
    assert list(to_8bit(np.array([0.0, 0.5, 1.0]))) == [0, 128, 255]


def test_png_preview_uses_the_tonemap_with_exposure_in_stops(tmp_path):
    from PIL import Image
    rgb = np.random.default_rng(1).random((4, 5, 3)) * 0.3
    path = write_png(tmp_path / "x.png", rgb, exposure=1.0)
    assert np.array_equal(np.asarray(Image.open(path)), to_8bit(tonemap(rgb, 2.0)))
