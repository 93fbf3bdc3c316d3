"""What the two volumetric path tracers share: the state of a batch of paths (building blocks).

The algorithm itself (the segment loop, scattering in a medium, surfaces and
medium tracking, shadow rays) is in :mod:`.volpath_phase` and :mod:`.volpath`;
this module holds the bookkeeping they share: the per-path arrays, random
numbers per segment, Mitsuba's roulette rule and the camera's view of emitters.

A path in a scene with media is a sequence of *segments*: each starts at the
camera, a surface or a point inside a medium and ends where the next event is
sampled (a scattering point in a medium, or a surface). Unlike surface-only
path tracing, the number of scattering events after k segments differs from
path to path (crossing an index-matched ``null`` boundary is a segment but no
scattering event), so the depth, the current medium, the last scattering
vertex and its pdf are per-path arrays here.

Random numbers: segment ``k`` of every path draws from its own block of
counters (``SLOTS`` numbers, at fixed offsets for roulette, free flight,
light choice, lobe and direction, then one per surface a shadow ray crosses),
so a path sees the same numbers whatever else is in its batch and the image
does not depend on batching.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..media.homogeneous import camera_medium, choose_channel
from ..sensors.perspective import Rays
from ..shapes.intersect import offset_p
from .base import CameraIntegrator, replace_hits, skip_emitters, subset_hit, trace

#: Counters reserved per segment; shadow rays use SLOT_SHADOW + k for their k-th crossing.
SLOTS = 512
SLOT_ROULETTE, SLOT_FLIGHT, SLOT_LIGHT, SLOT_LOBE, SLOT_DIRECTION, SLOT_SHADOW = 0, 1, 2, 5, 6, 16
#: Hard cap on segments (null crossings add segments without adding depth).
MAX_SEGMENTS = 4000


@dataclass
class PathBatch:
    """Per-path state of the live paths (row = index into the result).

    ``last_p`` / ``last_pdf``: position and sampling pdf of the last real
    scattering event (null crossings do not update them), for MIS.
    ``specular``: the last event was a Dirac bounce (or a scatter in a medium
    without emitter sampling), so emission found next counts in full.
    """

    row: np.ndarray
    o: np.ndarray
    d: np.ndarray
    tmax: np.ndarray
    beta: np.ndarray
    eta: np.ndarray
    depth: np.ndarray
    medium: np.ndarray
    channel: np.ndarray
    last_p: np.ndarray
    last_pdf: np.ndarray
    specular: np.ndarray
    rng: object

    def keep(self, rows: np.ndarray) -> "PathBatch":
        """The paths ``rows`` (integer indices) of this batch."""
        fields = {k: np.take(v, rows, axis=0) for k, v in vars(self).items() if k != "rng"}
        return PathBatch(**fields, rng=self.rng.subset(rows))

    def __len__(self) -> int:
        return len(self.row)


class VolumeIntegrator(CameraIntegrator):
    """Base of ``volpath`` and ``volpath_phase``: path setup, random numbers, roulette."""

    #: Renders participating media (render() refuses media scenes for the others).
    handles_media = True

    def start(self, scene, rays, rng) -> PathBatch:
        """Camera paths: throughput 1, in the sensor's medium, one RGB channel each."""
        n = len(rays)
        self._counter0 = rng.counter + 1
        channel = choose_channel(rng.next_1d())
        return PathBatch(row=np.arange(n), o=rays.o.copy(), d=rays.d.copy(), tmax=rays.tmax.copy(),
                         beta=np.ones((n, 3)), eta=np.ones(n), depth=np.zeros(n, np.int64),
                         medium=camera_medium(scene, n), channel=channel,
                         last_p=rays.o.copy(), last_pdf=np.ones(n),
                         specular=np.ones(n, dtype=bool), rng=rng)

    def counter(self, segment: int, slot: int) -> int:
        """Random-stream counter of ``slot`` in ``segment``."""
        return self._counter0 + segment * SLOTS + slot

    def uniform(self, paths: PathBatch, segment: int, slot: int, dims: int = 1) -> np.ndarray:
        """Uniform numbers of ``slot`` (and the next ``dims`` - 1) for every path."""
        paths.rng.counter = self.counter(segment, slot)
        return paths.rng.next_1d() if dims == 1 else paths.rng.next_2d()

    def survivors(self, paths: PathBatch, segment: int) -> np.ndarray:
        """Russian roulette and the depth limit at the start of a segment -> rows that go on.

        Mitsuba's ``volpath`` rule: once a path has scattered more than
        ``rr_depth`` times, continue with q = min(max(beta) eta^2, 0.95) and
        divide by q (every segment, null crossings included).
        """
        u = self.uniform(paths, segment, SLOT_ROULETTE)
        alive = np.any(paths.beta != 0, axis=1) & (paths.depth < self.depth_limit)
        # The surface integrators' rule, played once depth > rr_depth (not >=): depth - 1.
        survive, paths.beta = self.roulette_survivors(paths.beta, paths.eta, paths.depth - 1, u)
        return np.flatnonzero(alive & survive)

    def trace_segment(self, scene, paths: PathBatch):
        """Closest surface along each path's ray; area emitters skipped on the camera's
        segments (depth 0) when ``hide_emitters``."""
        rays = Rays(paths.o, paths.d, paths.tmax)
        hit = trace(scene, rays)
        if self.hide_emitters:
            first = np.flatnonzero(paths.depth == 0)
            if len(first):
                hit = replace_hits(hit, first, skip_emitters(scene, rays.subset(first),
                                                             subset_hit(hit, first)))
        return hit

    def visible_emission(self, depth: np.ndarray, Le: np.ndarray) -> np.ndarray:
        """``Le`` with the camera's view of emitters removed when ``hide_emitters``."""
        if self.hide_emitters:
            return np.where((depth == 0)[:, None], 0.0, Le)
        return Le


def move(paths: PathBatch, rows: np.ndarray, origin: np.ndarray, normal: np.ndarray,
         wo: np.ndarray) -> None:
    """Start the next segment of paths ``rows`` at ``origin`` along ``wo`` (offset off a
    surface along ``normal``; zero normals for points inside a medium)."""
    paths.o[rows] = offset_p(origin, normal, wo)
    paths.d[rows] = wo
    paths.tmax[rows] = np.inf
