"""The ``spot`` and ``directional`` emitters: next-event values, and loader errors.

Both are Dirac lights (pdf 1, MIS weight 1; BSDF sampling never hits them),
so next-event estimation is all there is to test: the sampled direction,
distance and weight from many reference points. Without Mitsuba: the spot's
falloff profile (full inside ``beam_width``, linear in angle down to 0 at
``cutoff_angle``) and the directional light's constant irradiance. Against
Mitsuba 3 (``mitsuba`` marker): ``sample_direction`` of the same XML at
reference points inside the beam, in the ramp and outside.
"""
import numpy as np
import pytest

from pathtracer import load_scene
from pathtracer.emitters.scene_emitters import pdf_emitter_direction, sample_emitter
from pathtracer.scene.errors import SceneError
from pathtracer.shapes.intersect import Hit, intersect
from tests.scenes import GRID_PNG

SCENE = """<scene version="3.0.0">
  <sensor type="perspective"><float name="fov" value="40"/>
    <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/>
      <rfilter type="box"/></film></sensor>
  {light}
</scene>"""

SPOT = """<emitter type="spot"><rgb name="intensity" value="3, 2, 1"/>
    <float name="cutoff_angle" value="35"/><float name="beam_width" value="15"/>
    <transform name="to_world"><scale x="1.5" y="0.7"/>
      <lookat origin="0.2, 2, -0.3" target="0.5, 0, 0.1" up="0, 0, 1"/></transform></emitter>"""
SPOT_DEFAULTS = """<emitter type="spot"><transform name="to_world">
    <lookat origin="0, 1, 0" target="0, 0, 0" up="0, 0, 1"/></transform></emitter>"""
#: A projected bitmap through a non-uniformly scaled frame (texture coordinates come from the
#: unnormalised local direction).
SPOT_TEXTURE = f"""<emitter type="spot"><rgb name="intensity" value="3, 2, 1"/>
    <texture type="bitmap" name="texture"><string name="filename" value="{GRID_PNG}"/></texture>
    <float name="cutoff_angle" value="35"/><float name="beam_width" value="15"/>
    <transform name="to_world"><scale x="1.5" y="0.7"/>
      <lookat origin="0.2, 2, -0.3" target="0.5, 0, 0.1" up="0, 0, 1"/></transform></emitter>"""
DIRECTIONAL = """<emitter type="directional"><rgb name="irradiance" value="2, 3, 4"/>
    <vector name="direction" value="0.3, -1, 0.2"/></emitter>"""
DIRECTIONAL_TO_WORLD = """<emitter type="directional"><rgb name="irradiance" value="2, 3, 4"/>
    <transform name="to_world"><lookat origin="0, 0, 0" target="-1, -1.2, -0.3"/></transform></emitter>"""
LIGHTS = {"spot": SPOT, "spot-defaults": SPOT_DEFAULTS, "spot-texture": SPOT_TEXTURE,
          "directional": DIRECTIONAL,
          "directional-to-world": DIRECTIONAL_TO_WORLD}


def load(tmp_path, light, name="scene.xml"):
    path = tmp_path / name
    path.write_text(SCENE.format(light=light))
    return path, load_scene(str(path))


def hits_at(points):
    """Reference points as a batch of hits (normal +y)."""
    count = len(points)
    n = np.tile([0.0, 1.0, 0.0], (count, 1))
    return Hit(np.ones(count, bool), np.zeros(count), points, n, n, np.zeros(count, np.int32),
               np.zeros(count, np.int64), np.zeros((count, 2)))


def floor_points(count, seed, spread=2.0):
    """Points on and around the floor, covering the spot's beam, ramp and dark outside."""
    rng = np.random.default_rng(seed)
    return np.column_stack((rng.uniform(-spread, spread, count), rng.uniform(-0.3, 0.5, count),
                            rng.uniform(-spread, spread, count)))


def next_event(scene, points):
    u = np.random.default_rng(0).random((len(points), 3))
    return sample_emitter(scene, hits_at(points), u[:, 2], u[:, :2], test_visibility=False)


# --------------------------------------------------------------------------
# Without Mitsuba
# --------------------------------------------------------------------------

def test_spot_falloff_is_full_then_linear_in_angle_then_zero(tmp_path):
    _, scene = load(tmp_path, SPOT_DEFAULTS)      # cutoff 20 degrees, beam 15 (3/4 of it)
    angles = np.radians([0.0, 10.0, 14.9, 16.0, 17.5, 19.0, 19.99, 20.5, 60.0, 120.0])
    # Points on the floor y = 0 at those angles from the light at (0, 1, 0) pointing down.
    points = np.column_stack((np.tan(np.minimum(angles, 1.4)), np.zeros(len(angles)), np.zeros(len(angles))))
    points[-1] = [0.0, 2.0, 0.0]                   # above the light: behind it
    ls = next_event(scene, points)
    dist2 = np.sum((points - [0.0, 1.0, 0.0]) ** 2, axis=1)
    expected = np.clip((20.0 - np.degrees(angles)) / 5.0, 0.0, 1.0)
    expected[-1] = 0.0
    np.testing.assert_allclose(ls.weight[:, 0] * dist2, expected, atol=1e-9)
    assert np.all(ls.delta) and np.all(ls.pdf == 1.0)
    np.testing.assert_allclose(ls.dist, np.sqrt(dist2))


def test_spot_texture_is_looked_up_where_the_direction_crosses_the_cone_square(tmp_path):
    """A spot at the origin shining along +z (its local x = world x): the direction to a
    point (a, b, 1) meets the texture at uv = 1/2 + (a, b) / (2 tan cutoff), so the cone's
    edge touches the square's sides; the textured weight is the plain one times the texel."""
    frame = '<transform name="to_world"><lookat origin="0, 0, 0" target="0, 0, 1" up="0, 1, 0"/></transform>'
    plain = f'<emitter type="spot"><float name="cutoff_angle" value="30"/>{frame}</emitter>'
    textured = plain.replace("<float", f'<texture type="bitmap" name="texture"><string name="filename" '
                                       f'value="{GRID_PNG}"/></texture><float')
    rng = np.random.default_rng(4)
    uv = rng.uniform(0.1, 0.9, (300, 2))
    points = np.column_stack(((uv - 0.5) * 2 * np.tan(np.radians(30)), np.ones(300)))
    _, scene = load(tmp_path, textured)
    _, reference = load(tmp_path, plain, "plain.xml")
    weight, plain_weight = next_event(scene, points).weight, next_event(reference, points).weight
    lit = plain_weight[:, 0] > 0
    ratio = weight[lit] / plain_weight[lit]
    assert lit.sum() > 150 and np.ptp(ratio) > 0.1     # inside the cone, and it varies
    np.testing.assert_allclose(ratio, scene.emitters[0].texture.eval(uv[lit]), rtol=1e-12)
    assert np.all(weight[~lit] == 0)


def test_directional_light_is_parallel_with_constant_irradiance(tmp_path):
    _, scene = load(tmp_path, DIRECTIONAL)
    ls = next_event(scene, floor_points(50, 1))
    towards_light = -np.array([0.3, -1.0, 0.2]) / np.linalg.norm([0.3, -1.0, 0.2])
    np.testing.assert_allclose(ls.wo, np.tile(towards_light, (50, 1)), atol=1e-15)
    np.testing.assert_allclose(ls.weight, np.tile([2.0, 3.0, 4.0], (50, 1)))
    assert np.all(np.isinf(ls.dist)) and np.all(ls.delta) and np.all(ls.pdf == 1.0)


def test_delta_lights_are_never_hit(tmp_path):
    """A BSDF-sampled ray cannot reach a Dirac light: its pdf and emission are 0 everywhere."""
    for light in (SPOT, DIRECTIONAL):
        _, scene = load(tmp_path, light)
        o = floor_points(20, 2)
        d = -next_event(scene, o).wo       # even exactly away from / towards the light
        assert np.all(pdf_emitter_direction(scene, o, intersect(scene, o, d), d) == 0)


@pytest.mark.parametrize("light, message", [
    ('<emitter type="spot"><rgb name="texture" value="0.5"/></emitter>', "must be a nested <texture>"),
    ('<emitter type="spot"><texture type="rawconstant" name="texture"><float name="value" '
     'value="0.5"/></texture></emitter>', "must vary over the image"),
    ('<emitter type="spot"><float name="cutoff_angle" value="10"/>'
     '<float name="beam_width" value="20"/></emitter>', "beam_width"),
    ('<emitter type="directional"><vector name="direction" value="0, 0, -1"/>'
     '<transform name="to_world"><rotate x="1" angle="10"/></transform></emitter>', "not both"),
    ('<emitter type="directional"><transform name="to_world"><scale value="2"/></transform></emitter>',
     "must not scale"),
    ('<emitter type="directional"><vector name="direction" value="0, 0, 0"/></emitter>', "zero"),
])
def test_bad_delta_lights_give_one_line_errors(tmp_path, light, message):
    path = tmp_path / "bad.xml"
    path.write_text(SCENE.format(light=light))
    with pytest.raises(SceneError, match=message) as info:
        load_scene(str(path))
    assert "bad.xml:5" in str(info.value) and "\n" not in str(info.value)


# --------------------------------------------------------------------------
# Against Mitsuba 3
# --------------------------------------------------------------------------

@pytest.mark.mitsuba
@pytest.mark.parametrize("name", sorted(LIGHTS))
def test_next_event_matches_mitsuba(tmp_path, name, mi):
    import drjit as dr

    path, scene = load(tmp_path, LIGHTS[name])
    emitter = mi.load_file(str(path)).emitters()[0]
    points = floor_points(400, 3)
    ours = next_event(scene, points)
    wo, dist, weight = [], [], []
    for p in points:
        it = dr.zeros(mi.Interaction3f)
        it.p = mi.Point3f(*p)
        ds, w = emitter.sample_direction(it, mi.Point2f(0.5, 0.5))
        assert ds.delta and ds.pdf == 1.0
        wo.append(list(ds.d))
        dist.append(ds.dist)
        weight.append(list(w))
    weight = np.array(weight)
    if name.startswith("spot"):
        # Inside the beam, in the ramp and outside: every regime of the falloff is exercised.
        full = np.max(weight * np.sum((points - scene.emitters[0].position) ** 2, axis=1)[:, None], axis=1)
        assert np.any(full == 0) and np.any(np.isclose(full, full.max()))
        assert np.any((full > 0) & (full < 0.9 * full.max()))
        np.testing.assert_allclose(ours.dist, dist, rtol=1e-5)
    np.testing.assert_allclose(ours.wo, wo, atol=1e-5)
    np.testing.assert_allclose(ours.weight, weight, rtol=1e-4, atol=1e-6)
