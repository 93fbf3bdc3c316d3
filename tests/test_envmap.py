"""The ``envmap`` emitter, its 2-D sampling distribution and image reading.

Without Mitsuba: the documented mapping (which image column faces which
way), the chi-square fit of :class:`Distribution2D` and of the envmap's
direction sampling to the densities they report (the density MIS uses),
sRGB decoding of 8-bit images. Against Mitsuba 3 (``mitsuba`` marker): the
same uniform numbers give the same point of ``Hierarchical2D`` and the same
direction, density and weight of ``envmap``'s ``sample_direction``;
``eval`` and ``pdf_direction`` agree at random directions, for EXR and PNG
maps, with ``to_world``, ``scale`` and ``mis_compensation``.
"""
from pathlib import Path

import numpy as np
import pytest

from pathtracer import INTEGRATORS, load_scene, render
from pathtracer.core.sampling import Distribution2D
from pathtracer.emitters.envmap import EnvironmentMap
from pathtracer.io.bitmap import BitmapError, read_bitmap, srgb_to_linear
from pathtracer.scene import transform
from pathtracer.scene.errors import SceneError
from pathtracer.scene.load import builtin_scene_path
from tests.chi2 import chi2_plane, chi2_sphere
from tools.scenes.make_envmap import sky

SKY = Path(builtin_scene_path("envmap")).parent / "envmap-sky.exr"
AXIS = np.array([0.3, 1.0, 0.2]) / np.linalg.norm([0.3, 1.0, 0.2])
TO_WORLD = transform.rotate(AXIS, 40.0)


def random_directions(count, seed):
    v = np.random.default_rng(seed).normal(size=(count, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def write_png(path, pixels):
    from PIL import Image
    Image.fromarray(pixels).save(path)


def envmap_scene_xml(filename, extra=""):
    return f"""<scene version="3.0.0">
  <sensor type="perspective"><float name="fov" value="40"/>
    <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/>
      <rfilter type="box"/></film></sensor>
  <emitter type="envmap"><string name="filename" value="{filename}"/>{extra}</emitter>
</scene>"""


# --------------------------------------------------------------------------
# Images
# --------------------------------------------------------------------------

def test_srgb_curve_endpoints_and_midpoint():
    np.testing.assert_allclose(srgb_to_linear(np.array([0.0, 1.0, 0.04045])), [0.0, 1.0, 0.04045 / 12.92])
    np.testing.assert_allclose(srgb_to_linear(np.array([0.5])), [0.214041], rtol=1e-5)


def test_png_is_decoded_to_linear_unless_raw(tmp_path):
    pixels = np.array([[[0, 128, 255], [64, 32, 16]]], dtype=np.uint8)
    write_png(tmp_path / "a.png", pixels)
    np.testing.assert_allclose(read_bitmap(tmp_path / "a.png", raw=True), pixels / 255.0)
    np.testing.assert_allclose(read_bitmap(tmp_path / "a.png"), srgb_to_linear(pixels / 255.0))
    write_png(tmp_path / "grey.png", pixels[:, :, 0])
    assert read_bitmap(tmp_path / "grey.png").shape == (1, 2, 1)


def test_exr_is_read_as_stored():
    np.testing.assert_array_equal(read_bitmap(SKY), sky().astype(np.float64))


def test_radiance_hdr_flat_and_run_length_scanlines(tmp_path):
    """RGBE: value = mantissa * 2^(exponent - 136); exponent 0 is black."""
    header = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +X 8\n"
    flat = bytes([128, 64, 32, 129] * 7 + [200, 0, 0, 0])                  # 128 * 2^-7 = 1, ...
    runs = bytes([2, 2, 0, 8]) + bytes([128 + 8, 100, 128 + 8, 50]) + bytes([8] + list(range(8))) \
        + bytes([128 + 8, 140])
    (tmp_path / "a.hdr").write_bytes(header + flat + runs)
    image = read_bitmap(tmp_path / "a.hdr")
    assert image.shape == (2, 8, 3)
    np.testing.assert_allclose(image[0, :7], np.tile([1.0, 0.5, 0.25], (7, 1)))
    np.testing.assert_array_equal(image[0, 7], [0.0, 0.0, 0.0])
    np.testing.assert_allclose(image[1], np.column_stack((np.full(8, 100.0), np.full(8, 50.0), np.arange(8.0))) * 16)
    (tmp_path / "cut.hdr").write_bytes(header + flat + runs[:9])
    with pytest.raises(BitmapError, match="truncated or corrupt"):
        read_bitmap(tmp_path / "cut.hdr")


def test_unreadable_images_raise_bitmap_error(tmp_path):
    (tmp_path / "bad.png").write_bytes(b"not an image")
    for name in ("missing.exr", "bad.png"):
        with pytest.raises(BitmapError, match=name):
            read_bitmap(tmp_path / name)


def test_envmap_loader_errors_name_the_line(tmp_path):
    cases = {
        "missing.exr": ("", "file not found: \"missing.exr\""),
        str(SKY): ('<float name="scale" value="2"/><transform name="to_world"><scale value="2"/></transform>',
                   "must not scale"),
    }
    for filename, (extra, message) in cases.items():
        path = tmp_path / "scene.xml"
        path.write_text(envmap_scene_xml(filename, extra))
        with pytest.raises(SceneError, match=message) as info:
            load_scene(str(path))
        assert "scene.xml:5" in str(info.value)


# --------------------------------------------------------------------------
# Distribution2D
# --------------------------------------------------------------------------

def bumpy_grid(shape=(9, 13), seed=4):
    values = np.random.default_rng(seed).random(shape) ** 3
    values[2, :] = 0.0          # a zero row: patches that touch it fade to 0
    values[:, 5] *= 20          # a bright column
    return values


def test_distribution2d_density_integrates_to_one_and_matches_sample():
    dist = Distribution2D(bumpy_grid())
    g = (np.arange(400) + 0.5) / 400
    xy = np.stack(np.meshgrid(g, g), axis=-1).reshape(-1, 2)
    assert abs(dist.pdf(xy).mean() - 1.0) < 1e-3
    points, pdf = dist.sample(np.random.default_rng(1).random((2000, 2)))
    np.testing.assert_allclose(pdf, dist.pdf(points), rtol=1e-9)


@pytest.mark.statistical(assertions=1)
def test_distribution2d_samples_follow_its_density():
    dist = Distribution2D(bumpy_grid())
    result = chi2_plane(lambda u: dist.sample(u)[0], dist.pdf, bounds=((0, 1), (0, 1)),
                        n_samples=200_000, res=(24, 16), subdiv=8, seed=7)
    assert result.passed, result.message


def test_distribution2d_of_zeros_samples_nothing():
    points, pdf = Distribution2D(np.zeros((3, 4))).sample(np.full((5, 2), 0.5))
    assert np.all(pdf == 0) and np.all(np.isfinite(points))


# --------------------------------------------------------------------------
# The envmap emitter (no Mitsuba)
# --------------------------------------------------------------------------

def test_mapping_puts_the_sun_towards_plus_x_and_the_top_row_up():
    """The documented convention: u = 0.25 faces +x, v = 0 is +y (as Mitsuba's figure shows)."""
    env = EnvironmentMap(sky())
    sun = np.array([[np.sin(0.3 * np.pi), np.cos(0.3 * np.pi), 0.0]])    # u = 0.25, v = 0.3
    np.testing.assert_allclose(env.direction_to_uv(sun), [[0.25, 0.3]], atol=1e-12)
    assert env.eval(sun)[0, 0] > 5 and env.eval(-sun)[0, 0] < 1
    # Straight up is the top row: the zenith blue of the sky gradient.
    np.testing.assert_allclose(env.eval(np.array([[0.0, 1.0, 0.0]]))[0], [0.25, 0.45, 1.0], atol=1e-4)


def test_pixel_centres_are_returned_exactly():
    env = EnvironmentMap(sky(), scale=2.0)
    j, i = np.meshgrid(np.arange(32), np.arange(16))
    uv = np.stack(((j.ravel() + 0.5) / 32, i.ravel() / 15), axis=1)
    np.testing.assert_allclose(env.lookup(uv), 2.0 * sky().reshape(-1, 3), rtol=1e-6)


@pytest.mark.statistical(assertions=1)
def test_envmap_sampling_follows_its_pdf():
    env = EnvironmentMap(sky(), to_world=TO_WORLD)
    result = chi2_sphere(lambda u: env.sample(u[:, :2])[0], env.pdf, n_samples=200_000,
                         res=(24, 32), axis=TO_WORLD[:3, 1], subdiv=(16, 8), seed=11)
    assert result.passed, result.message


def test_envmap_sample_weight_is_radiance_over_pdf():
    env = EnvironmentMap(sky(), scale=1.5, to_world=TO_WORLD)
    wo, pdf, radiance = env.sample(np.random.default_rng(2).random((3000, 2)))
    np.testing.assert_allclose(np.linalg.norm(wo, axis=1), 1.0, rtol=1e-12)
    np.testing.assert_allclose(pdf, env.pdf(wo), rtol=1e-6)
    np.testing.assert_allclose(radiance, env.eval(wo), rtol=1e-6, atol=1e-12)


# --------------------------------------------------------------------------
# Against Mitsuba 3
# --------------------------------------------------------------------------

@pytest.mark.mitsuba
def test_distribution2d_equals_mitsubas_hierarchical2d(mi):
    values = bumpy_grid((16, 33))
    theirs = mi.Hierarchical2D0(values.astype(np.float32))
    ours = Distribution2D(values.astype(np.float32))
    u = np.random.default_rng(3).random((500, 2))
    points, pdf = ours.sample(u)
    ref = [theirs.sample(mi.Point2f(*x)) for x in u]
    np.testing.assert_allclose(points, [list(r[0]) for r in ref], atol=5e-5)
    np.testing.assert_allclose(pdf, [r[1] for r in ref], rtol=1e-3, atol=1e-6)
    np.testing.assert_allclose(ours.pdf(u), [theirs.eval(mi.Point2f(*x)) for x in u], rtol=1e-3, atol=1e-6)


def compare_with_mitsuba(mi, tmp_path, filename, extra, seed):
    """eval, pdf_direction and sample_direction of our and Mitsuba's envmap from the same file."""
    import drjit as dr

    path = tmp_path / "scene.xml"
    path.write_text(envmap_scene_xml(filename, extra))
    ours = load_scene(str(path)).environment
    theirs = mi.load_file(str(path)).environment()
    it = dr.zeros(mi.Interaction3f)
    v = random_directions(300, seed)
    value, density = [], []
    for d in v:
        si = dr.zeros(mi.SurfaceInteraction3f)
        si.wi = mi.Vector3f(*(-d))
        value.append(list(theirs.eval(si)))
        ds = mi.DirectionSample3f()
        ds.d = mi.Vector3f(*d)
        density.append(theirs.pdf_direction(it, ds))
    np.testing.assert_allclose(ours.eval(v), value, rtol=1e-4, atol=1e-6)
    np.testing.assert_allclose(ours.pdf(v), density, rtol=1e-3)

    u = np.random.default_rng(seed + 1).random((300, 2))
    wo, pdf, radiance = ours.sample(u)
    ref = [theirs.sample_direction(it, mi.Point2f(*x)) for x in u]
    np.testing.assert_allclose(wo, [list(ds.d) for ds, _ in ref], atol=1e-4)
    np.testing.assert_allclose(pdf, [ds.pdf for ds, _ in ref], rtol=1e-3)
    np.testing.assert_allclose(radiance / pdf[:, None], [list(w) for _, w in ref], rtol=2e-3)


ROTATED = ('<float name="scale" value="1.7"/><transform name="to_world">'
           f'<rotate x="{AXIS[0]:.17g}" y="{AXIS[1]:.17g}" z="{AXIS[2]:.17g}" angle="40"/></transform>')


@pytest.mark.mitsuba
@pytest.mark.parametrize("extra", ["", ROTATED, '<boolean name="mis_compensation" value="true"/>'],
                         ids=["plain", "rotated-scaled", "mis-compensation"])
def test_envmap_exr_matches_mitsuba(mi, tmp_path, extra):
    compare_with_mitsuba(mi, tmp_path, str(SKY), extra, seed=20)


@pytest.mark.mitsuba
def test_radiance_hdr_reads_as_mitsuba_reads_it(mi, tmp_path):
    """A file Mitsuba writes (run-length encoded) decodes to exactly Mitsuba's values."""
    image = (np.random.default_rng(5).random((6, 40, 3)) ** 4 * [1.0, 10.0, 1000.0]).astype(np.float32)
    image[0, 0] = 0.0
    mi.Bitmap(image).write(str(tmp_path / "sky.hdr"))
    np.testing.assert_array_equal(read_bitmap(tmp_path / "sky.hdr"), np.array(mi.Bitmap(str(tmp_path / "sky.hdr"))))


@pytest.mark.mitsuba
def test_envmap_png_matches_mitsuba(mi, tmp_path):
    """An 8-bit map is sRGB-decoded to linear radiance, as Mitsuba does."""
    pixels = (np.clip(sky() / 6.0, 0, 1) ** 0.5 * 255).astype(np.uint8)
    write_png(tmp_path / "sky.png", pixels)
    compare_with_mitsuba(mi, tmp_path, str(tmp_path / "sky.png"), "", seed=30)


@pytest.mark.parametrize("integrator", sorted(set(INTEGRATORS) - {"light", "bdpt"}))   # no envmap light paths
def test_hide_emitters_hides_the_environment_from_camera_rays(integrator):
    """As in Mitsuba: escaped camera rays see black; the map still lights the scene."""
    scene = load_scene("envmap", width=8, height=8)
    shown = render(scene, integrator=integrator, spp=2, seed=1, max_depth=3)
    hidden = render(scene, integrator=integrator, spp=2, seed=1, max_depth=3, hide_emitters=True)
    assert np.all(shown.mean[0] > 0.1) and np.all(hidden.mean[0] == 0)      # the top row is sky
    assert hidden.mean[-1].mean() > 0.1                                      # the lit floor
