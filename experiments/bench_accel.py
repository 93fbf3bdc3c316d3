"""Micro-benchmark of the triangle BVH: build time and rays/s.

Scenes: a noisy height field (rays from above, like camera rays onto a
terrain) and a bumpy closed sphere (rays from a surrounding shell, aimed at
points inside it, so a ray enters and leaves the mesh). Both ~100k triangles,
64k rays; shadow rays go from the hit points to random points on a
shell. Run: ``python experiments/bench_accel.py [--tris N] [--rays N]``; with
``--render-queries`` it replays the BVH queries of a render of the benchmark mesh scene
instead (docs/performance.md's "replay").
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from experiments.bench import warmed_scene
from pathtracer import render
from pathtracer.accel.bvh import BVH
from pathtracer.shapes.intersect import spawn_ray_to


def height_field(n_tris: int, rng) -> np.ndarray:
    """Grid over [-1, 1]^2 with noisy heights, two triangles per cell."""
    k = int(np.sqrt(n_tris / 2))
    x, y = np.meshgrid(np.linspace(-1, 1, k + 1), np.linspace(-1, 1, k + 1))
    z = 0.1 * np.sin(6 * x) * np.cos(5 * y) + 0.01 * rng.standard_normal(x.shape)
    v = np.stack((x, y, z), axis=-1)
    a, b, c, d = v[:-1, :-1], v[:-1, 1:], v[1:, :-1], v[1:, 1:]
    return np.concatenate((np.stack((a, b, d), 2).reshape(-1, 3, 3),
                           np.stack((a, d, c), 2).reshape(-1, 3, 3)))


def bumpy_sphere(n_tris: int, rng) -> np.ndarray:
    """Latitude-longitude sphere with radial noise, closed."""
    k = int(np.sqrt(n_tris / 4))
    th, ph = np.meshgrid(np.linspace(0, np.pi, k + 1), np.linspace(0, 2 * np.pi, 2 * k + 1))
    r = 1 + 0.02 * rng.standard_normal(th.shape)
    r[-1] = r[0]  # close the seam
    r[:, 0], r[:, -1] = r[0, 0], r[0, -1]  # and the poles
    v = np.stack((r * np.sin(th) * np.cos(ph), r * np.sin(th) * np.sin(ph), r * np.cos(th)), -1)
    a, b, c, d = v[:-1, :-1], v[:-1, 1:], v[1:, :-1], v[1:, 1:]
    return np.concatenate((np.stack((a, b, d), 2).reshape(-1, 3, 3),
                           np.stack((a, d, c), 2).reshape(-1, 3, 3)))


def rays_at(n: int, rng, src_r: float, dst_r: float, up=False):
    """Unit rays from a shell of radius src_r towards points in a ball of radius dst_r."""
    o = rng.standard_normal((n, 3))
    o *= src_r / np.linalg.norm(o, axis=1, keepdims=True)
    if up:
        o[:, 2] = np.abs(o[:, 2])
    d = rng.uniform(-dst_r, dst_r, (n, 3)) - o
    return o, d / np.linalg.norm(d, axis=1, keepdims=True)


def bench(name, tri, o, d, rng, repeat=3):
    """Time building ``name``'s BVH and tracing the rays ``o``, ``d`` through it; print the rates."""
    t0 = time.perf_counter()
    bvh = BVH(tri)
    build = time.perf_counter() - t0
    t, prim, _, _ = bvh.intersect(o, d)
    # Shadow rays: from the hit points to random points on a shell of radius 3.
    h = prim >= 0
    v = tri[prim[h]]
    nrm = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
    so, sd, smax = spawn_ray_to(o[h] + t[h, None] * d[h], nrm, rays_at(h.sum(), rng, 3.0, 0.0)[0])
    best_i = best_o = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        bvh.intersect(o, d)
        t1 = time.perf_counter()
        occ = bvh.occluded(so, sd, smax)
        t2 = time.perf_counter()
        best_i, best_o = min(best_i, t1 - t0), min(best_o, t2 - t1)
    print(f"{name}: {len(tri)} tris, build {build:.2f} s, {bvh.num_nodes} nodes\n"
          f"  intersect: {len(o)} rays, {np.mean(h):.0%} hit, {len(o) / best_i / 1e3:.0f}k rays/s\n"
          f"  occluded:  {len(so)} shadow rays, {np.mean(occ):.0%} blocked, "
          f"{len(so) / best_o / 1e3:.0f}k rays/s")


def render_queries(size: int = 128, spp: int = 16, repeat: int = 3) -> None:
    """Replay the BVH queries of a render of the benchmark mesh scene; print the best time.

    The render (``path``, ``size`` x ``size``, ``spp``) records every closest-hit and
    shadow-ray query that reaches the mesh's BVH; they are then run again on their own, so
    that a change to the traversal is timed on the rays a render really traces (from
    surfaces, bounded by the room's hits) rather than on synthetic ones.
    """
    scene = warmed_scene("mesh", "path", size, size)
    bvh = scene._accel.big
    queries = []
    record = {"intersect": bvh.intersect, "occluded": bvh.occluded}

    def recording(kind):
        def query(o, d, tmax=None):
            queries.append((kind, np.array(o), np.array(d), None if tmax is None else np.array(tmax)))
            return record[kind](o, d, tmax)
        return query

    bvh.intersect, bvh.occluded = recording("intersect"), recording("occluded")
    try:
        render(scene, integrator="path", spp=spp, seed=1, processes=1, progress=False)
    finally:
        del bvh.intersect, bvh.occluded
    best = np.inf
    for _ in range(repeat):
        t0 = time.process_time()
        for kind, o, d, tmax in queries:
            getattr(bvh, kind)(o, d, tmax)
        best = min(best, time.process_time() - t0)
    rays = sum(len(q[1]) for q in queries)
    print(f"mesh scene render queries: {len(queries)} calls, {rays} rays, "
          f"best {best:.3f} CPU-s ({rays / best / 1e3:.0f}k rays/s)")


def main():
    """Benchmark the intersector on a height field and a bumpy sphere (command line)."""
    ap = argparse.ArgumentParser()
    ap.add_argument("--tris", type=int, default=100_000)
    ap.add_argument("--rays", type=int, default=65_536)
    ap.add_argument("--render-queries", action="store_true",
                    help="instead: replay the BVH queries of a mesh-scene render (128 x 128, 16 spp)")
    args = ap.parse_args()
    if args.render_queries:
        render_queries()
        return
    rng = np.random.default_rng(0)
    bench("height field", height_field(args.tris, rng),
          *rays_at(args.rays, rng, 3.0, 1.0, up=True), rng)
    bench("bumpy sphere", bumpy_sphere(args.tris, rng), *rays_at(args.rays, rng, 3.0, 1.0), rng)


if __name__ == "__main__":
    main()
