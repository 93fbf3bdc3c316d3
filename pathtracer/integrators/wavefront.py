"""The wavefront: a batch of paths traced in lock-step, and the helpers on hit batches.

An integrator evaluates its estimator for a whole batch of camera rays at once. Every
path of the batch is one row of a set of arrays (its result row, throughput, ...); a path
that ends is removed from all of them together, so that each vertex costs work only for
the paths still alive. :class:`Paths` owns those arrays and that bookkeeping, so that an
integrator's ``radiance`` says only what its estimator does at a vertex::

    paths = self.camera_paths(scene, rays, rng)     # every camera ray at its first hit
    while paths:
        paths.add_radiance(paths.beta * Le)         # L += beta * Le
        paths.keep(mask)                            # the paths where mask holds go on
        paths.scatter(bs.wo, bs.weight, bs.eta)     # beta *= f cos / p
        paths.next_hit(scene)                       # trace the scattered rays
    return paths.L

The random stream of a path travels with it, so a path sees the same numbers whichever
other paths share its batch (:mod:`pathtracer.core.rng`).

A *pool* (:meth:`Paths.pool`) holds at most ``size`` live paths of a longer list of
camera rays: when roulette has thinned it below half, :meth:`Paths.next_hit` tops it up
with new camera paths at their first hits. Every iteration then works on thousands of
paths instead of a batch's last few dozen (a batch's roulette tail had taken a third of
a render's time), and each path still sees the numbers and the arithmetic it would see
alone, so the image is bit-identical. The estimator's code must treat ``depth`` as a
per-path array for that: integrators that do say so with ``refills = True``
(:attr:`~pathtracer.integrators.base.Integrator.refills`).
"""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from ..core.rays import Rays
from ..core.rng import RandomStream
from ..core.vec import put_rows
from ..shapes import intersect


class Paths:
    """The live paths of one batch of camera rays.

    Per-path arrays (one row per live path, in this order):

    ``row``   the camera ray (row of :attr:`L`) the path adds its radiance to
    ``beta``  (m, 3) throughput: the path's f cos / p products (and 1/q of roulette)
    ``eta``   (m,) product of the relative indices of refraction crossed (for roulette)
    ``wi``    (m, 3) unit direction from the hit back along the ray that reached it
    ``wo``    (m, 3) the scattered direction, once :meth:`scatter` has chosen it
    ``hit``   the intersection of each path's current ray (:mod:`pathtracer.shapes.intersect`)
    ``rng``   the paths' random streams (:class:`pathtracer.core.rng.RandomStream`)

    plus every array an integrator adds with :meth:`declare`. ``depth`` counts the
    segments before the current hit (0 on the camera ray's hit): one int for a batch
    (its paths move in lock-step), an (m,) array in a pool; paths made by
    :meth:`segments` (the volume integrators) have it per path too, and count in it
    what their integrator counts (scattering events). :attr:`L` (n, 3) is every camera
    ray's radiance sample, live or not.

    What :meth:`add_radiance` adds waits in ``gathered``, the path's own (m, 3) row,
    until the path ends (:meth:`keep`, :meth:`split`) or :attr:`L` is read: adding to a
    contiguous array costs a thirtieth of a scatter into the camera rays' rows.

    Parameters
    ----------
    rays : Rays
        The camera rays (n of them).
    rng : RandomStream
        One stream per camera ray.
    hit : hit batch or None
        Their first hits; None makes a batch without live paths (``max_depth`` = 0).
    untraced : bool
        With ``hit`` None: the paths are alive all the same, before their first segment is
        traced (:meth:`segments`).
    """

    def __init__(self, rays: Rays, rng: RandomStream, hit=None, *, untraced: bool = False):
        n = len(rays)
        self._L = np.zeros((n, 3))
        alive = hit is not None or untraced
        live = n if alive else 0
        self.row, self.gathered, self.beta, self.eta, self.wi = _fresh(np.arange(live),
                                                                       rays.d[:live])
        self.wo = None
        self.hit = hit
        self.rng = rng if alive else rng.subset(self.row)
        self.depth = 0
        self._fields = ["row", "gathered", "beta", "eta", "wi", "wo"]
        self._rows_unique = True     # False once a path has split: rows of L repeat
        self._initial = {}           # declared fields' start values (for refills)
        self._waiting = None         # a pool's camera rays not started yet (see pool)
        self.first_counter = None    # segments' counters start here (see segments)

    @classmethod
    def pool(cls, rays: Rays, rng: RandomStream, size: int, trace_camera) -> "Paths":
        """A pool of at most ``size`` live paths over the camera rays ``rays``.

        The first ``size`` camera rays start at once; :meth:`next_hit` starts the others
        whenever fewer than ``size / 2`` paths are left. ``trace_camera(rays)`` returns
        the first hits of camera rays. ``depth`` is then a per-path array.
        """
        size = max(1, int(size))
        first = np.arange(min(size, len(rays)))
        camera = rays.subset(first)
        paths = cls(camera, rng.subset(first), trace_camera(camera))
        paths._L = np.zeros((len(rays), 3))
        paths._depth_per_path()
        # The camera streams as they are now: the integrator draws from its own copy.
        paths._waiting = _Waiting(rays, rng.subset(np.arange(len(rays))), len(first), size,
                                  trace_camera)
        return paths

    @classmethod
    def segments(cls, rays: Rays, rng: RandomStream, first_counter: int) -> "Paths":
        """Live paths on the camera rays ``rays``, not traced yet (``hit`` stays None), for an
        integrator that traces and counts every segment itself (the volume integrators,
        :mod:`.volume`).

        ``depth`` is then a per-path array that the integrator advances, and the paths draw
        their numbers at fixed counters (:meth:`numbers_at`), segment after segment, from
        ``first_counter`` on: a path sees the same numbers whatever else is in its batch.
        """
        paths = cls(rays, rng, untraced=True)
        paths._depth_per_path()
        paths.first_counter = first_counter
        return paths

    def _depth_per_path(self) -> None:
        """``depth`` as an (m,) array, one per path (pools, segments), carried like the others."""
        self.depth = np.zeros(len(self.row), np.int64)
        self._fields.append("depth")

    def numbers_at(self, counter: int, dims: int = 1, rows: np.ndarray | None = None) -> np.ndarray:
        """Every live path's uniform number ``counter`` of its stream (``dims`` = 2: that one
        and the next, as (m, 2)); only those of the paths ``rows`` (indices) if given: the
        same numbers as ``numbers_at(counter, dims)[rows]``, drawn for those paths alone."""
        self.rng.counter = counter + dims
        return self.rng.numbers(counter, dims, rows)

    def __len__(self) -> int:
        return len(self.row)

    def __bool__(self) -> bool:
        """Paths are alive, or a pool still has camera rays to start."""
        return len(self.row) > 0 or (self._waiting is not None and self._waiting.left > 0)

    def declare(self, **fields) -> None:
        """Add per-path arrays that :meth:`keep` and :meth:`split` carry along.

        Each value is a scalar (the same start value for every path) or an array with one
        row per camera ray (``len(L)``), of which every path takes its own row.
        """
        for name, value in fields.items():
            self._initial[name] = value
            setattr(self, name, self._start_values(name, self.row))
            self._fields.append(name)

    def _start_values(self, name: str, rows: np.ndarray) -> np.ndarray:
        """Declared field ``name`` of new paths on camera rays ``rows``."""
        value = self._initial[name]
        if np.ndim(value) == 0:
            return np.full(len(rows), value)
        return np.asarray(value)[rows]

    @property
    def L(self) -> np.ndarray:
        """(n, 3) radiance sample of every camera ray, with what the live paths gathered."""
        self._deliver(slice(None))
        return self._L

    @L.setter
    def L(self, value) -> None:
        # An integrator (a submission, say) may assign L whole (``paths.L = paths.L + x``):
        # the value it read holds what the live paths gathered (the getter delivered it), so
        # the gathered sums restart from zero.
        self.gathered[...] = 0.0
        self._L = np.asarray(value, dtype=np.float64)

    def add_radiance(self, value: np.ndarray, rows=None) -> None:
        """``L += value`` for every live path (or for the live paths ``rows``)."""
        if rows is None:
            self.gathered += value
        else:
            self.gathered[rows] += value

    def keep(self, mask: np.ndarray):
        """Keep the paths where ``mask`` holds, with every array and random stream.

        Returns what indexes the kept rows of any other per-path array.
        """
        if mask.all():
            return slice(None)
        self._deliver(np.flatnonzero(~mask))
        rows = np.flatnonzero(mask)
        self._take(rows)
        self.rng = self.rng.subset(rows)
        return rows

    def _deliver(self, paths) -> None:
        """Add the radiance that ``paths`` gathered to their camera rays' rows of ``L``."""
        target = self.row[paths]
        if self._rows_unique:    # np.take and put_rows: 3-4x faster than fancy (m, 3) indexing
            gathered = self.gathered if isinstance(paths, slice) else np.take(self.gathered, paths, axis=0)
            put_rows(self._L, target, np.take(self._L, target, axis=0) + gathered)
        else:   # rows repeat: unbuffered adds, on the flat array (NumPy's fast path, ~3x)
            flat = (target[:, None] * 3 + np.arange(3)).ravel()
            np.add.at(self._L.reshape(-1), flat, self.gathered[paths].ravel())
        self.gathered[paths] = 0.0

    def split(self, copies: int, rows=None) -> np.ndarray:
        """Replace paths ``rows`` (default: all) by ``copies`` children each.

        The paths not split come first, in their order, then the children of every split
        path together (path-major). A child gets its parent's arrays and an independent
        random stream (:meth:`pathtracer.core.rng.RandomStream.branch`); each adds to its
        parent's row of :attr:`L`. Returns the parent index of every new path.
        """
        everything = rows is None or len(rows) == len(self)
        rows = np.arange(len(self)) if rows is None else np.asarray(rows)
        # Children must not inherit what the parent gathered. Only the parents deliver:
        # when a path's sum reaches L must not depend on the other paths of the batch.
        self._deliver(rows)
        whole = np.zeros(0, int) if everything else np.flatnonzero(
            ~np.isin(np.arange(len(self)), rows))
        parent = np.concatenate((whole, np.repeat(rows, copies)))
        if everything:
            self.rng = self.rng.branch(copies)
        else:
            self.rng = RandomStream.concatenate([self.rng.subset(whole),
                                                 self.rng.subset(rows).branch(copies)])
        self._take(parent)
        self._rows_unique = False
        return parent

    def scatter(self, wo: np.ndarray, weight: np.ndarray, eta=None) -> None:
        """Continue every path along ``wo``: ``beta *= weight`` (f cos / p), ``eta *= eta``."""
        self.wo = wo
        self.beta = self.beta * weight
        if eta is not None:
            self.eta = self.eta * eta
        self.depth += 1

    def next_hit(self, scene) -> None:
        """Trace every path's scattered ray to its next hit (a pool below half its size
        then starts new camera paths)."""
        # spawn reads only the hits' points and normals: those two of the compacted hit
        rays = spawn(SimpleNamespace(p=self._hit_field("p"), n=self._hit_field("n")), self.wo)
        self.hit = trace(scene, rays)
        self.wi = -rays.d
        self.wo = None
        waiting = self._waiting
        if waiting is not None and waiting.left and len(self) <= waiting.size // 2:
            self._start(waiting.next(waiting.size - len(self)))

    def _start(self, camera) -> None:
        """Append new paths on camera rays ``camera`` (indices), at their first hits."""
        waiting = self._waiting
        rays = waiting.rays.subset(camera)
        start = dict(zip(("row", "gathered", "beta", "eta", "wi"), _fresh(camera, rays.d)),
                     depth=np.zeros(len(camera), np.int64))
        for name in self._fields:
            value = getattr(self, name)
            if value is not None:
                new = start[name] if name in start else self._start_values(name, camera)
                setattr(self, name, np.concatenate((value, new)))
        self.hit = concatenate_hits([self.hit, waiting.trace_camera(rays)])
        self.rng = self.rng.joined(waiting.rng.subset(camera))

    @property
    def hit(self):
        """The intersection of each live path's current ray (compacted when first read)."""
        if self._hit_rows is not None:
            self._hit, self._hit_rows = subset_hit(self._hit, self._hit_rows), None
        return self._hit

    @hit.setter
    def hit(self, value) -> None:
        self._hit, self._hit_rows = value, None

    def _hit_field(self, name: str) -> np.ndarray:
        """One field of :attr:`hit` for the live paths, without compacting the others."""
        value = getattr(self._hit, name)
        return value if self._hit_rows is None else np.take(value, self._hit_rows, axis=0)

    def _take(self, rows) -> None:
        for name in self._fields:
            value = getattr(self, name)
            if value is not None:
                setattr(self, name, np.take(value, rows, axis=0))
        # The hit is compacted when next read: after roulette, only its points and normals
        # are (to spawn the next rays).
        if self._hit is not None:      # None: paths not traced yet (segments)
            self._hit_rows = rows if self._hit_rows is None else np.take(self._hit_rows, rows)


def _fresh(camera: np.ndarray, d: np.ndarray) -> tuple:
    """``row``, ``gathered``, ``beta``, ``eta`` and ``wi`` of new paths on camera rays
    ``camera`` (indices) with directions ``d``."""
    m = len(camera)
    return camera, np.zeros((m, 3)), np.ones((m, 3)), np.ones(m), -d


class _Waiting:
    """A pool's camera rays: those not started yet are ``begin:``."""

    def __init__(self, rays: Rays, rng: RandomStream, begin: int, size: int, trace_camera):
        self.rays, self.rng, self.begin, self.size = rays, rng, begin, size
        self.trace_camera = trace_camera

    @property
    def left(self) -> int:
        return len(self.rays) - self.begin

    def next(self, count: int) -> np.ndarray:
        """Indices of the next ``count`` camera rays (fewer at the end)."""
        rows = np.arange(self.begin, min(len(self.rays), self.begin + count))
        self.begin += len(rows)
        return rows


def trace(scene, rays: Rays):
    """Closest hit of every ray."""
    return intersect.intersect(scene, rays.o, rays.d, rays.tmax)


def spawn(hit, wo: np.ndarray) -> Rays:
    """Rays leaving the hits (anything with points ``p`` and geometric normals ``n``) along
    ``wo``, offset against self-intersection."""
    o = intersect.spawn_ray(hit.p, hit.n, wo)
    return Rays(o, wo, np.full(len(wo), np.inf))


def subset_hit(hit, rows):
    """The hits ``rows`` of a batch (works on any dataclass of arrays).

    ``rows`` are integer indices (``np.take`` along axis 0 is several times
    faster than fancy indexing of (n, 3) arrays) or a boolean mask.
    """
    rows = np.asarray(rows)
    if rows.dtype == bool:
        rows = np.flatnonzero(rows)
    return type(hit)(**{k: np.take(v, rows, axis=0) for k, v in vars(hit).items()})


def replace_hits(hit, rows, new):
    """A copy of ``hit`` with rows ``rows`` overwritten by ``new``."""
    out = {}
    for k, v in vars(hit).items():
        v = v.copy()
        v[rows] = getattr(new, k)
        out[k] = v
    return type(hit)(**out)


def concatenate_hits(hits: list):
    """One hit batch holding the rows of every batch of ``hits``, in order."""
    return type(hits[0])(**{k: np.concatenate([getattr(h, k) for h in hits], axis=0)
                            for k in vars(hits[0])})
