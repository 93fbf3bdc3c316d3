"""Heterogeneous media: the .vol reader, grid lookups, closed forms and Mitsuba's volpath.

Hand values: the reader's axis order ((z * ny + y) * nx + x) on a grid of unequal sides;
trilinear, nearest and the three wrap modes on a grid holding the linear function
x + 2 y + 4 z of its cell indices. Closed forms: shadow rays through a slab whose grid
has two densities along the ray have E[T] = exp(-sigma_1 d / 2 - sigma_2 d / 2) per
channel (ratio tracking); an emitter seen through that slab with albedo 0 keeps that
transmittance on camera paths (delta tracking's null and real collisions); a
``constvolume`` medium renders the homogeneous medium's image in mean. Against Mitsuba's
``volpath``: the committed reference of ``hetero-smoke`` (mean and variance: the same
estimator) and a live render of a scene written here (``use_grid_bbox``, ``mirror``).
"""
import re
import struct

import numpy as np
import pytest
from scipy.stats import norm

from mitsuba_refs.report.wording import verdict_line
from mitsuba_refs.stats import MeanTestOptions, VarianceTestOptions, compare_means, compare_variances
from mitsuba_refs.verdicts.compare import compare
from pathtracer import load_scene, render
from pathtracer.core.rng import RandomStream, sample_keys
from pathtracer.io.vol import VolFormatError, read_vol, write_vol
from pathtracer.media.homogeneous import shadow_transmittance
from pathtracer.scene.errors import SceneError
from pathtracer.volumes import grid_lookup
from tests.budget import ALPHA
from tests.scenes import medium_ball_on_floor
from tests.test_analytic import assert_matches, footprint_average
from tests.test_media import LIGHT_WALL, write_scene

VOLUMETRIC = ("volpath", "volpath_phase")


# -- the .vol reader --------------------------------------------------------------------------

def test_vol_reader_reads_mitsubas_layout(tmp_path):
    """Bytes written by hand: value k of the file is cell (x, y, z, c) with
    k = ((z * ny + y) * nx + x) * channels + c."""
    nx, ny, nz, ch = 3, 2, 4, 3
    values = np.arange(nx * ny * nz * ch, dtype="<f4")
    path = tmp_path / "g.vol"
    path.write_bytes(b"VOL" + struct.pack("<B", 3) + struct.pack("<iiiii", 1, nx, ny, nz, ch)
                     + struct.pack("<6f", -1, -2, -3, 1, 2, 3) + values.tobytes())
    grid = read_vol(str(path))
    assert grid.resolution == (3, 2, 4) and grid.channels == 3
    np.testing.assert_array_equal(grid.bbox, [[-1, -2, -3], [1, 2, 3]])
    for x, y, z, c in [(0, 0, 0, 0), (2, 0, 0, 1), (1, 1, 0, 2), (2, 1, 3, 0), (0, 1, 2, 1)]:
        assert grid.data[z, y, x, c] == ((z * ny + y) * nx + x) * ch + c
    write_vol(str(tmp_path / "again.vol"), grid.data, grid.bbox)
    assert (tmp_path / "again.vol").read_bytes() == path.read_bytes()


@pytest.mark.parametrize("mutate,message", [
    (lambda b: b"VOX" + b[3:], "does not start with 'VOL'"),
    (lambda b: b[:3] + b"\x02" + b[4:], "version 2"),
    (lambda b: b[:4] + struct.pack("<i", 2) + b[8:], "encoding 2"),
    (lambda b: b[:20] + struct.pack("<i", 2) + b[24:], "2 channels"),
    (lambda b: b[:-4], "needs 80"),
    (lambda b: b[:48] + struct.pack("<f", np.nan) + b[52:], "non-finite"),
    (lambda b: b[:10], "shorter than the 48-byte header"),
])
def test_vol_reader_refuses_bad_files(tmp_path, mutate, message):
    path = tmp_path / "g.vol"
    write_vol(str(path), np.ones((2, 2, 2)))
    path.write_bytes(mutate(path.read_bytes()))
    with pytest.raises(VolFormatError, match=message):
        read_vol(str(path))


# -- lookups ----------------------------------------------------------------------------------

#: A 2 x 2 x 2 grid whose cell (x, y, z) holds x + 2 y + 4 z.
LINEAR = (np.arange(2)[None, None, :] + 2 * np.arange(2)[None, :, None]
          + 4 * np.arange(2)[:, None, None]).astype(float)[..., None]


@pytest.mark.parametrize("u,filter_type,wrap_mode,expected", [
    ((0.5, 0.5, 0.5), "trilinear", "clamp", 3.5),       # s = u R - 1/2 = (0.5, 0.5, 0.5)
    ((0.25, 0.25, 0.25), "trilinear", "clamp", 0.0),    # the first cell's centre
    ((0.75, 0.25, 0.75), "trilinear", "clamp", 5.0),
    ((0.1, 0.6, 0.9), "trilinear", "clamp", 5.4),       # s = (-0.3, 0.7, 1.3): x and z clamped
    ((0.1, 0.6, 0.9), "trilinear", "repeat", 4.5),      # x: 0.3 * 1 + 0.7 * 0; z: 0.7 * 4 + 0.3 * 0
    ((0.1, 0.6, 0.9), "trilinear", "mirror", 5.4),      # one cell out: mirror = clamp
    ((-0.3, 0.6, 0.9), "trilinear", "mirror", 0.1 + 1.4 + 4),   # x: s = -1.1, cells -2, -1 -> 1, 0
    ((-0.3, 0.6, 0.9), "trilinear", "repeat", 0.9 + 1.4 + 2.8),  # x: cells -2, -1 -> 0, 1
    ((0.1, 0.6, 0.9), "nearest", "clamp", 6.0),         # cell (0, 1, 1)
    ((1.2, 0.6, -0.4), "nearest", "clamp", 3.0),        # cell (2, 1, -1) -> (1, 1, 0)
    ((1.2, 0.6, -0.4), "nearest", "repeat", 6.0),       # -> (0, 1, 1)
    ((1.2, 0.6, -0.4), "nearest", "mirror", 3.0),       # -> (1, 1, 0)
])
def test_grid_lookup_hand_values(u, filter_type, wrap_mode, expected):
    value = grid_lookup(LINEAR, np.array([u]), filter_type, wrap_mode)
    assert value.shape == (1, 1)
    assert value[0, 0] == pytest.approx(expected, abs=1e-12)


def test_gridvolume_places_its_grid_with_to_world_and_use_grid_bbox(tmp_path):
    """World point -> local: to_world inverted, then (use_grid_bbox) the file's box onto the
    unit cube; 1 channel reads the same in R, G, B; the majorant is scale x max."""
    write_vol(str(tmp_path / "lin.vol"), LINEAR, bbox=((0, 0, 0), (4, 4, 4)))
    body = """
    <medium type="heterogeneous" id="m">
        <volume type="gridvolume" name="sigma_t"><string name="filename" value="lin.vol"/>
            <boolean name="use_grid_bbox" value="{bbox}"/>
            <transform name="to_world"><scale value="2"/><translate value="1, 0, 0"/></transform>
        </volume>
        <float name="scale" value="3"/>
        <rgb name="albedo" value="0.5, 0.25, 1"/>
    </medium>
    <shape type="sphere"><bsdf type="null"/><ref id="m" name="interior"/></shape>"""
    plain = write_scene(tmp_path, body.format(bbox="false")).media[0]
    np.testing.assert_allclose(plain.sigma_t.bbox, [[1, 0, 0], [3, 2, 2]])
    assert plain.majorant == 3 * 7
    # world (2, 1, 1) -> local (0.5, 0.5, 0.5) -> 3.5
    sigma_t, sigma_s = plain.coefficients(np.array([[2.0, 1.0, 1.0]]))
    np.testing.assert_allclose(sigma_t, [[10.5] * 3])
    np.testing.assert_allclose(sigma_s, [[5.25, 2.625, 10.5]])
    boxed = write_scene(tmp_path, body.format(bbox="true")).media[0]
    np.testing.assert_allclose(boxed.sigma_t.bbox, [[1, 0, 0], [9, 8, 8]])
    np.testing.assert_allclose(boxed.coefficients(np.array([[5.0, 4.0, 4.0]]))[0], [[10.5] * 3])


@pytest.mark.parametrize("body,message", [
    ('<volume type="gridvolume" name="sigma_t"><string name="filename" value="nowhere.vol"/>'
     '</volume>', "file not found"),
    ('<volume type="gridvolume" name="sigma_t"><string name="filename" value="bad.vol"/>'
     '</volume>', "cannot read .*bad.vol.*does not start with 'VOL'"),
    ('<volume type="gridvolume" name="sigma_t"><string name="filename" value="ok.vol"/>'
     '<string name="wrap_mode" value="tile"/></volume>', "wrap_mode must be one of"),
    ('<volume type="gridvolume" name="sigma_t"><string name="filename" value="ok.vol"/>'
     '<string name="filter_type" value="cubic"/></volume>', "filter_type must be one of"),
    ('<volume type="gridvolume" name="density"><string name="filename" value="ok.vol"/>'
     '</volume>', 'needs name="sigma_t" or name="albedo"'),
    ('<rgb name="sigma_t" value="2, 1, 1"/>', "must lie in \\[0, 1\\]"),
    ('<volume type="constvolume" name="albedo"><float name="value" value="1"/>'
     '<transform name="to_world"><scale value="0"/></transform></volume>', "singular"),
    ('<volume type="constvolume" name="sigma_t"><float name="level" value="1"/></volume>',
     'unsupported property "level"'),
])
def test_bad_volumes_are_one_line_errors_naming_the_line(tmp_path, body, message):
    write_vol(str(tmp_path / "ok.vol"), np.ones((2, 2, 2)))
    (tmp_path / "bad.vol").write_bytes(b"NOTAVOL" + bytes(60))
    with pytest.raises(SceneError, match=message) as error:
        write_scene(tmp_path, f'<medium type="heterogeneous" id="m">{body}</medium>')
    assert re.search(r"scene\.xml:\d+", str(error.value)) and "\n" not in str(error.value)


# -- closed forms -----------------------------------------------------------------------------

#: A slab 0.8 thick (z in [-0.4, 0.4]) between null boundaries; its grid has two cells along
#: z (nearest): the lower half has extinction a, the upper half b, per channel. ``max_value``
#: raises the majorant to 2 x 2.5 = 5: most collisions are null ones.
HALVES = np.array([[0.25, 0.5, 1.0], [1.0, 0.75, 0.125]])
SLAB = """
    <medium type="heterogeneous" id="slab">
        <volume type="gridvolume" name="sigma_t"><string name="filename" value="halves.vol"/>
            <string name="filter_type" value="nearest"/>
            <float name="max_value" value="2.5"/>
            <transform name="to_world"><translate value="-0.5, -0.5, -0.5"/>
                <scale value="20, 20, 0.8"/></transform>
        </volume>
        <float name="scale" value="2"/>
        <float name="albedo" value="{albedo}"/>
    </medium>
    <shape type="cube">
        <transform name="to_world"><scale value="10, 10, 0.4"/></transform>
        <bsdf type="null"/>
        <ref id="slab" name="interior"/>
    </shape>"""


def slab_scene(tmp_path, albedo, extra=""):
    write_vol(str(tmp_path / "halves.vol"), HALVES.reshape(2, 1, 1, 3))
    return write_scene(tmp_path, SLAB.format(albedo=albedo) + extra)


SLAB_SIGMA = 2 * HALVES.sum(0) * 0.4      # the optical depth across the slab, per channel


@pytest.mark.statistical(assertions=1)
def test_slab_of_two_densities_has_transmittance_exp_minus_sum(tmp_path):
    """Ratio tracking through the slab: E[T] = exp(-(sigma_a + sigma_b) d / 2) per channel."""
    scene = slab_scene(tmp_path, 0.5)
    assert scene.media[0].majorant == 5.0
    n = 40_000
    start = np.tile([0.3, -0.2, 2.0], (n, 1))
    wo = np.tile([0.0, 0.0, -1.0], (n, 1))
    rng = RandomStream(sample_keys(4, np.arange(n)))
    channel = np.minimum((rng.next_1d() * 3).astype(np.int64), 2)
    T = shadow_transmittance(scene, start, np.zeros((n, 3)), wo, np.full(n, 4.0),
                             np.full(n, -1), channel, rng, 10)
    expected = np.exp(-SLAB_SIGMA)
    z = (T.mean(0) - expected) / np.sqrt(T.var(0, ddof=1) / n)
    assert np.all(2 * norm.sf(np.abs(z)) > ALPHA / 3), (T.mean(0), expected)
    assert np.all(T >= 0) and np.all(T <= 1)


@pytest.mark.statistical(assertions=1)
@pytest.mark.parametrize("integrator", VOLUMETRIC)
def test_emitter_seen_through_slab_of_two_densities(tmp_path, integrator):
    """Albedo 0: camera paths cross the slab (along d, |d_z| of it per unit length) with
    E = Le exp(-optical depth / |d_z|): null collisions must keep it, real ones end it."""
    scene = slab_scene(tmp_path, 0, LIGHT_WALL)
    result = render(scene, integrator, spp=32, seed=31, processes=1)
    expected = footprint_average(scene, lambda hit, w: np.array([1.0, 2.0, 3.0])
                                 * np.exp(-SLAB_SIGMA / np.abs(w[:, 2:3])), sub=4)
    assert_matches(result, expected)


CONST_CUBE = """
    <medium type="{kind}" id="fog">
        {sigma_t}
        <rgb name="albedo" value="0.9, 0.7, 0.5"/>
        <float name="scale" value="3"/>
        <phase type="hg"><float name="g" value="0.3"/></phase>
    </medium>
    <shape type="cube">
        <transform name="to_world"><scale value="0.5"/><translate value="0.5, 0.5, 0.5"/></transform>
        <bsdf type="null"/>
        <ref id="fog" name="interior"/>
    </shape>
    <shape type="rectangle">
        <transform name="to_world"><scale value="3"/><translate value="0.5, 0.5, -1"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.7, 0.7, 0.7"/></bsdf>
    </shape>
    <emitter type="point"><point name="position" value="1.5, 2, 1.5"/>
        <rgb name="intensity" value="6, 6, 6"/></emitter>
    <shape type="sphere"><point name="center" value="-0.5, 1.5, 0.5"/><float name="radius" value="0.3"/>
        <emitter type="area"><rgb name="radiance" value="3, 3, 3"/></emitter></shape>"""


@pytest.mark.statistical(assertions=1)
@pytest.mark.parametrize("integrator", VOLUMETRIC)
def test_constvolume_medium_equals_the_homogeneous_one_in_mean(tmp_path, integrator):
    """sigma_t as a constvolume filling the unit cube (the medium's cube): the same light
    transport as a homogeneous medium, by another estimator (coloured sigma_t: null
    collisions in the two thinner channels, weighted by the mean null probability)."""
    rgb = '<rgb name="sigma_t" value="0.2, 0.6, 1"/>'
    kw = dict(fov=50, origin="0.5, 0.7, 4", target="0.5, 0.4, 0", size=16)
    hetero = write_scene(tmp_path, CONST_CUBE.format(kind="heterogeneous", sigma_t=rgb), **kw)
    assert hetero.media[0].majorant == 3.0
    homogeneous = write_scene(tmp_path, CONST_CUBE.format(kind="homogeneous", sigma_t=rgb), **kw)
    a = render(hetero, integrator, spp=64, seed=32, processes=1)
    b = render(homogeneous, integrator, spp=64, seed=33, processes=1)
    agreement = compare_means(a.mean, a.variance, a.spp, b.mean, b.variance, b.spp,
                              alpha=ALPHA, options=MeanTestOptions(tile=4))
    assert agreement.agree, verdict_line(agreement)


@pytest.mark.parametrize("integrator", VOLUMETRIC)
def test_homogeneous_medium_with_an_albedo_volume(tmp_path, integrator):
    """Mitsuba's homogeneous medium takes a <volume name="albedo">: a constvolume of the
    rgb albedo renders the same image (to rounding) with the same seed; a grid of two
    albedos (0 on the left half) darkens it."""
    rgb = '<rgb name="sigma_t" value="0.2, 0.6, 1"/>'
    kw = dict(fov=50, origin="0.5, 0.7, 4", target="0.5, 0.4, 0", size=8)
    plain = write_scene(tmp_path, CONST_CUBE.format(kind="homogeneous", sigma_t=rgb), **kw)
    volume = CONST_CUBE.format(kind="homogeneous", sigma_t=rgb).replace(
        '<rgb name="albedo" value="0.9, 0.7, 0.5"/>',
        '<volume type="constvolume" name="albedo"><rgb name="value" value="0.9, 0.7, 0.5"/></volume>')
    textured = write_scene(tmp_path, volume, **kw)
    assert textured.media[0].albedo_volume is not None
    a = render(plain, integrator, spp=4, seed=35, processes=1)
    b = render(textured, integrator, spp=4, seed=35, processes=1)
    np.testing.assert_allclose(b.mean, a.mean, rtol=1e-9, atol=1e-12)
    write_vol(str(tmp_path / "two.vol"), np.array([[0.0, 0.0, 0.0], [0.875, 0.75, 0.5]]).reshape(1, 1, 2, 3))
    halves = write_scene(tmp_path, volume.replace(
        '<volume type="constvolume" name="albedo"><rgb name="value" value="0.9, 0.7, 0.5"/></volume>',
        '<volume type="gridvolume" name="albedo"><string name="filename" value="two.vol"/>'
        '<string name="filter_type" value="nearest"/></volume>'), **kw)
    np.testing.assert_array_equal(halves.media[0].albedo_volume.eval(np.array([[0.2, 0.5, 0.5],
                                                                               [0.7, 0.5, 0.5]])),
                                  [[0, 0, 0], [0.875, 0.75, 0.5]])
    if integrator == "volpath":    # (volpath_phase finds the lights too rarely at 4 spp)
        c = render(halves, integrator, spp=4, seed=35, processes=1)
        assert c.mean.sum() < a.mean.sum()


def test_heterogeneous_image_does_not_depend_on_batching():
    """Paths take different numbers of null collisions, each its own segment: the numbers a
    path draws are still fixed by its counters, whatever its batch."""
    scene = load_scene("hetero-smoke", width=8, height=8)
    for integrator in VOLUMETRIC:
        one = render(scene, integrator, spp=2, seed=5, processes=1)
        other = render(scene, integrator, spp=2, seed=5, processes=1, batch_size=29)
        np.testing.assert_array_equal(one.mean, other.mean)
        np.testing.assert_array_equal(one.variance, other.variance)


# -- against Mitsuba's volpath ----------------------------------------------------------------

@pytest.mark.statistical(assertions=2)
@pytest.mark.parametrize("integrator", VOLUMETRIC)
def test_hetero_smoke_agrees_with_mitsuba_volpath(integrator):
    """The committed reference (docs/references.md); volpath is Mitsuba's estimator, so its
    variance agrees too."""
    comparison = compare("hetero-smoke", integrator, spp=16, alpha=ALPHA, convergence=False,
                         bounces=False, processes=2)
    assert comparison.mean.agree, comparison.report()
    if integrator == "volpath":
        assert comparison.variance is not None and comparison.variance.agree, comparison.report()


@pytest.mark.mitsuba
@pytest.mark.statistical(assertions=2)
def test_grid_bbox_and_mirror_agree_with_live_mitsuba_volpath(tmp_path):
    """A scene written here: a 1-channel trilinear grid placed by use_grid_bbox (the file's
    box) with mirror wrapping, a coloured constvolume albedo, a sphere of smoke on a floor."""
    from mitsuba_refs.reference.render import render_reference
    z, y, x = np.mgrid[0:4, 0:5, 0:3]
    write_vol(str(tmp_path / "puff.vol"), ((x + 1) * (5 - y) * (1 + z % 2)) / 30.0,
              bbox=((-1, -1, -1), (1, 1, 1)))
    body = """
    <medium type="heterogeneous" id="puff">
        <volume type="gridvolume" name="sigma_t"><string name="filename" value="puff.vol"/>
            <boolean name="use_grid_bbox" value="true"/>
            <string name="wrap_mode" value="mirror"/>
            <transform name="to_world"><scale value="0.8"/></transform>
        </volume>
        <volume type="constvolume" name="albedo"><rgb name="value" value="0.9, 0.6, 0.3"/></volume>
        <float name="scale" value="5"/>
    </medium>""" + medium_ball_on_floor("puff", 0.8, 4, "1, 2, 1", 8, 0.2)
    write_scene(tmp_path, body, fov=45, origin="0, 0.5, 3.5", target="0, 0, 0", size=16)
    path = str(tmp_path / "scene.xml")
    reference = render_reference(path, {}, "volpath", 1024, 1)
    ours = render(load_scene(path), "volpath", spp=64, seed=34, processes=1)
    mean = compare_means(ours.mean, ours.variance, 64, reference.mean, reference.var,
                         reference.n, alpha=ALPHA, options=MeanTestOptions(tile=4))
    assert mean.agree, verdict_line(mean)
    variance = compare_variances(ours.variance, 64, reference.var, reference.n,
                                 alpha=ALPHA, options=VarianceTestOptions(tile=4))
    assert variance.agree, verdict_line(variance)


def test_hetero_smoke_reads_its_grids():
    scene = load_scene("hetero-smoke")
    medium = scene.media[0]
    assert medium.majorant == 6.0      # scale 6 x the grid's largest value, 1 (blue)
    assert medium.sigma_t.data.shape == (5, 6, 8, 3) and medium.albedo.data.shape == (2, 4, 3, 1)
