"""Scene intersection (triangles, spheres, disks), shadow rays and ray spawning.

The last tests compare with Mitsuba 3's own ``ray_intersect`` (scalar_rgb)
when mitsuba is importable.
"""
import numpy as np
import pytest

from pathtracer.scene.types import Camera, Scene
from pathtracer.shapes import intersect as geometry


def make_scene(tris=(), tri_n=None, spheres=(), disks=()):
    """A Scene holding only geometry: one mesh shape, then one shape per sphere / disk.

    ``spheres``: (center, radius, flip) tuples; ``disks``: (to_world, flip).
    """
    tri_p = np.asarray(tris, float).reshape(-1, 3, 3)
    if tri_n is None:
        fn = np.cross(tri_p[:, 1] - tri_p[:, 0], tri_p[:, 2] - tri_p[:, 0])
        fn /= np.maximum(np.linalg.norm(fn, axis=1, keepdims=True), 1e-300)
        tri_n = np.repeat(fn[:, None], 3, axis=1)
    kinds, prims = ["mesh"], [[0, len(tri_p)]]
    kinds += ["sphere"] * len(spheres) + ["disk"] * len(disks)
    prims += [[i, i + 1] for i in range(len(spheres))] + [[i, i + 1] for i in range(len(disks))]
    n_shapes = len(kinds)
    to_world = np.array([np.asarray(m, float) for m, _ in disks]).reshape(-1, 4, 4)
    return Scene(
        tri_p=tri_p, tri_n=np.asarray(tri_n, float).reshape(-1, 3, 3),
        tri_shape=np.zeros(len(tri_p), np.int32),
        sphere_center=np.array([c for c, _, _ in spheres], float).reshape(-1, 3),
        sphere_radius=np.array([r for _, r, _ in spheres], float),
        sphere_flip=np.array([f for _, _, f in spheres], bool),
        sphere_shape=np.arange(1, 1 + len(spheres), dtype=np.int32),
        disk_to_world=to_world, disk_to_local=np.linalg.inv(to_world) if len(disks) else to_world,
        disk_flip=np.array([f for _, f in disks], bool),
        disk_shape=np.arange(1 + len(spheres), n_shapes, dtype=np.int32),
        shape_kind=kinds, shape_prim=np.array(prims, np.int64),
        shape_bsdf=np.zeros(n_shapes, np.int32), shape_emitter=np.full(n_shapes, -1, np.int32),
        shape_area=np.ones(n_shapes), shape_tri_cdf=[None] * n_shapes,
        shape_name=kinds, bsdfs=[], emitters=[], environment=None,
        camera=Camera(to_world=np.eye(4), x_fov=45.0))


def affine(scale=(1, 1, 1), angle=0.0, axis=(0, 0, 1), translate=(0, 0, 0)):
    """4x4 matrix: scale, then rotate (degrees, about axis), then translate."""
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    th = np.radians(angle)
    r = np.eye(3) + np.sin(th) * k + (1 - np.cos(th)) * k @ k
    m = np.eye(4)
    m[:3, :3] = r @ np.diag(scale)
    m[:3, 3] = translate
    return m


def unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def rays_towards(rng, n, src_r=4.0, dst_r=1.5):
    o = unit(rng.normal(size=(n, 3))) * src_r
    return o, unit(rng.uniform(-dst_r, dst_r, (n, 3)) - o)


QUAD = [[[-1, -1, 0], [1, -1, 0], [1, 1, 0]], [[-1, -1, 0], [1, 1, 0], [-1, 1, 0]]]


# ----------------------------------------------------------------------
# Analytic shapes


def test_sphere_hits_from_outside_and_inside():
    c = np.array([1.0, 2.0, 3.0])
    sc = make_scene(spheres=[(c, 2.0, False)])
    o = np.array([c + [0, 0, 10], c + [0.5, 0, 0]])
    d = np.array([[0, 0, -1.0], [1.0, 0, 0]])
    hit = geometry.intersect(sc, o, d)
    assert hit.valid.all() and np.all(hit.shape == 1) and np.all(hit.prim == 0)
    np.testing.assert_allclose(hit.t, [8.0, 1.5])
    np.testing.assert_allclose(hit.p, [c + [0, 0, 2], c + [2, 0, 0]])
    np.testing.assert_allclose(hit.n, [[0, 0, 1], [1, 0, 0]])
    np.testing.assert_allclose(hit.sh_n, hit.n)
    np.testing.assert_allclose(hit.uv[1], [0.0, 0.5])  # phi = 0, theta = pi/2
    flipped = geometry.intersect(make_scene(spheres=[(c, 2.0, True)]), o, d)
    np.testing.assert_allclose(flipped.n, -hit.n)


def test_sphere_random_rays_against_quadratic():
    rng = np.random.default_rng(0)
    c, r = np.array([0.3, -0.2, 0.1]), 1.1
    o, d = rays_towards(rng, 5000)
    hit = geometry.intersect(make_scene(spheres=[(c, r, False)]), o, d)
    # Closest root of |o + t d - c| = r, computed independently.
    b = np.einsum("ij,ij->i", o - c, d)
    disc = b * b - (np.einsum("ij,ij->i", o - c, o - c) - r * r)
    expect = disc > 0
    np.testing.assert_array_equal(hit.valid, expect)
    t = -b[expect] - np.sqrt(disc[expect])
    np.testing.assert_allclose(hit.t[expect], t, rtol=1e-10)
    np.testing.assert_allclose(np.linalg.norm(hit.p[expect] - c, axis=1), r, rtol=1e-14)
    assert np.all(np.einsum("ij,ij->i", hit.n[expect], d[expect]) < 0)


def test_disk_with_nonuniform_scale_and_rotation():
    m = affine(scale=(2.0, 0.5, 1.0), angle=30, axis=(1, 1, 0), translate=(0.5, 0, -1))
    sc = make_scene(disks=[(m, False)])
    rng = np.random.default_rng(1)
    # Targets: points of the local plane inside / outside the unit disk.
    local = rng.uniform(-1.3, 1.3, (4000, 2))
    inside = np.hypot(local[:, 0], local[:, 1]) <= 1
    keep = np.abs(np.hypot(local[:, 0], local[:, 1]) - 1) > 1e-6
    local, inside = local[keep], inside[keep]
    pts = np.c_[local, np.zeros(len(local)), np.ones(len(local))] @ m.T
    o = pts[:, :3] + unit(rng.normal(size=(len(local), 3))) * 3
    d = unit(pts[:, :3] - o)
    hit = geometry.intersect(sc, o, d)
    np.testing.assert_array_equal(hit.valid, inside)
    np.testing.assert_allclose(hit.p[inside], pts[inside, :3], atol=1e-12)
    np.testing.assert_allclose(hit.uv[inside], local[inside], atol=1e-12)
    # Normal: inverse transpose of the linear part applied to +z.
    n = unit(np.linalg.inv(m[:3, :3]).T @ [0, 0, 1.0])
    np.testing.assert_allclose(hit.n[inside], np.tile(n, (inside.sum(), 1)), atol=1e-14)
    flipped = geometry.intersect(make_scene(disks=[(m, True)]), o, d)
    np.testing.assert_allclose(flipped.n[inside], -hit.n[inside])


def test_triangle_hit_fields():
    tri = [[[0, 0, 0], [2, 0, 0], [0, 2, 0]]]
    tri_n = [[unit([0, 0, 1]), unit([1, 0, 1]), unit([0, 1, 1])]]
    sc = make_scene(tris=tri, tri_n=tri_n)
    hit = geometry.intersect(sc, np.array([[0.5, 0.5, 3.0]]), np.array([[0, 0, -1.0]]))
    assert hit.valid[0] and hit.shape[0] == 0 and hit.prim[0] == 0
    np.testing.assert_allclose(hit.t, [3.0])
    np.testing.assert_allclose(hit.p, [[0.5, 0.5, 0]])
    np.testing.assert_allclose(hit.uv, [[0.25, 0.25]])
    np.testing.assert_allclose(hit.n, [[0, 0, 1]])
    sh = unit(np.array([0.5, 0.25, 0.25]) @ np.array(tri_n[0]))
    np.testing.assert_allclose(hit.sh_n[0], sh)


def test_closest_across_shape_kinds_and_occluded():
    rng = np.random.default_rng(2)
    sc = make_scene(tris=np.array(QUAD) * 1.5 + [0, 0, -0.5],
                    spheres=[((0.4, 0.3, 0.2), 0.5, False), ((-0.6, -0.5, 0.6), 0.3, True)],
                    disks=[(affine(scale=(0.7, 0.7, 1), angle=70, axis=(1, 0, 0),
                                   translate=(0, 0.8, 0.3)), False)])
    o, d = rays_towards(rng, 20000)
    hit = geometry.intersect(sc, o, d)
    assert set(np.unique(hit.shape)) == {-1, 0, 1, 2, 3}
    # Each shape alone gives a t >= the combined one, and the winner's equals it.
    for shape in range(4):
        alone = make_scene(**{
            0: dict(tris=sc.tri_p),
            1: dict(spheres=[(sc.sphere_center[0], sc.sphere_radius[0], False)]),
            2: dict(spheres=[(sc.sphere_center[1], sc.sphere_radius[1], True)]),
            3: dict(disks=[(sc.disk_to_world[0], False)])}[shape])
        ta = geometry.intersect(alone, o, d).t
        assert np.all(ta >= hit.t)
        np.testing.assert_array_equal(ta[hit.shape == shape], hit.t[hit.shape == shape])
    tmax = rng.uniform(0, 6, len(o))
    np.testing.assert_array_equal(geometry.occluded(sc, o, d, tmax), hit.t < tmax)
    assert np.all(np.isinf(hit.t[~hit.valid])) and np.all(hit.prim[~hit.valid] == -1)
    np.testing.assert_allclose(np.linalg.norm(hit.n[hit.valid], axis=1), 1.0)
    # tmax limits intersect too.
    short = geometry.intersect(sc, o, d, tmax)
    np.testing.assert_array_equal(short.valid, hit.t < tmax)


# ----------------------------------------------------------------------
# Ray spawning


def test_spawn_ray_offsets_along_normal_to_the_side_of_d():
    p = np.array([[1.0, -3.0, 2.0], [0.0, 0.0, 0.0]])
    n = np.array([[0, 0, 1.0], [0, 1.0, 0]])
    d = np.array([[0.3, 0, 0.9], [0, -1.0, 0]])
    o = geometry.spawn_ray(p, n, d)
    eps = geometry.RAY_EPSILON
    assert eps == pytest.approx(8.9407e-5, rel=1e-4)
    np.testing.assert_allclose(o - p, [[0, 0, 4 * eps], [0, -eps, 0]], rtol=1e-12)
    oi, di, ti = geometry.spawn_ray_inf(p, n, d)
    np.testing.assert_array_equal(oi, o)
    assert np.all(np.isinf(ti))


def test_spawn_ray_to_stops_short_of_the_target():
    p = np.array([[0.0, 0.0, 0.0]])
    n = np.array([[0.0, 0.0, 1.0]])
    target = np.array([[0.0, 0.0, 2.0]])
    o, d, tmax = geometry.spawn_ray_to(p, n, target)
    np.testing.assert_allclose(o, [[0, 0, geometry.RAY_EPSILON]])
    np.testing.assert_allclose(d, [[0, 0, 1.0]])
    dist = 2.0 - geometry.RAY_EPSILON
    np.testing.assert_allclose(tmax, [dist * (1 - geometry.SHADOW_EPSILON)])
    # A shadow ray from a floor point to a point on a light quad is not
    # blocked by either surface, but is by a quad in between.
    floor, light = np.array(QUAD), np.array(QUAD) + [0, 0, 2]
    light = light[:, ::-1]  # facing down
    sc = make_scene(tris=np.concatenate((floor, light)))
    rng = np.random.default_rng(3)
    a = np.c_[rng.uniform(-1, 1, (1000, 2)), np.zeros(1000)]
    b = np.c_[rng.uniform(-1, 1, (1000, 2)), np.full(1000, 2.0)]
    o, d, tmax = geometry.spawn_ray_to(a, np.tile([0, 0, 1.0], (1000, 1)), b)
    assert not geometry.occluded(sc, o, d, tmax).any()
    blocker = make_scene(tris=np.concatenate((floor, light, np.array(QUAD) * 2 + [0, 0, 1])))
    assert geometry.occluded(blocker, o, d, tmax).all()


def test_spawned_rays_do_not_hit_their_own_surface():
    rng = np.random.default_rng(4)
    sc = make_scene(spheres=[((0, 0, 0), 1.0, False)], tris=np.array(QUAD) * 3 + [0, 0, -1.0])
    o, d = rays_towards(rng, 5000, dst_r=1.0)
    hit = geometry.intersect(sc, o, d)
    h = hit.valid
    # Leave into the outer hemisphere of the geometric normal.
    wo = unit(rng.normal(size=(h.sum(), 3)))
    wo *= np.sign(np.einsum("ij,ij->i", wo, hit.n[h]))[:, None]
    nxt = geometry.intersect(sc, geometry.spawn_ray(hit.p[h], hit.n[h], wo), wo)
    same = nxt.valid & (nxt.shape == hit.shape[h])
    # A convex sphere or a plane is never hit again on the outer side.
    assert not same.any()


# ----------------------------------------------------------------------
# Against Mitsuba 3


def mitsuba_trace(mi, scene, o, d):
    """Mitsuba's t (inf on miss), geometric and shading normals, one ray at a time."""
    t = np.full(len(o), np.inf)
    n, sh = np.zeros((len(o), 3)), np.zeros((len(o), 3))
    for i in range(len(o)):
        si = scene.ray_intersect(mi.Ray3f(mi.Point3f(*o[i]), mi.Vector3f(*d[i])))
        if si.is_valid():
            t[i] = si.t
            n[i], sh[i] = np.array(si.n), np.array(si.sh_frame.n)
    return t, n, sh


def mesh_triangles(mi, shape):
    """World-space triangles and vertex normals of a Mitsuba mesh."""
    params = mi.traverse(shape)
    v = np.array(params["vertex_positions"]).reshape(-1, 3)
    f = np.array(params["faces"]).reshape(-1, 3)
    vn = np.array(params["vertex_normals"]).reshape(-1, 3) if shape.has_vertex_normals() else None
    tri_p = v[f]
    if vn is None:
        return tri_p, None
    return tri_p, vn[f]


def compare(mi, ours, theirs, o, d):
    t_ref, n_ref, sh_ref = mitsuba_trace(mi, theirs, o, d)
    hit = geometry.intersect(ours, o, d)
    valid_ref = np.isfinite(t_ref)
    assert 0.1 < valid_ref.mean() < 0.95
    # Grazing rays (|cos| < 0.02 against our normal) may flip between hit and
    # miss in float32; everything else must agree exactly on hit/miss.
    cos = np.abs(np.einsum("ij,ij->i", hit.n, d))
    grazing = hit.valid & (cos < 0.02)
    disagree = (hit.valid != valid_ref) & ~grazing
    assert disagree.mean() < 2e-3, f"{disagree.sum()} hit/miss disagreements"
    both = hit.valid & valid_ref & ~grazing
    np.testing.assert_allclose(hit.t[both], t_ref[both], rtol=1e-4, atol=1e-5)
    np.testing.assert_allclose(hit.n[both], n_ref[both], atol=1e-4)
    np.testing.assert_allclose(hit.sh_n[both], sh_ref[both], atol=1e-4)


N_RAYS = 3000


def test_against_mitsuba_rectangle_and_cube(mi):
    rng = np.random.default_rng(10)
    m = affine(scale=(1.5, 0.7, 1), angle=40, axis=(1, 2, 0.5), translate=(0.2, -0.3, 0.1))
    theirs = mi.load_dict({"type": "scene", "rect": {
        "type": "rectangle", "to_world": mi.ScalarTransform4f(m.tolist())}})
    tri = np.einsum("ij,tkj->tki", m[:3, :3], np.array(QUAD, float)) + m[:3, 3]
    o, d = rays_towards(rng, N_RAYS)
    compare(mi, make_scene(tris=tri), theirs, o, d)

    m = affine(scale=(0.8, 1.2, 0.5), angle=25, axis=(0, 1, 1))
    theirs = mi.load_dict({"type": "scene", "cube": {
        "type": "cube", "to_world": mi.ScalarTransform4f(m.tolist())}})
    tri, _ = mesh_triangles(mi, theirs.shapes()[0])
    assert len(tri) == 12
    compare(mi, make_scene(tris=tri), theirs, o, d)


def test_against_mitsuba_sphere_and_disk(mi):
    rng = np.random.default_rng(11)
    o, d = rays_towards(rng, N_RAYS)
    for flip in (False, True):
        theirs = mi.load_dict({"type": "scene", "s": {
            "type": "sphere", "center": [0.2, -0.1, 0.3], "radius": 0.9, "flip_normals": flip}})
        ours = make_scene(spheres=[((0.2, -0.1, 0.3), 0.9, flip)])
        compare(mi, ours, theirs, o, d)
    m = affine(scale=(1.3, 0.6, 1), angle=-50, axis=(1, 0.2, 0), translate=(0, 0.3, -0.2))
    for flip in (False, True):
        theirs = mi.load_dict({"type": "scene", "disk": {
            "type": "disk", "flip_normals": flip, "to_world": mi.ScalarTransform4f(m.tolist())}})
        compare(mi, make_scene(disks=[(m, flip)]), theirs, o, d)


def test_against_mitsuba_random_mesh_with_normals(mi):
    rng = np.random.default_rng(12)
    n_v, n_f = 300, 400
    v = rng.uniform(-1, 1, (n_v, 3))
    f = rng.integers(0, n_v, (n_f, 3))
    f = f[(f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])]
    vn = unit(rng.normal(size=(n_v, 3)))
    mesh = mi.Mesh("soup", n_v, len(f), has_vertex_normals=True)
    params = mi.traverse(mesh)
    params["vertex_positions"] = v.ravel().tolist()
    params["faces"] = f.astype(np.uint32).ravel().tolist()
    params["vertex_normals"] = vn.ravel().tolist()
    params.update()
    theirs = mi.load_dict({"type": "scene", "mesh": mesh})
    ours = make_scene(tris=v[f], tri_n=vn[f])
    o, d = rays_towards(rng, N_RAYS)
    compare(mi, ours, theirs, o, d)
