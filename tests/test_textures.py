"""Textures: image reading, bitmap/checkerboard lookups, uv at hits, textured BSDFs.

Tests taking ``mi`` compare with Mitsuba 3.9.1 in ``scalar_rgb``: the
same image files and XML, looked up at the same (float32) coordinates, and
``SurfaceInteraction3f.uv`` of the same rays against our
:func:`pathtracer.geometry.texture_uv`.
"""
from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from pathtracer import load_scene
from pathtracer.bsdfs import Conductor, Dielectric, Diffuse, RoughConductor, TwoSided
from pathtracer.io.bitmap import BitmapError, read_bitmap, srgb_to_linear
from pathtracer.scene import transform
from pathtracer.shapes.intersect import intersect, texture_uv
from pathtracer.textures import BitmapTexture, Checkerboard, ConstantTexture, wrap_index
from tests.test_serialized import shape_record, write_serialized

FILM = ('<film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/>'
        '<rfilter type="box"/></film>')
SENSOR = f'<sensor type="perspective"><float name="fov" value="40"/>{FILM}</sensor>'


def _f32(x) -> np.ndarray:
    """Round to float32 so that both sides look up exactly the same coordinates."""
    return np.asarray(x, np.float32).astype(np.float64)


def _image(tmp_path, seed=1, shape=(5, 7, 3), name="tex.png") -> str:
    texels = np.random.default_rng(seed).integers(0, 256, shape, dtype=np.uint8)
    path = tmp_path / name
    Image.fromarray(texels if shape[2] > 1 else texels[:, :, 0]).save(path)
    return str(path)


def _exr(tmp_path, data: np.ndarray, name="tex.exr") -> str:
    import OpenEXR

    path = tmp_path / name
    channels = {c: np.ascontiguousarray(data[:, :, i], np.float32) for i, c in enumerate("RGB")}
    with OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION,
                       "type": OpenEXR.scanlineimage}, channels) as exr:
        exr.write(str(path))
    return str(path)


# -- reading images -------------------------------------------------------------

def test_png_is_decoded_from_srgb_unless_raw(tmp_path):
    path = _image(tmp_path)
    raw = read_bitmap(path, raw=True)
    stored = np.asarray(Image.open(path), np.float64) / 255.0
    np.testing.assert_array_equal(raw, stored)
    np.testing.assert_allclose(read_bitmap(path), srgb_to_linear(stored), rtol=1e-15)
    # The sRGB curve's fixed points and its linear toe.
    np.testing.assert_allclose(srgb_to_linear([0.0, 1.0, 0.04]), [0.0, 1.0, 0.04 / 12.92])


def test_exr_is_linear_and_keeps_values_above_one(tmp_path):
    data = np.random.default_rng(2).uniform(-0.5, 4.0, (3, 4, 3)).astype(np.float32)
    np.testing.assert_array_equal(read_bitmap(_exr(tmp_path, data)), data)
    np.testing.assert_array_equal(read_bitmap(_exr(tmp_path, data), raw=True), data)


def test_grey_and_alpha_channels(tmp_path):
    grey = read_bitmap(_image(tmp_path, shape=(4, 3, 1)))
    assert grey.shape == (4, 3, 1)
    rgba = read_bitmap(_image(tmp_path, shape=(4, 3, 4), name="a.png"), raw=True)
    assert rgba.shape == (4, 3, 3)      # alpha dropped when reading
    # Grey is repeated to RGB; texels are held in float32.
    uv = np.array([[0.5 / 3, 0.5 / 4]])
    np.testing.assert_array_equal(BitmapTexture(grey).eval(uv), _f32(np.repeat(grey[0, 0], 3))[None])
    np.testing.assert_array_equal(BitmapTexture(rgba).eval(uv), _f32(rgba[0, 0, :3])[None])


def test_unreadable_image(tmp_path):
    (tmp_path / "tex.bmp").write_bytes(b"not an image")
    with pytest.raises(BitmapError, match="not a readable image"):
        read_bitmap(tmp_path / "tex.bmp")


# -- lookups ------------------------------------------------------------------------

def test_wrap_modes():
    i = np.arange(-7, 8)
    np.testing.assert_array_equal(wrap_index(i, 3, "repeat"), np.mod(i, 3))
    np.testing.assert_array_equal(wrap_index(i, 3, "clamp"), np.clip(i, 0, 2))
    # Mirror: period 6, the edge texel repeated at each reflection.
    np.testing.assert_array_equal(wrap_index(np.arange(-3, 9), 3, "mirror"),
                                  [2, 1, 0, 0, 1, 2, 2, 1, 0, 0, 1, 2])


def test_bilinear_hits_texels_at_their_centres_and_nearest_is_piecewise_constant():
    data = _f32(np.random.default_rng(3).random((4, 6, 3)))
    y, x = np.mgrid[0:4, 0:6]
    centres = np.stack(((x.ravel() + 0.5) / 6, (y.ravel() + 0.5) / 4), axis=1)
    texels = data.reshape(-1, 3)
    np.testing.assert_allclose(BitmapTexture(data).eval(centres), texels, atol=1e-15)
    jitter = centres + np.random.default_rng(4).uniform(-0.49, 0.49, centres.shape) / [6, 4]
    np.testing.assert_array_equal(BitmapTexture(data, "nearest").eval(jitter), texels)
    # Row 0 of the image is at small v (no vertical flip in the lookup).
    assert np.array_equal(BitmapTexture(data, "nearest").eval([[0.01, 0.01]])[0], data[0, 0])


def test_checkerboard_and_to_uv():
    board = Checkerboard([1, 0, 0], [0, 0, 1], to_uv=transform.scale([2, 2, 1]))
    # Scaled by 2, (0.1, 0.1) -> (0.2, 0.2): both fractional parts <= 1/2 -> color0.
    values = board.eval([[0.1, 0.1], [0.3, 0.1], [0.3, 0.3], [0.1, 0.3]])
    np.testing.assert_array_equal(values, [[1, 0, 0], [0, 0, 1], [1, 0, 0], [0, 0, 1]])
    # A 4x4 translate moves uv; a 9-value matrix's third column does not.
    shifted = Checkerboard(1.0, 0.0, to_uv=transform.translate([0.5, 0, 0]))
    assert shifted.eval([[0.1, 0.1]])[0, 0] == 0.0
    matrix = Checkerboard(1.0, 0.0, to_uv=transform.from_values([1, 0, 0.5, 0, 1, 0, 0, 0, 1]))
    assert matrix.eval([[0.1, 0.1]])[0, 0] == 1.0
    assert np.all(ConstantTexture(0.3).eval(np.zeros((2, 2))) == 0.3)


def test_undefined_uv_gives_black():
    tex = BitmapTexture(np.ones((2, 2, 3)))
    np.testing.assert_array_equal(tex.eval([[np.nan, np.nan], [0.5, 0.5]]), [[0, 0, 0], [1, 1, 1]])


# -- textured BSDFs -----------------------------------------------------------------

def test_constant_bsdfs_keep_the_fast_path():
    for bsdf in (Diffuse(0.5), Diffuse(ConstantTexture([0.1, 0.2, 0.3])), Conductor(),
                 Dielectric(), TwoSided(Diffuse(0.2))):
        assert not bsdf.textured
    assert isinstance(Diffuse(ConstantTexture(0.3)).reflectance, np.ndarray)


def test_bound_bsdf_equals_the_constant_bsdf_of_each_hit():
    tex = BitmapTexture(np.random.default_rng(5).random((3, 5, 3)))
    rng = np.random.default_rng(6)
    n = 50
    uv = rng.random((n, 2))
    wi = np.column_stack((rng.uniform(-0.5, 0.5, (n, 2)), np.full(n, 0.8)))
    wi /= np.linalg.norm(wi, axis=1)[:, None]
    u1, u2 = rng.random(n), rng.random((n, 2))
    colour = tex.eval(uv)
    for textured, constant in ((TwoSided(Diffuse(tex)), lambda c: TwoSided(Diffuse(c))),
                               (Conductor(tex), Conductor),
                               (RoughConductor("ggx", 0.3, 0.3, tex),
                                lambda c: RoughConductor("ggx", 0.3, 0.3, c)),
                               (Dielectric(1.5, 1.0, tex, tex), lambda c: Dielectric(1.5, 1.0, c, c))):
        assert textured.textured
        bound = textured.at(uv)
        got = bound.sample(wi, u1, u2)
        value = bound.eval(wi, got.wo)
        for k in range(0, n, 7):
            one = constant(colour[k])
            want = one.sample(wi[k:k + 1], u1[k:k + 1], u2[k:k + 1])
            np.testing.assert_allclose(got.weight[k], want.weight[0], rtol=1e-14)
            np.testing.assert_allclose(got.wo[k], want.wo[0], rtol=1e-14)
            np.testing.assert_allclose(value[k], one.eval(wi[k:k + 1], got.wo[k:k + 1])[0],
                                       rtol=1e-14)
        assert np.any(got.weight != got.weight[0])  # the colour does vary over the hits


# -- scenes ---------------------------------------------------------------------------

def _scene_file(tmp_path, body: str) -> str:
    path = tmp_path / "scene.xml"
    path.write_text(f'<scene version="3.0.0">{SENSOR}{body}</scene>')
    return str(path)


def test_textures_are_shared_through_refs_and_built_once(tmp_path):
    _image(tmp_path)
    path = _scene_file(tmp_path, """
        <texture type="bitmap" id="img"><string name="filename" value="tex.png"/></texture>
        <bsdf type="diffuse" id="a"><ref id="img" name="reflectance"/></bsdf>
        <bsdf type="conductor" id="b"><ref name="specular_reflectance" id="img"/></bsdf>
        <shape type="rectangle"><ref id="a"/></shape>
        <shape type="sphere"><ref id="b"/></shape>""")
    scene = load_scene(path)
    assert scene.bsdfs[0].reflectance is scene.bsdfs[1].specular_reflectance


# Shapes whose uv Mitsuba and we must agree on: (XML, periodic uv columns).
SHAPES = {
    "rectangle": ('<shape type="rectangle"><boolean name="flip_normals" value="true"/>'
                  '<transform name="to_world"><scale x="1.5" y="0.7"/><rotate x="1" y="0" z="0" '
                  'angle="30"/></transform></shape>', ()),
    "cube": ('<shape type="cube"><transform name="to_world"><scale x="0.8" y="1.2" z="1"/>'
             '<rotate x="0.6" y="0.8" z="0" angle="40"/></transform></shape>', ()),
    "sphere": ('<shape type="sphere"><float name="radius" value="0.7"/><point name="center" '
               'x="0.1" y="0" z="0.2"/><transform name="to_world"><rotate x="0" y="0.6" z="0.8" '
               'angle="70"/><translate x="0.2"/></transform></shape>', (0,)),
    "disk": ('<shape type="disk"><transform name="to_world"><scale x="1.3" y="0.9"/>'
             '<rotate x="1" y="0" z="0" angle="-50"/></transform></shape>', (1,)),
    "obj": ('<shape type="obj"><string name="filename" value="quad.obj"/></shape>', ()),
    "obj no flip": ('<shape type="obj"><string name="filename" value="quad.obj"/>'
                    '<boolean name="flip_tex_coords" value="false"/></shape>', ()),
    "obj without vt": ('<shape type="obj"><string name="filename" value="plain.obj"/></shape>', ()),
    "ply u v": ('<shape type="ply"><string name="filename" value="uv.ply"/></shape>', ()),
    "ply s t flipped": ('<shape type="ply"><string name="filename" value="st.ply"/>'
                        '<boolean name="flip_tex_coords" value="true"/></shape>', ()),
    "serialized": ('<shape type="serialized"><string name="filename" value="uv.serialized"/>'
                   '</shape>', ()),
}
OBJ_VT = ("v -1 -1 0.1\nv 1 -1 -0.2\nv 1 1 0\nv -1 1 0.3\nv 0 0 0.8\n"
          "vt 0.1 0.2\nvt 0.9 0.3\nvt 0.8 0.7\nvt 0.2 0.95\nvt 0.5 0.5 0\n"
          "f 1/1 2/2 5/5\nf 2/2 3/3 5/5\nf 3/3 4/4 5/5\nf 4/4 1/1 5/5\n")


def _ply(u: str, v: str) -> str:
    return ("ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
            f"property float z\nproperty float {u}\nproperty float {v}\nelement face 2\n"
            "property list uchar int vertex_indices\nend_header\n"
            "-1 -1 0 0.1 0.2\n1 -1 0.2 0.9 0.3\n1 1 0 0.8 0.7\n-1 1 -0.1 0.2 0.95\n3 0 1 2\n3 0 2 3\n")


def _rays(count: int, seed: int):
    """Rays from a sphere of radius 4 towards random points near the origin (float32 values)."""
    rng = np.random.default_rng(seed)
    o = rng.normal(size=(count, 3))
    o = 4.0 * o / np.linalg.norm(o, axis=1)[:, None]
    d = rng.uniform(-0.9, 0.9, (count, 3)) - o
    return _f32(o), _f32(d / np.linalg.norm(d, axis=1)[:, None])


@pytest.mark.mitsuba
@pytest.mark.parametrize("shape", sorted(SHAPES))
def test_uv_at_hits_matches_mitsuba(mi, tmp_path, shape):
    (tmp_path / "quad.obj").write_text(OBJ_VT)
    (tmp_path / "plain.obj").write_text("\n".join(l for l in OBJ_VT.splitlines()
                                                   if not l.startswith(("vt", "f")))
                                        + "\nf 1 2 5\nf 2 3 5\nf 3 4 5\nf 4 1 5\n")
    (tmp_path / "uv.ply").write_text(_ply("u", "v"))
    (tmp_path / "st.ply").write_text(_ply("s", "t"))
    write_serialized(tmp_path / "uv.serialized", [shape_record(
        [[-1, -1, 0.1], [1, -1, -0.2], [1, 1, 0], [-1, 1, 0.3]], [[0, 1, 2], [0, 2, 3]],
        uvs=[[0.1, 0.2], [0.9, 0.3], [0.8, 0.7], [0.2, 0.95]])])
    xml, periodic = SHAPES[shape]
    path = _scene_file(tmp_path, xml)
    o, d = _rays(400, seed=len(shape))
    hit = intersect(load_scene(path), o, d)
    theirs = mi.load_file(path)
    mask, uv = [], []
    for k in range(len(o)):
        si = theirs.ray_intersect(mi.Ray3f(o[k], d[k]))
        mask.append(bool(si.is_valid()))
        uv.append(np.array(si.uv))
    mask, uv = np.array(mask), np.array(uv)
    # Rays through an edge may hit on one side only: those must be rare.
    assert np.count_nonzero(mask != hit.valid) <= 2
    both = np.flatnonzero(mask & hit.valid)
    assert len(both) > 100
    ours = texture_uv(load_scene(path), hit, both)
    diff = np.abs(ours - uv[both])
    for column in periodic:  # angles: 0 and 1 are the same place
        diff[:, column] = np.minimum(diff[:, column], 1.0 - diff[:, column])
    assert diff.max() < 2e-5, (shape, diff.max(), both[np.argmax(diff.max(axis=1))])


FILTER_WRAP_RAW = [(f, w, raw) for f in ("nearest", "bilinear") for w in ("repeat", "mirror", "clamp")
                   for raw in (False, True)]
TO_UV = {
    "scale": '<scale x="2.5" y="0.6"/>',
    "translate": '<translate x="0.3" y="-0.45"/>',
    "rotate": '<rotate z="1" angle="30"/>',
    "matrix": '<matrix value="2 0.5 0.25  0.1 3 0.4  0 0 1"/>',
}


def _mitsuba_lookups(mi, xml: str, uv: np.ndarray) -> np.ndarray:
    texture = mi.load_string(xml)
    si = mi.SurfaceInteraction3f()
    out = np.empty((len(uv), 3))
    for k, (u, v) in enumerate(uv):
        si.uv = mi.Point2f(u, v)
        out[k] = np.array(texture.eval(si))
    return out


def _lookup_points(count=200, seed=7):
    return _f32(np.random.default_rng(seed).uniform(-1.5, 2.5, (count, 2)))


def _texture_xml(kind: str, body: str) -> str:
    return f'<texture version="3.0.0" type="{kind}">{body}</texture>'


@pytest.mark.mitsuba
@pytest.mark.parametrize("filter_type, wrap_mode, raw", FILTER_WRAP_RAW)
def test_bitmap_lookups_match_mitsuba(mi, tmp_path, filter_type, wrap_mode, raw):
    path = _image(tmp_path)
    uv = _lookup_points()
    xml = _texture_xml("bitmap", f'<string name="filename" value="{path}"/>'
                       f'<string name="filter_type" value="{filter_type}"/>'
                       f'<string name="wrap_mode" value="{wrap_mode}"/>'
                       f'<boolean name="raw" value="{str(raw).lower()}"/>')
    ours = BitmapTexture(read_bitmap(path, raw=raw), filter_type, wrap_mode).eval(uv)
    np.testing.assert_allclose(ours, _mitsuba_lookups(mi, xml, uv), rtol=1e-5, atol=2e-6)


@pytest.mark.mitsuba
@pytest.mark.parametrize("to_uv", sorted(TO_UV))
def test_to_uv_matches_mitsuba(mi, tmp_path, to_uv):
    """Both plugins, loaded from the same XML by both renderers."""
    image = _image(tmp_path)
    uv = _lookup_points(150, seed=8)
    for body in (f'<string name="filename" value="{image}"/>',
                 '<rgb name="color0" value="0.9, 0.5, 0.1"/><rgb name="color1" value="0.05"/>'):
        kind = "bitmap" if "filename" in body else "checkerboard"
        inner = f'{body}<transform name="to_uv">{TO_UV[to_uv]}</transform>'
        xml = _texture_xml(kind, inner)
        nested = f'<texture type="{kind}" name="reflectance">{inner}</texture>'
        path = _scene_file(tmp_path, f'<shape type="sphere"><bsdf type="diffuse">{nested}'
                                     '</bsdf></shape>')
        ours = load_scene(path).bsdfs[0].reflectance.eval(uv)
        np.testing.assert_allclose(ours, _mitsuba_lookups(mi, xml, uv), rtol=1e-5, atol=2e-6,
                                   err_msg=kind)


@pytest.mark.mitsuba
def test_exr_jpeg_grey_alpha_and_16_bit_images_match_mitsuba(mi, tmp_path):
    uv = _lookup_points(100, seed=9)
    rng = np.random.default_rng(10)
    jpeg = tmp_path / "tex.jpg"
    Image.fromarray(rng.integers(0, 256, (6, 5, 3), dtype=np.uint8)).save(jpeg, quality=90)
    grey16 = tmp_path / "grey16.png"
    Image.fromarray(rng.integers(0, 65536, (4, 5), dtype=np.uint16)).save(grey16)
    paths = [_exr(tmp_path, rng.uniform(0, 3, (4, 6, 3))), str(jpeg),
             _image(tmp_path, shape=(5, 4, 1), name="grey.png"),
             _image(tmp_path, shape=(3, 4, 4), name="rgba.png"), str(grey16)]
    for path in paths:
        for raw in (False, True):
            xml = _texture_xml("bitmap", f'<string name="filename" value="{path}"/>'
                               f'<boolean name="raw" value="{str(raw).lower()}"/>')
            np.testing.assert_allclose(BitmapTexture(read_bitmap(path, raw=raw)).eval(uv),
                                       _mitsuba_lookups(mi, xml, uv), rtol=1e-5, atol=2e-6,
                                       err_msg=f"{path} raw={raw}")
