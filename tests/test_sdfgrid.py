"""The ``sdfgrid`` shape (pathtracer.shapes.sdfgrid): hits on the trilinear zero set of a
sampled sphere, normals, misses, instancing, the loader's refusals, and hits / normals
against Mitsuba's own ``sdfgrid`` (scalar_rgb ``ray_intersect``) in both normal modes."""
import numpy as np
import pytest

from pathtracer.io.vol import write_vol
from pathtracer.scene.errors import SceneError
from pathtracer.scene.load import load_scene
from pathtracer.shapes.intersect import intersect, occluded
from pathtracer.shapes.sdfgrid import SDFGridShape, field

CENTRE, RADIUS = np.array([0.45, 0.5, 0.55]), 0.3


def sphere_sdf(nx, ny, nz, centre=CENTRE, radius=RADIUS):
    """Exact signed distance (object units) of a sphere at the nodes, as (z, y, x) float32."""
    z, y, x = np.meshgrid(*(np.linspace(0, 1, k) for k in (nz, ny, nx)), indexing="ij")
    dist = np.sqrt((x - centre[0]) ** 2 + (y - centre[1]) ** 2 + (z - centre[2]) ** 2)
    return (dist - radius).astype(np.float32)


def _rays(lo, hi, n, seed, spread=2.0):
    """Rays from a sphere around the box towards random points inside it (unit directions)."""
    rng = np.random.default_rng(seed)
    centre, size = (lo + hi) / 2, np.linalg.norm(hi - lo)
    o = rng.normal(size=(n, 3))
    o = centre + spread * size * o / np.linalg.norm(o, axis=1, keepdims=True)
    d = lo + rng.random((n, 3)) * (hi - lo) - o
    return o, d / np.linalg.norm(d, axis=1, keepdims=True)


def _grazing(centre, radius, n, seed, band):
    """Rays passing at distances ``radius * (1 + U(-band, band))`` from ``centre``."""
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    side = np.cross(d, rng.normal(size=(n, 3)))
    side /= np.linalg.norm(side, axis=1, keepdims=True)
    offset = radius * (1 + band * (2 * rng.random(n) - 1))
    return centre + side * offset[:, None] - 3 * d, d


SCALE = np.diag([2.0, 2.0, 2.0, 1.0]) @ np.array([[1, 0, 0, -0.5], [0, 1, 0, 0.2],
                                                   [0, 0, 1, 1.0], [0, 0, 0, 1.0]])


@pytest.mark.parametrize("normals", ["analytic", "smooth"])
def test_sphere_grid_hits_lie_on_the_trilinear_zero_set(normals):
    """A 21 x 17 x 21 grid of a sphere's exact SDF, scaled by 2: hit points are zeros of
    the interpolated field (regula falsi stops within 1e-5 of the root in ray parameter:
    |F| < 1e-5 * |grad F| = 2e-5 in object units at most), within a voxel of the sphere, the
    normals are unit, face the incoming rays (all start outside) and are within h / r
    radians of the sphere's (h the voxel, r the radius); occlusion agrees."""
    grid = SDFGridShape(sphere_sdf(21, 17, 21).astype(float), SCALE, normals, 0)
    lo, hi = grid.bounds()
    o, d = _rays(lo, hi, 2000, seed=1)
    t, voxel, _, _ = grid.intersect(o, d)
    hit = np.isfinite(t)
    assert 400 < hit.sum() < 1900 and np.all(voxel[hit] >= 0) and np.all(voxel[~hit] == -1)
    p = o[hit] + t[hit, None] * d[hit]
    g = p @ grid.to_grid[:3, :3].T + grid.to_grid[:3, 3]
    assert np.abs(field(grid.data, g)).max() < 2e-5
    world_centre = SCALE[:3, :3] @ CENTRE + SCALE[:3, 3]
    voxel_size = 2.0 / 16                                  # the largest, along y, in world units
    assert np.abs(np.linalg.norm(p - world_centre, axis=1) - 2 * RADIUS).max() < voxel_size
    n, sh_n = grid.surface(p)
    for normal in (n, sh_n):
        np.testing.assert_allclose(np.linalg.norm(normal, axis=1), 1.0, atol=1e-12)
        assert np.all(np.sum(normal * d[hit], axis=1) < 0)
        radial = (p - world_centre) / np.linalg.norm(p - world_centre, axis=1, keepdims=True)
        # The interpolant's gradient is off the true one by O(h |Hessian|) = O(h / r).
        assert np.min(np.sum(normal * radial, axis=1)) > np.cos((1 / 16) / RADIUS)
    np.testing.assert_array_equal(grid.occluded(o, d, np.where(hit, t * 1.001, 1e9)), hit)
    assert not grid.occluded(o[hit], d[hit], t[hit] * 0.999).any()


def test_rays_that_miss_the_cube_or_the_sphere_miss():
    """Rays that pass beside the unit cube, and rays through a cube corner (outside the
    sphere), miss; a ray from the centre outwards hits at the radius, from inside."""
    grid = SDFGridShape(sphere_sdf(21, 21, 21).astype(float), np.eye(4), "smooth", 0)
    o = np.array([[-1.0, 2.0, 0.5], [0.5, 0.5, 3.0], [-0.5, 0.02, 0.02], [0.45, 0.5, 0.55]])
    d = np.array([[1.0, 0, 0], [0, 1.0, 0], [1.0, 0, 0], [1.0, 0, 0]])
    t, *_ = grid.intersect(o, d)
    assert np.all(np.isinf(t[:3]))
    assert t[3] == pytest.approx(RADIUS, abs=2e-3)     # the chord error of a 1/20 voxel
    n, _ = grid.surface(o[3:] + t[3] * d[3:])
    assert n[0, 0] > 0.99                              # outwards, along the ray


def _scene(tmp_path, shape, extra=""):
    path = tmp_path / "scene.xml"
    path.write_text(f"""<scene version="3.0.0">
  <sensor type="perspective"><film type="hdrfilm"><integer name="width" value="8"/>
    <integer name="height" value="8"/><rfilter type="box"/></film></sensor>
  {extra}
  {shape}
</scene>""")
    return str(path)


def _grid_file(tmp_path, data, name="grid.vol"):
    write_vol(str(tmp_path / name), data)
    return name


def test_instance_moves_the_grid_as_its_transform_says(tmp_path):
    """A grid drawn by a rotating, scaling instance: the scene's hits are the object-space
    hits of the rays mapped back (same t), and the normals the inverse transpose's image."""
    name = _grid_file(tmp_path, sphere_sdf(21, 13, 21))
    group = f"""<shape type="shapegroup" id="g"><shape type="sdfgrid">
      <string name="filename" value="{name}"/><string name="normals" value="analytic"/></shape></shape>
    <shape type="instance"><ref id="g"/><transform name="to_world">
      <scale value="1.5 1 2"/><rotate x="0.6" y="0.8" z="0" angle="40"/>
      <translate value="1 -2 0.5"/></transform></shape>"""
    scene = load_scene(_scene(tmp_path, group))
    assert scene.shape_kind == ["sdfgrid"]
    grid = scene.sdfgrids[0]
    m = grid.to_world
    local = SDFGridShape(sphere_sdf(21, 13, 21).astype(float), np.eye(4), "analytic", 0)
    lo, hi = grid.bounds()
    o, d = _rays(lo, hi, 500, seed=4)
    h = intersect(scene, o, d)
    inv = np.linalg.inv(m)
    t_local, *_ = local.intersect(o @ inv[:3, :3].T + inv[:3, 3], d @ inv[:3, :3].T)
    assert h.valid.sum() > 50
    np.testing.assert_array_equal(h.valid, np.isfinite(t_local))
    np.testing.assert_allclose(h.t[h.valid], t_local[h.valid], rtol=1e-9)
    p_local = (h.p[h.valid] - m[:3, 3]) @ inv[:3, :3].T
    n_local, _ = local.surface(p_local)
    expect = n_local @ inv[:3, :3]                     # inverse transpose of to_world
    expect /= np.linalg.norm(expect, axis=1, keepdims=True)
    np.testing.assert_allclose(h.n[h.valid], expect, atol=1e-9)
    np.testing.assert_array_equal(h.uv[h.valid], 0.0)
    np.testing.assert_array_equal(occluded(scene, o, d, np.full(len(o), 1e9)), h.valid)


REFUSALS = {  # name: (shape element, expected line, message fragment)
    "three channels": ('<shape type="sdfgrid">\n<string name="filename" value="rgb.vol"/></shape>',
                       6, "3 channels"),
    "truncated file": ('<shape type="sdfgrid">\n<string name="filename" value="short.vol"/></shape>',
                       6, "needs"),
    "x and z sizes differ": ('<shape type="sdfgrid">\n<string name="filename" value="xz.vol"/></shape>',
                             6, "x and z"),
    "no surface": ('<shape type="sdfgrid">\n<string name="filename" value="empty.vol"/></shape>',
                   6, "no voxel holds a sign change"),
    "unknown normals": ('<shape type="sdfgrid"><string name="filename" value="grid.vol"/>\n'
                        '<string name="normals" value="flat"/></shape>', 6, "normals must be one of"),
    "flip_normals": ('<shape type="sdfgrid"><string name="filename" value="grid.vol"/>\n'
                     '<boolean name="flip_normals" value="true"/></shape>', 6, "flip_normals"),
    "rotation": ('<shape type="sdfgrid"><string name="filename" value="grid.vol"/>\n'
                 '<transform name="to_world"><rotate z="1" angle="30"/></transform></shape>', 6,
                 "only scale"),
    "area emitter": ('<shape type="sdfgrid"><string name="filename" value="grid.vol"/>\n'
                     '<emitter type="area"/></shape>', 6, "cannot be an area emitter"),
    "unknown parameter": ('<shape type="sdfgrid"><string name="filename" value="grid.vol"/>\n'
                          '<float name="radius" value="1"/></shape>', 6, "radius"),
}


@pytest.mark.parametrize("case", list(REFUSALS))
def test_loader_refuses_with_file_and_line(tmp_path, case):
    shape, line, fragment = REFUSALS[case]
    _grid_file(tmp_path, sphere_sdf(9, 9, 9))
    _grid_file(tmp_path, np.stack([sphere_sdf(9, 9, 9)] * 3, axis=-1), "rgb.vol")
    _grid_file(tmp_path, sphere_sdf(9, 9, 7), "xz.vol")
    _grid_file(tmp_path, np.ones((4, 4, 4), np.float32), "empty.vol")
    (tmp_path / "short.vol").write_bytes((tmp_path / "grid.vol").read_bytes()[:200])
    with pytest.raises(SceneError) as error:
        load_scene(_scene(tmp_path, shape))
    assert str(error.value).startswith(f"{tmp_path / 'scene.xml'}:{line}: ") or \
        str(error.value).startswith(f"scene.xml:{line}: ")
    assert fragment in str(error.value)


# -- against Mitsuba -----------------------------------------------------------------------

# The surface leaves the grid through its x = 0 and z = 1 faces, so the smooth normals'
# border rules (voxels with a negative index left out, the clamped field beyond the last
# node) are exercised too; y has its own resolution.
BORDER_CENTRE, BORDER_RADIUS = np.array([0.2, 0.5, 0.7]), 0.42


@pytest.mark.parametrize("normals", ["analytic", "smooth"])
def test_hits_and_normals_match_mitsuba(tmp_path, normals, mi):
    """2500 rays at the scaled and moved grid and 1500 that graze the sphere (passing within
    2 % of its radius): the same rays hit, except grazing rays whose closest approach to the
    interpolated surface is below Mitsuba's float32 resolution (at most 0.5 % of them); t and
    the hit point within a relative 1e-5 (Mitsuba's float32 t, and regula falsi's 1e-5 stop;
    1e-4 for the grazing rays, whose t error grows as 1 / cos of the incidence, ~0.01 here),
    the geometric and shading normals within 2e-4 per component (float32 field differences
    across a voxel, ~1e-6 of the field's range, divided by the gradient), except hits within
    1e-3 voxel of a voxel face (the analytic normal is discontinuous there, and rounding
    picks the voxel), of which there are a handful."""
    data = sphere_sdf(25, 19, 25, BORDER_CENTRE, BORDER_RADIUS)
    path = str(tmp_path / "border.vol")
    write_vol(path, data)
    to_world = np.diag([2.0, 1.5, 2.5, 1.0])
    to_world[:3, 3] = [0.3, -1.0, 0.5]
    ours = SDFGridShape(data.astype(float), to_world, normals, 0)
    theirs = mi.load_dict({"type": "scene", "g": {
        "type": "sdfgrid", "filename": path, "normals": normals,
        "to_world": mi.ScalarTransform4f(to_world.tolist())}})
    lo, hi = ours.bounds()
    o1, d1 = _rays(lo, hi, 2500, seed=7)
    # Graze the sphere in object space (a sphere there), mapped to world.
    og, dg = _grazing(BORDER_CENTRE, BORDER_RADIUS, 1500, seed=8, band=0.02)
    o2 = og @ to_world[:3, :3].T + to_world[:3, 3]
    d2 = dg @ to_world[:3, :3].T
    d2 /= np.linalg.norm(d2, axis=1, keepdims=True)
    o, d = np.concatenate([o1, o2]), np.concatenate([d1, d2])
    t, *_ = ours.intersect(o, d)
    ref_t, ref_p = np.full(len(o), np.inf), np.zeros((len(o), 3))
    ref_n, ref_sh = np.zeros((len(o), 3)), np.zeros((len(o), 3))
    for i in range(len(o)):
        si = theirs.ray_intersect(mi.Ray3f(o[i].tolist(), d[i].tolist()))
        if si.is_valid():
            ref_t[i], ref_p[i] = si.t, np.array(si.p)
            ref_n[i], ref_sh[i] = np.array(si.n), np.array(si.sh_frame.n)
    hit, ref_hit = np.isfinite(t), np.isfinite(ref_t)
    assert hit[:2500].sum() > 500 and hit[2500:].sum() > 300
    np.testing.assert_array_equal(hit[:2500], ref_hit[:2500])
    assert (hit != ref_hit).sum() <= 0.005 * 1500
    both = np.flatnonzero(hit & ref_hit)
    straight, grazing = both[both < 2500], both[both >= 2500]
    np.testing.assert_allclose(t[straight], ref_t[straight], rtol=1e-5)
    np.testing.assert_allclose(t[grazing], ref_t[grazing], rtol=1e-4)
    p = o[both] + t[both, None] * d[both]
    np.testing.assert_allclose(p, ref_p[both], rtol=0, atol=1e-5 * np.abs(ref_p).max())
    n, sh_n = ours.surface(p)
    g = p @ ours.to_grid[:3, :3].T + ours.to_grid[:3, 3]
    near_face = np.abs(g - np.rint(g)).min(axis=1) < 1e-3
    assert near_face.sum() < 0.01 * len(both)
    for mine, ref in ((n, ref_n[both]), (sh_n, ref_sh[both])):
        err = np.abs(mine - ref).max(axis=1)
        assert err[~near_face].max() < 2e-4
        assert np.median(err) < 1e-5
