"""The triangle BVH agrees with brute force, is watertight and honours tmin/tmax."""
import numpy as np
import pytest

from pathtracer.accel.bvh import BVH


def random_soup(rng, n, size=0.3):
    """``n`` random triangles scattered in [0, 10]^3."""
    return rng.random((n, 1, 3)) * 10 + rng.normal(size=(n, 3, 3)) * size


def random_rays(rng, n, lo=-1.0, hi=11.0):
    o = rng.uniform(lo, hi, (n, 3))
    d = rng.normal(size=(n, 3))
    return o, d / np.linalg.norm(d, axis=1, keepdims=True)


def lat_long_sphere(k):
    """Closed triangulated unit sphere: shared vertices, 4 k^2 triangles."""
    th, ph = np.meshgrid(np.linspace(0, np.pi, k + 1), np.linspace(0, 2 * np.pi, 2 * k + 1))
    v = np.stack((np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)), -1)
    v[-1] = v[0]  # identical seam vertices: the seam must not leak
    a, b, c, d = v[:-1, :-1], v[:-1, 1:], v[1:, :-1], v[1:, 1:]
    return np.concatenate((np.stack((a, b, d), 2).reshape(-1, 3, 3),
                           np.stack((a, d, c), 2).reshape(-1, 3, 3)))


def test_matches_brute_force_on_random_soup():
    rng = np.random.default_rng(1)
    tri = random_soup(rng, 1500)
    o, d = random_rays(rng, 10_000)
    t, prim, b1, b2 = BVH(tri).intersect(o, d)
    tb, primb, _, _ = BVH(tri, brute_force_max=10**9).intersect(o, d)
    assert 0.2 < np.mean(prim >= 0) < 0.9
    np.testing.assert_array_equal(t, tb)
    # Different prims only for exact ties in t.
    assert np.all((prim == primb) | (t == tb))
    h = prim >= 0
    p = o[h] + t[h, None] * d[h]
    v = tri[prim[h]]
    q = v[:, 0] + b1[h, None] * (v[:, 1] - v[:, 0]) + b2[h, None] * (v[:, 2] - v[:, 0])
    np.testing.assert_allclose(p, q, atol=1e-9)


def test_bounded_work_lists_give_the_same_hits(monkeypatch):
    """Traversal halves a work list longer than MAX_PAIRS and finishes the halves one after
    the other (bounded memory where many boxes overlap): the hits must not change."""
    rng = np.random.default_rng(5)
    tri = random_soup(rng, 1500, size=2.0)   # big, overlapping triangles: many live pairs
    o, d = random_rays(rng, 4000)
    bvh = BVH(tri)
    t, prim, b1, b2 = bvh.intersect(o, d)
    occ = bvh.occluded(o, d, np.full(len(o), 5.0))
    monkeypatch.setattr("pathtracer.accel.bvh.MAX_PAIRS", 64)
    t_small, prim_small, b1_small, b2_small = bvh.intersect(o, d)
    np.testing.assert_array_equal(t_small, t)
    assert np.all((prim_small == prim) | (t_small == t))
    np.testing.assert_array_equal(bvh.occluded(o, d, np.full(len(o), 5.0)), occ)
    tb, _, _, _ = BVH(tri, brute_force_max=10**9).intersect(o, d)
    np.testing.assert_array_equal(t_small, tb)


def test_tmax_and_occluded_consistent_with_intersect():
    rng = np.random.default_rng(2)
    tri = random_soup(rng, 800)
    o, d = random_rays(rng, 10_000)
    bvh = BVH(tri)
    t, prim, _, _ = bvh.intersect(o, d)
    tmax = rng.uniform(0, 12, len(o))
    t2, prim2, _, _ = bvh.intersect(o, d, tmax)
    closer = t < tmax
    np.testing.assert_array_equal(t2[closer], t[closer])
    assert np.all(prim2[~closer] == -1) and np.all(np.isinf(t2[~closer]))
    np.testing.assert_array_equal(bvh.occluded(o, d, tmax), closer)
    np.testing.assert_array_equal(bvh.occluded(o, d), prim >= 0)


@pytest.mark.parametrize("n_tris", [1, 2, 12, 31])
def test_small_scenes_brute_force_equals_tree(n_tris):
    rng = np.random.default_rng(n_tris)
    tri = random_soup(rng, n_tris, size=3.0)
    o, d = random_rays(rng, 3000)
    small = BVH(tri)
    assert small.brute_force
    tree = BVH(tri, brute_force_max=0)
    for a, b in zip(small.intersect(o, d), tree.intersect(o, d)):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(small.occluded(o, d, 5.0), tree.occluded(o, d, 5.0))


def test_watertight_closed_mesh():
    rng = np.random.default_rng(3)
    tri = lat_long_sphere(40)  # 6400 triangles
    bvh = BVH(tri)
    # Random rays from inside, and rays aimed exactly at vertices and edge
    # midpoints (shared by 2-6 triangles), from inside and from outside.
    verts = tri.reshape(-1, 3)
    mids = 0.5 * (tri[:, 0] + tri[:, 1])
    targets = np.concatenate((verts[rng.integers(0, len(verts), 3000)],
                              mids[rng.integers(0, len(mids), 3000)]))
    inside = rng.normal(size=(len(targets), 3)) * 0.2
    outside = rng.normal(size=(len(targets), 3))
    outside *= 3 / np.linalg.norm(outside, axis=1, keepdims=True)
    o_rand = rng.uniform(-0.55, 0.55, (5000, 3))  # inside the unit sphere
    d_rand = rng.normal(size=(5000, 3))
    o = np.concatenate((inside, outside, o_rand))
    d = np.concatenate((targets - inside, targets - outside, d_rand))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    t, prim, _, _ = bvh.intersect(o, d)
    assert np.all(prim >= 0), f"{np.sum(prim < 0)} rays slipped through"
    assert np.all(bvh.occluded(o, d))


def test_axis_aligned_rays_and_flat_boxes():
    # A grid of axis-aligned unit quads in z = 0 (zero-thickness boxes), hit
    # by rays along -z exactly through shared edges and corners, and rays
    # parallel to the plane that must miss.
    k = 16
    x, y = np.meshgrid(np.arange(k, dtype=float), np.arange(k, dtype=float))
    c = np.stack((x, y, np.zeros_like(x)), -1).reshape(-1, 3)
    ex, ey = np.array([1.0, 0, 0]), np.array([0, 1.0, 0])
    tri = np.concatenate((np.stack((c, c + ex, c + ex + ey), 1),
                          np.stack((c, c + ex + ey, c + ey), 1)))
    g = np.stack(np.meshgrid(np.arange(0, k + 0.1, 0.5), np.arange(0, k + 0.1, 0.5)), -1)
    o = np.concatenate((g.reshape(-1, 2), np.full((g.size // 2, 1), 2.0)), axis=1)
    d = np.tile([0.0, 0.0, -1.0], (len(o), 1))
    bvh = BVH(tri)
    t, prim, _, _ = bvh.intersect(o, d)
    assert np.all(prim >= 0) and np.allclose(t, 2.0)
    par = np.tile([1.0, 0.0, 0.0], (len(o), 1))
    o2 = o.copy()
    o2[:, 0] -= 20
    assert np.all(bvh.intersect(o2, par)[1] == -1)


def test_no_hits_behind_origin_or_at_zero():
    tri = lat_long_sphere(8)
    bvh = BVH(tri, brute_force_max=0)
    o = np.array([[0.0, 0.0, 5.0], [0.0, 0.0, 1.0]])  # outside; on the pole vertex
    d = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0]])  # both pointing away
    t, prim, _, _ = bvh.intersect(o, d)
    assert np.all(prim == -1) and np.all(np.isinf(t))


def test_empty_mesh():
    bvh = BVH(np.zeros((0, 3, 3)))
    o, d = np.zeros((5, 3)), np.tile([0.0, 0.0, 1.0], (5, 1))
    t, prim, _, _ = bvh.intersect(o, d)
    assert np.all(prim == -1) and np.all(np.isinf(t))
    assert not bvh.occluded(o, d, 1.0).any()


def test_far_away_origins():
    # Rays from 1e4 units away (float32 slab rounding is ~1e-3 there) still
    # hit small triangles exactly where brute force does.
    rng = np.random.default_rng(4)
    tri = random_soup(rng, 400, size=0.5)
    target = rng.uniform(0, 10, (4000, 3))
    o = rng.normal(size=(4000, 3))
    o *= 1e4 / np.linalg.norm(o, axis=1, keepdims=True)
    d = target - o
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    t, prim, _, _ = BVH(tri).intersect(o, d)
    tb, primb, _, _ = BVH(tri, brute_force_max=10**9).intersect(o, d)
    np.testing.assert_array_equal(t, tb)


def test_small_mesh_limits_blas_to_one_thread():
    """SmallMesh's tiny float32 matmuls must not use OpenBLAS threads: idle ones spin and,
    with the other cores busy, made a render cost 17x the CPU time."""
    import threadpoolctl  # a dependency of the project

    from pathtracer.accel.small_mesh import SmallMesh
    SmallMesh(np.random.default_rng(0).random((4, 3, 3)))
    blas = threadpoolctl.threadpool_info()
    assert blas and all(lib["num_threads"] == 1 for lib in blas if lib["user_api"] == "blas")


def test_split_mesh_equals_one_bvh():
    """A closed mesh inside a room of big triangles: the room in a SmallMesh first, the mesh in
    a BVH, gives the hits of one BVH over both (indices of the whole scene) and the same
    occlusion, with and without tmax."""
    from pathtracer.accel.small_mesh import SplitMesh, small_shapes
    rng = np.random.default_rng(5)
    room = random_soup(rng, 12, size=6.0)
    mesh = lat_long_sphere(24) * 2.0 + 5.0
    tri = np.concatenate((mesh[:500], room, mesh[500:]))
    shape = np.concatenate((np.zeros(500), np.arange(1, 13), np.zeros(len(mesh) - 500)))
    small = small_shapes(shape.astype(np.int32))
    assert small.sum() == 12 and np.all(small[500:512])
    split, whole = SplitMesh(tri, small), BVH(tri)
    o, d = random_rays(rng, 20_000)
    t, prim, b1, b2 = split.intersect(o, d)
    tw, primw, b1w, b2w = whole.intersect(o, d)
    in_room = (prim >= 500) & (prim < 512)
    assert np.mean(in_room) > 0.2 and np.mean((prim >= 0) & ~in_room) > 0.02   # 800 mesh hits
    same = prim == primw
    assert same.mean() > 0.999          # the rest: near-ties in float32 between room triangles
    np.testing.assert_allclose(t[same], tw[same], rtol=1e-12)
    np.testing.assert_allclose(b1[same], b1w[same], atol=1e-9)
    tmax = rng.uniform(0, 12, len(o))
    occ = split.occluded(o, d, tmax)
    assert np.mean(occ == whole.occluded(o, d, tmax)) > 0.999
    np.testing.assert_array_equal(occ, split.intersect(o, d, tmax)[1] >= 0)


def _parallelogram_pairs(rng, count):
    """``count`` random parallelograms, each as two triangles with shuffled vertex orders."""
    tris = []
    for _ in range(count):
        x, e1, e2 = rng.normal(size=(3, 3))
        s, t = x + e1, x + e2
        halves = ([x, s, t], [s + t - x, s, t])
        tris += [[h[i] for i in rng.permutation(3)] for h in halves]
    return np.array(tris)


def test_small_mesh_pairs_parallelograms_and_matches_the_bvh():
    """SmallMesh tests each rectangle (two triangles forming a parallelogram, in any vertex
    order) as one primitive, lone triangles as before: the hits, triangle indices and
    barycentrics are those of the BVH (float64 Möller–Trumbore per triangle)."""
    from pathtracer.accel.small_mesh import SmallMesh
    rng = np.random.default_rng(11)
    lone = rng.normal(size=(7, 3, 3))
    kite = np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[1, 0, 0], [0, 1, 0], [2, 2, 0]]], float)
    tri = np.concatenate((_parallelogram_pairs(rng, 20), lone, kite + 3.0))
    mesh = SmallMesh(tri)
    assert mesh.num_primitives == 20 + 7 + 2   # the kite's halves share an edge but stay apart
    n = 40_000
    k = rng.integers(0, len(tri), n)
    target = np.einsum("nk,nkj->nj", rng.dirichlet((1, 1, 1), n), tri[k])
    o = rng.normal(size=(n, 3)) * 4
    d = target - o
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    t, prim, b1, b2 = mesh.intersect(o, d)
    tb, primb, b1b, b2b = BVH(tri, brute_force_max=10**9).intersect(o, d)
    assert (prim >= 0).all()
    same = prim == primb
    assert same.mean() > 0.9995   # the rest: float32 near-ties at shared edges
    np.testing.assert_allclose(t[same], tb[same], rtol=1e-10)
    np.testing.assert_allclose(b1[same], b1b[same], atol=1e-9)
    np.testing.assert_allclose(b2[same], b2b[same], atol=1e-9)
    v = tri[prim]
    p = v[:, 0] + b1[:, None] * (v[:, 1] - v[:, 0]) + b2[:, None] * (v[:, 2] - v[:, 0])
    np.testing.assert_allclose(p, o + t[:, None] * d, atol=1e-9)
    np.testing.assert_array_equal(mesh.occluded(o, d, t * 0.999), prim != prim)   # no hit before


def test_rays_along_the_bounds_are_not_culled():
    """Rays are first tested against the tree's bounds (a float64 slab test with a tiny
    margin): segments that just reach a face of the bounds, and rays lying in a face plane,
    must find the triangles that brute force finds."""
    rng = np.random.default_rng(6)
    soup = random_soup(rng, 600, size=0.5)
    top = soup[..., 2].max() + 0.5
    flat = np.array([[[0, 0, top], [10, 0, top], [0, 10, top]],
                     [[10, 0, top], [10, 10, top], [0, 10, top]]], float)   # the top face
    tri = np.concatenate((soup, flat))
    bvh, brute = BVH(tri), BVH(tri, brute_force_max=10**9)
    n = 4000
    # Segments from above that end 1e-7 past the points of the top face they aim at.
    target = np.column_stack((rng.uniform(0.5, 9.5, (n, 2)), np.full(n, top)))
    o = target + rng.normal(size=(n, 3)) * [2, 2, 0] + [0, 0, 5]
    d = target - o
    dist = np.linalg.norm(d, axis=1)
    d /= dist[:, None]
    t, prim, _, _ = bvh.intersect(o, d, dist * (1 + 1e-7))
    assert np.all(prim >= len(soup))   # every segment reaches the top face
    np.testing.assert_array_equal(bvh.occluded(o, d, dist * (1 + 1e-7)), np.ones(n, bool))
    # Rays in the face planes of the bounds, half of them parallel to the face.
    lo, hi = tri.reshape(-1, 3).min(axis=0), tri.reshape(-1, 3).max(axis=0)
    o = rng.uniform(lo, hi, (n, 3))
    d = rng.normal(size=(n, 3))
    axis = rng.integers(0, 3, n)
    face = np.where(rng.random((n, 1)) < 0.5, lo, hi)
    o[np.arange(n), axis] = face[np.arange(n), axis]
    d[np.arange(n) % 2 == 0, axis[np.arange(n) % 2 == 0]] = 0.0
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    t, prim, _, _ = bvh.intersect(o, d)
    tb, primb, _, _ = brute.intersect(o, d)
    assert (prim >= 0).sum() > 100
    np.testing.assert_array_equal(t, tb)
    np.testing.assert_array_equal(bvh.occluded(o, d, 3.0), brute.occluded(o, d, 3.0))
