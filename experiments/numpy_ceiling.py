"""How fast can pure NumPy run this estimator at all? A ceiling for the speed targets.

Run ``python -m experiments.numpy_ceiling [--resolution 128] [--spp 16] [--rounds 5]
[--json OUT]``: the ceiling, our ``path`` and Mitsuba ``scalar_rgb``'s ``path`` render the
Cornell box in turn, one render of each per round, in one process pinned to a core, and the
paths per CPU-second and their ratios are printed per round.

:func:`render_ceiling` is Mitsuba's ``path`` estimator (next-event estimation and BSDF
sampling combined by the power heuristic, roulette after ``rr_depth``) written for one
kind of scene only: triangles, ``diffuse`` BSDFs, one-sided area lights, a box filter and
a pinhole camera, the Cornell box of the bench. It keeps only what that scene needs:

* one layout, (3, n) component rows, so that every per-component operation runs on
  contiguous memory and the all-pairs intersection never transposes;
* one normal and one albedo per triangle (flat shading; every BSDF diffuse), gathered
  by triangle index: no BSDF or emitter dispatch, no hit records, no texture lookups;
* one compaction per bounce, of eight arrays;
* NumPy's own bit generator (PCG64), drawn in bulk, instead of per-path counter streams
  (which make the tracer's images independent of batching);
* the tracer's own float32 all-pairs filter (:class:`pathtracer.accel.small_mesh.SmallMesh`),
  then ``t`` from the winning triangle's plane in float64.

Everything else a general tracer does for the same paths is left out, so its rate tells
how far a pure-NumPy tracer of this estimator can get on the machine at hand, and what
our ``path`` pays for being general (docs/performance.md, "A ceiling for pure NumPy").
Its image agrees with the committed Mitsuba reference (``tests/test_numpy_ceiling.py``), so
the ceiling is the rate of a correct renderer, not of one that skips work.
"""
from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np

from pathtracer import load_scene, render
from pathtracer.accel.small_mesh import SmallMesh
from pathtracer.core.machine import this_machine
from pathtracer.core.vec import frame

from .bench import SCENES

RAY_EPS = 1e-4  # offset of a ray's origin from its surface, and of a shadow ray's end


class DiffuseBox:
    """The scene tables the estimator reads, for a scene of triangles with diffuse BSDFs.

    Parameters
    ----------
    scene : pathtracer Scene (triangles only, every BSDF ``diffuse``, area emitters only)
    """

    def __init__(self, scene):
        if any(type(b).__name__ != "Diffuse" for b in scene.bsdfs):
            raise ValueError("the ceiling renders scenes of diffuse BSDFs only")
        tri = scene.tri_p
        self.mesh = SmallMesh(tri)
        e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
        cross = np.cross(e1, e2)
        area2 = np.linalg.norm(cross, axis=1)
        normal = cross / area2[:, None]
        # Per triangle, rows: normal (3), plane offset n . p0 (1), albedo (3), radiance (3).
        albedo = np.array([scene.bsdfs[b].reflectance for b in scene.shape_bsdf])[scene.tri_shape]
        radiance = np.zeros((len(tri), 3))
        light = np.zeros(len(tri), bool)
        for e in scene.emitters:
            mine = scene.tri_shape == e.shape
            radiance[mine], light[mine] = e.radiance, True
        self.normal = np.ascontiguousarray(normal.T)
        self.offset = np.einsum("ij,ij->i", normal, tri[:, 0])
        self.albedo = np.ascontiguousarray(albedo.T)
        self.radiance = np.ascontiguousarray(radiance.T)
        self.is_light = light
        # Light sampling: a triangle by area, then a uniform point on it.
        self.light_tri = np.flatnonzero(light)
        light_area = area2[light] / 2
        self.light_area = light_area.sum()
        self.light_cdf = np.cumsum(light_area) / self.light_area
        self.light_p0 = np.ascontiguousarray(tri[light, 0].T)
        self.light_e1 = np.ascontiguousarray(e1[light].T)
        self.light_e2 = np.ascontiguousarray(e2[light].T)

    def closest(self, o, d):
        """Triangle (n,) int (-1: none) and float64 distance (n,) of the first hit of rays
        (o, d: (3, n))."""
        n = o.shape[1]
        key = np.empty(n, np.uint32)
        chunk = self.mesh.chunk
        for s in range(0, n, chunk):
            key[s:s + chunk] = self.mesh._closest_keys(o[:, s:s + chunk], d[:, s:s + chunk])
        found = key < np.uint32(0x7F800000)
        prim = (key & np.uint32((1 << self.mesh._bits) - 1)).astype(np.intp)
        # The winning primitive's triangle: the half that contains the point. Both halves
        # of a parallelogram share a plane, so either gives t and the normal.
        tri = self.mesh._triangles[2 * prim]
        normal = _cols(self.normal, tri)
        t = (self.offset[tri] - np.einsum("ij,ij->j", normal, o)) / np.einsum("ij,ij->j", normal, d)
        return np.where(found, tri, -1), t


def _cols(a, index):
    """Columns ``index`` of (3, n) ``a``: ``np.take`` is 4x faster than ``a[:, index]``."""
    return np.take(a, index, axis=1)


def _add_cols(a, index, value):
    """``a[:, index] += value`` for unique ``index``, one component row at a time."""
    for c in range(3):
        a[c, index] += value[c]


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _power(a, b):
    a2 = a * a
    return a2 / (a2 + b * b)


def _radiance(box: DiffuseBox, o, d, rng, rr_depth: int = 5):
    """Radiance (3, n) along camera rays (o, d: (3, n)): Mitsuba's ``path``, unbounded depth.

    At vertex x_k (normal n, albedo rho) reached with throughput beta along d::

        L += beta * Le * w_bsdf,        w_bsdf = p_bsdf^2 / (p_bsdf^2 + p_light^2)  (1 from the camera)
        y ~ uniform on the lights;      p_light = |y - x|^2 / (cos_l A)
        L += beta * rho / pi * cos_x * Le * V(x, y) / p_light * w_light
        w ~ cosine hemisphere;          beta *= rho,  p_bsdf = cos / pi
        after rr_depth bounces: go on with q = min(max(beta), 0.95), beta /= q
    """
    n = o.shape[1]
    # ---- Loop state: one column per live path ----
    L = np.zeros((3, n))           # radiance of every camera ray
    index = np.arange(n)           # each live path's column of L
    beta = np.ones((3, n))         # path throughput
    prev_p = None                  # previous vertex, for the light pdf of a hit (None: camera)
    prev_pdf = np.ones(n)          # pdf of the BSDF sample that left it
    depth = 0                      # bounces so far (the paths move in lock-step)
    tri, t = box.closest(o, d)
    while True:
        # ---- Emission found by BSDF sampling, weighted against light sampling ----
        hit = tri >= 0
        tri = np.where(hit, tri, 0)
        normal = _cols(box.normal, tri)
        cos_wi = -_dot(normal, d)
        lit = np.flatnonzero(box.is_light[tri] & hit & (cos_wi > 0))
        if len(lit):
            w = 1.0
            if prev_p is not None:
                to_hit = _cols(o, lit) + t[lit] * _cols(d, lit) - _cols(prev_p, lit)
                pdf_light = _dot(to_hit, to_hit) / (cos_wi[lit] * box.light_area)
                w = _power(prev_pdf[lit], pdf_light)
            _add_cols(L, index[lit], _cols(beta, lit) * _cols(box.radiance, tri[lit]) * w)

        # ---- Paths that escaped or met a back face end; roulette, then one compaction ----
        live = np.flatnonzero(hit & (cos_wi > 0))
        q = None
        if depth >= rr_depth:
            q = np.minimum(_cols(beta, live).max(axis=0), 0.95)
            survive = rng.random(len(live)) < q
            live, q = live[survive], q[survive]
        if not len(live):
            return L
        index, tri, t = index[live], tri[live], t[live]
        beta = _cols(beta, live) if q is None else _cols(beta, live) / q
        o, d, normal = _cols(o, live), _cols(d, live), _cols(normal, live)
        if prev_p is not None:
            prev_p = _cols(prev_p, live)
        x = o + t * d
        albedo = _cols(box.albedo, tri)
        m = len(live)

        # ---- Direct light: a point on a light, a shadow ray, MIS against BSDF sampling ----
        u = rng.random((3, m))
        pick = np.minimum(np.searchsorted(box.light_cdf, u[0], side="right"), len(box.light_cdf) - 1)
        root = np.sqrt(u[1])
        b1, b2 = 1.0 - root, u[2] * root
        y = _cols(box.light_p0, pick) + _cols(box.light_e1, pick) * b1 + _cols(box.light_e2, pick) * b2
        to_light = y - x
        dist2 = _dot(to_light, to_light)
        wo = to_light / np.sqrt(dist2)
        cos_x = _dot(normal, wo)
        cos_l = -_dot(_cols(box.normal, box.light_tri[pick]), wo)
        useful = np.flatnonzero((cos_x > 0) & (cos_l > 0))
        if len(useful):
            origin = _cols(x, useful) + RAY_EPS * _cols(normal, useful)
            to = _cols(y, useful) - origin
            span = np.sqrt(_dot(to, to))
            blocker, t_block = box.closest(origin, to / span)
            visible = (blocker < 0) | (t_block >= span * (1 - RAY_EPS))
            pdf_light = dist2[useful] / (cos_l[useful] * box.light_area)
            pdf_bsdf = cos_x[useful] / np.pi
            Le = _cols(box.radiance, box.light_tri[pick[useful]])
            f = _cols(albedo, useful) / np.pi * cos_x[useful]
            weight = _power(pdf_light, pdf_bsdf) / pdf_light * visible
            _add_cols(L, index[useful], _cols(beta, useful) * f * Le * weight)

        # ---- BSDF sample: cosine-weighted hemisphere (weight = albedo) ----
        u = rng.random((2, m))
        r, phi = np.sqrt(u[0]), 2 * np.pi * u[1]
        cos_theta = np.sqrt(np.maximum(0.0, 1.0 - u[0]))
        _, s_axis, t_axis = frame(normal.T)   # the tracer's frame; columns of normal.T are rows
        x_local, y_local = r * np.cos(phi), r * np.sin(phi)
        d = np.stack([s_axis[c] * x_local + t_axis[c] * y_local + normal[c] * cos_theta
                      for c in range(3)])
        beta = beta * albedo
        prev_p, prev_pdf = x, cos_theta / np.pi
        depth += 1

        # ---- The next hit ----
        o = x + RAY_EPS * normal
        tri, t = box.closest(o, d)


def render_ceiling(scene, spp: int, seed: int = 0, batch: int = 32768):
    """Render the Cornell-box-like ``scene`` (see :class:`DiffuseBox`) with ``spp`` samples per
    pixel, in batches of ``batch`` paths, through the scene's pinhole camera and box filter.

    Returns
    -------
    mean, variance : (H, W, 3) arrays
        Per-pixel mean and unbiased per-sample variance (as :func:`pathtracer.render` returns
        them, for :func:`mitsuba_refs.stats.compare_means`).
    """
    camera = scene.camera
    width, height = camera.width, camera.height
    box = DiffuseBox(scene)
    rng = np.random.default_rng(seed)
    total = width * height * spp
    moments = np.zeros((2, 3, width * height))     # per pixel: sum of L and of L^2
    tan_half = np.tan(np.radians(camera.x_fov) / 2)
    rotation, origin = camera.to_world[:3, :3], camera.to_world[:3, 3]
    for start in range(0, total, batch):
        pixel = np.arange(start, min(start + batch, total)) // spp
        u = rng.random((2, len(pixel)))
        s_x = (pixel % width + u[0]) / width
        s_y = (pixel // width + u[1]) / height
        d_cam = np.stack(((1 - 2 * s_x) * tan_half, (1 - 2 * s_y) * tan_half * height / width,
                          np.ones(len(pixel))))
        near = camera.near_clip / d_cam[2] * np.sqrt(_dot(d_cam, d_cam))   # along the unit ray
        d = rotation @ d_cam
        d /= np.sqrt(_dot(d, d))
        o = origin[:, None] + d * near
        L = _radiance(box, o, d, rng)
        for c in range(3):
            moments[0, c] += np.bincount(pixel, L[c], minlength=width * height)
            moments[1, c] += np.bincount(pixel, L[c] * L[c], minlength=width * height)
    mean = moments[0] / spp
    variance = np.maximum(moments[1] - spp * mean * mean, 0.0) / (spp - 1) if spp > 1 else 0 * mean
    return (mean.T.reshape(height, width, 3), variance.T.reshape(height, width, 3))


def _cpu_rate(render_once, paths: int) -> float:
    """Paths per CPU-second of one call of ``render_once``."""
    start = time.process_time()
    render_once()
    return paths / (time.process_time() - start)


def alternate(resolution: int, spp: int, rounds: int, mitsuba: bool = True) -> dict:
    """Paths per CPU-second of the ceiling, our ``path`` and Mitsuba ``scalar_rgb``'s ``path``
    on the Cornell box, one render of each per round, in this process (pin it to a core).

    The three alternate round by round, so that a busy neighbour on a shared machine slows
    all of them alike; the ratios are taken within each round.
    """
    scene = load_scene(str(SCENES / "cornell-box.xml"), width=resolution, height=resolution)
    paths = resolution * resolution * spp
    sides = {"ceiling": lambda seed: render_ceiling(scene, spp, seed),
             "path": lambda seed: render(scene, integrator="path", spp=spp, seed=seed,
                                         processes=1, progress=False)}
    if mitsuba:
        import drjit as dr  # optional and heavy: imported where it renders
        import mitsuba as mi
        mi.set_variant("scalar_rgb")
        dr.set_thread_count(1)
        mi_scene = mi.load_file(str(SCENES / "cornell-box.xml"), width=resolution,
                                height=resolution, spp=spp)
        mi_path = mi.load_dict({"type": "path"})
        sides["mitsuba"] = lambda seed: np.asarray(mi.render(mi_scene, integrator=mi_path,
                                                             spp=spp, seed=seed))
    for warm_up in sides.values():
        warm_up(99)
    rates = {name: [] for name in sides}
    for round_ in range(rounds):
        for name, side in sides.items():
            rates[name].append(_cpu_rate(lambda: side(round_), paths))
    return dict(machine=this_machine().describe(), resolution=resolution, spp=spp, rates=rates)


def main(argv=None) -> None:
    """Print (and with ``--json`` write) the alternated rates of :func:`alternate`."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--resolution", type=int, default=128)
    parser.add_argument("--spp", type=int, default=16)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--core", type=int, default=0, help="core to pin to (-1: none)")
    parser.add_argument("--no-mitsuba", action="store_true", help="leave Mitsuba out")
    parser.add_argument("--json", help="write the rates here")
    args = parser.parse_args(argv)
    if args.core >= 0 and hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {args.core})
    report = alternate(args.resolution, args.spp, args.rounds, mitsuba=not args.no_mitsuba)
    rates = report["rates"]
    print(f"{report['machine']}; Cornell box {args.resolution}x{args.resolution}, {args.spp} spp; "
          "paths per CPU-second, one render of each per round")
    for round_ in range(args.rounds):
        row = {name: rates[name][round_] for name in rates}
        line = "  ".join(f"{name} {rate / 1e3:.0f}k" for name, rate in row.items())
        if "mitsuba" in row:
            line += (f"  | ceiling / mitsuba {row['ceiling'] / row['mitsuba']:.2f}"
                     f"  path / mitsuba {row['path'] / row['mitsuba']:.2f}")
        print(line + f"  path / ceiling {row['path'] / row['ceiling']:.2f}")
    if args.json:
        Path(args.json).write_text(json.dumps(report, indent=1))


if __name__ == "__main__":
    main()
