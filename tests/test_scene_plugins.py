"""Loader plugins of users' Mitsuba scenes: the analytic ``cylinder``, ``shapegroup`` /
``instance``, and samplers other than ``independent`` (rendered independently on both
sides). Hits are compared with Mitsuba 3's own ray intersections (scalar_rgb, marked
``mitsuba``).
"""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from pathtracer import load_scene
from pathtracer.shapes.intersect import intersect, texture_uv
from tests.test_bsdfs import random_directions

SENSOR = """<sensor type="perspective"><float name="fov" value="40"/>
  <transform name="to_world"><lookat origin="0, -6, 2" target="0, 0, 0.5" up="0, 0, 1"/></transform>
  {sampler}<film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="6"/>
  <rfilter type="box"/></film></sensor>"""
CYLINDERS = """
<shape type="cylinder"><point name="p0" value="0.2, -0.1, 0"/><point name="p1" value="-0.3, 0.4, 1.5"/>
  <float name="radius" value="0.7"/>
  <transform name="to_world"><rotate z="1" angle="30"/><translate x="0.5"/></transform></shape>
<shape type="cylinder"><boolean name="flip_normals" value="true"/>
  <transform name="to_world"><scale x="0.4" y="0.4" z="2"/><translate x="-1.5" y="1" z="-0.5"/></transform></shape>
"""
INSTANCES = """
<shape type="shapegroup" id="group">
  <shape type="sphere"><point name="center" value="0.5, 0, 0.3"/><float name="radius" value="0.4"/></shape>
  <shape type="rectangle"><transform name="to_world"><rotate x="1" angle="70"/></transform></shape>
  <shape type="cylinder"><float name="radius" value="0.2"/></shape>
</shape>
<shape type="instance"><ref id="group"/></shape>
<shape type="instance"><ref id="group"/>
  <transform name="to_world"><rotate y="1" angle="45"/><scale value="0.8"/>
    <translate x="-1.2" z="1"/></transform></shape>
"""


def _write(tmp_path, body: str, sampler: str = "") -> str:
    path = tmp_path / "scene.xml"
    path.write_text(f'<scene version="3.0.0">{SENSOR.format(sampler=sampler)}{body}</scene>')
    return str(path)


def _rays(n: int, seed: int):
    """Rays from a box around the shapes (some start inside a cylinder) in all directions."""
    rng = np.random.default_rng(seed)
    o = rng.uniform([-2.5, -2.5, -1.0], [2.5, 2.5, 2.5], (n, 3))
    # Half aimed at the shapes' region, half in random directions.
    target = rng.uniform([-1.5, -1.0, -0.5], [1.0, 1.0, 1.5], (n, 3))
    aimed = (target - o) / np.linalg.norm(target - o, axis=1)[:, None]
    return o, np.where((np.arange(n) % 2 == 0)[:, None], aimed, random_directions(n, seed + 1))


def _mitsuba_hits(mi, path, o, d):
    scene = mi.load_file(path)
    out = {"valid": [], "t": [], "n": [], "uv": []}
    for a, b in zip(o, d):
        si = scene.ray_intersect(mi.Ray3f(mi.Point3f(*a), mi.Vector3f(*b)))
        out["valid"].append(bool(si.is_valid()))
        out["t"].append(float(si.t))
        out["n"].append([si.n[0], si.n[1], si.n[2]])
        out["uv"].append([si.uv[0], si.uv[1]])
    return {k: np.array(v) for k, v in out.items()}


def _compare_hits(mi, path, n=3000, seed=800, with_uv=True):
    scene = load_scene(path)
    o, d = _rays(n, seed)
    ours, theirs = intersect(scene, o, d), _mitsuba_hits(mi, path, o, d)
    # Validity may differ only for rays grazing an edge within float32 noise.
    differ = ours.valid != theirs["valid"]
    assert differ.mean() < 2e-3, differ.sum()
    both = ours.valid & theirs["valid"]
    assert both.mean() > 0.3
    t_close = np.abs(ours.t[both] - theirs["t"][both]) < 1e-4 * (1 + theirs["t"][both])
    assert t_close.mean() > 0.998
    rows = np.flatnonzero(both)[t_close]
    np.testing.assert_allclose(ours.n[rows], theirs["n"][rows], atol=2e-4)
    if with_uv:
        uv = texture_uv(scene, ours, rows)
        du = np.abs(uv - theirs["uv"][rows])
        du[:, 0] = np.minimum(du[:, 0], 1 - du[:, 0])   # phi wraps at 0 / 1
        assert np.max(du) < 2e-4


@pytest.mark.mitsuba
def test_mitsuba_cylinder_hits(tmp_path, mi):
    """t, normal (outward; inward with flip_normals) and uv = (phi / 2pi, z) as Mitsuba's."""
    _compare_hits(mi, _write(tmp_path, CYLINDERS), seed=800)


@pytest.mark.mitsuba
def test_mitsuba_instances(tmp_path, mi):
    """A shapegroup drawn by two instances: the same surfaces and normals as Mitsuba's."""
    _compare_hits(mi, _write(tmp_path, INSTANCES), seed=810, with_uv=False)


def test_instances_share_the_group_bsdf(tmp_path):
    scene = load_scene(_write(tmp_path, INSTANCES))
    assert scene.shape_kind.count("cylinder") == 2 and scene.shape_kind.count("sphere") == 2
    assert len(set(scene.shape_bsdf.tolist())) == 1


def test_cylinder_area_light_is_refused(tmp_path):
    body = '<shape type="cylinder"><emitter type="area"/></shape>'
    with pytest.raises(ValueError, match="area emitter on a cylinder is not supported"):
        load_scene(_write(tmp_path, body))


def test_stratified_sampler_by_reference_renders_independently(tmp_path):
    """A top-level sampler referenced by id loads; other types warn that both sides
    sample independently."""
    body = '<sampler type="stratified" id="s"><integer name="sample_count" value="9"/>' \
           '<boolean name="jitter" value="false"/></sampler>'
    path = tmp_path / "scene.xml"
    sensor = SENSOR.format(sampler='<ref id="s"/>')
    path.write_text(f'<scene version="3.0.0">{body}{sensor}{CYLINDERS}</scene>')
    from pathtracer.sensors import sampler
    sampler._warned_samplers.discard("stratified")
    with pytest.warns(UserWarning, match="independent sampler too"):
        scene = load_scene(str(path))
    assert scene.spp == 9
    from mitsuba_refs.reference.cache import _identity
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert "stratified" in _identity(str(path), {}, "path", 16, 0)["sampler"]


@pytest.mark.mitsuba
def test_mitsuba_reference_sampler_is_independent(tmp_path, mi):
    from mitsuba_refs.reference.render import load_mitsuba_scene
    sampler = '<sampler type="multijitter"><integer name="sample_count" value="16"/>' \
              '<boolean name="jitter" value="true"/></sampler>'
    scene = load_mitsuba_scene(_write(tmp_path, CYLINDERS, sampler), {})
    sampler = scene.sensors()[0].sampler()
    assert type(sampler).__name__ == "IndependentSampler" or "Independent" in str(sampler)
    assert sampler.sample_count() == 16
