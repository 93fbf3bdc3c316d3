"""What the two volumetric path tracers share: their paths' state and numbers (building blocks).

The algorithm itself (the segment loop, scattering in a medium, surfaces and
medium tracking, shadow rays) is in :mod:`.volpath_phase` and :mod:`.volpath`;
this module holds the bookkeeping they share: the per-path arrays (on the
wavefront's :class:`~pathtracer.integrators.wavefront.Paths`, made by
:meth:`VolumeIntegrator.start`), random numbers per segment, Mitsuba's
roulette rule and the camera's view of emitters.

A path in a scene with media is a sequence of *segments*: each starts at the
camera, a surface or a point inside a medium and ends where the next event is
sampled (a scattering point in a medium, or a surface). Unlike surface-only
path tracing, the number of scattering events after k segments differs from
path to path (crossing an index-matched ``null`` boundary is a segment but no
scattering event), so the depth, the current medium, the last scattering
vertex and its pdf are per-path arrays here.

Random numbers: segment ``k`` of every path draws from its own block of
counters (``SLOTS`` numbers, at fixed offsets for roulette, free flight,
light choice, lobe, direction and the null-collision choice, then one per step
of a shadow ray: a surface crossed or a tentative collision),
so a path sees the same numbers whatever else is in its batch and the image
does not depend on batching.

The integrators read the rows of the (n, 3) per-path arrays with ``np.take`` (once per
step, reusing what they gathered) and write them with ``put_rows`` or ``multiply_rows``
(:mod:`pathtracer.core.vec`): NumPy's fancy indexing of (n, 3) arrays is several times
slower, and the values are the same.
"""
from __future__ import annotations

import numpy as np

from ..core.rays import Rays
from ..core.vec import any_row, put_rows
from ..media.homogeneous import camera_medium, choose_channel
from ..shapes.intersect import offset_p
from .base import CameraIntegrator, replace_hits, skip_emitters, subset_hit, trace
from .wavefront import Paths

#: Counters reserved per segment; shadow rays use SLOT_SHADOW + k for their k-th step.
SLOTS = 512
SLOT_ROULETTE, SLOT_FLIGHT, SLOT_LIGHT, SLOT_LOBE, SLOT_DIRECTION, SLOT_SHADOW = 0, 1, 2, 5, 6, 16
#: Null or real collision in a heterogeneous medium.
SLOT_NULL = 8
#: Hard cap on segments (null crossings add segments without adding depth).
MAX_SEGMENTS = 4000


class VolumeIntegrator(CameraIntegrator):
    """Base of ``volpath``, ``volpathmis`` and ``volpath_phase``: path setup, random numbers,
    roulette."""

    #: Renders participating media (render() refuses media scenes for the others).
    handles_media = True

    def start(self, scene, rays, rng) -> Paths:
        """Camera paths (:meth:`Paths.segments`): throughput 1, in the sensor's medium, one RGB
        channel each, with the per-path arrays of a path in media.

        ``o``, ``d``, ``tmax``: the ray of the path's next segment; ``medium``: the medium it
        is in (-1: vacuum); ``channel``: the RGB channel of its free-flight sampling
        (:meth:`flight_channel`);
        ``last_p`` / ``last_pdf``: position and sampling pdf of the last real scattering event
        (null crossings do not update them), for MIS; ``specular``: the last event was a
        Dirac bounce (or a scatter in a medium without emitter sampling), so emission found
        next counts in full. ``depth`` counts the scattering events.
        """
        n = len(rays)
        first_counter = rng.counter + 1
        channel = self.flight_channel(rng.next_1d())
        paths = Paths.segments(rays, rng, first_counter)
        paths.declare(o=rays.o, d=rays.d, tmax=rays.tmax, medium=camera_medium(scene, n),
                      channel=channel, last_p=rays.o, last_pdf=1.0, specular=True)
        return paths

    def flight_channel(self, u: np.ndarray) -> np.ndarray:
        """The channel (n,) whose extinction drives each path's free flights, from uniform
        ``u``: one of R, G, B, uniformly (``volpath``)."""
        return choose_channel(u)

    @staticmethod
    def counter(paths: Paths, segment: int, slot: int) -> int:
        """Random-stream counter of ``slot`` in ``segment`` of ``paths``."""
        return paths.first_counter + segment * SLOTS + slot

    def uniform(self, paths: Paths, segment: int, slot: int, dims: int = 1,
                rows: np.ndarray | None = None) -> np.ndarray:
        """Uniform numbers of ``slot`` (and the next ``dims`` - 1) for every path, or for the
        paths ``rows`` (indices) alone: ``uniform(paths, segment, slot, dims)[rows]``."""
        return paths.numbers_at(self.counter(paths, segment, slot), dims, rows)

    def survivors(self, paths: Paths, segment: int) -> np.ndarray:
        """Russian roulette and the depth limit at the start of a segment -> which paths go on
        (a mask, for :meth:`Paths.keep`).

        Mitsuba's ``volpath`` rule: once a path has scattered more than
        ``rr_depth`` times, continue with q = min(max(beta) eta^2, 0.95) and
        divide by q (every segment, null crossings included).
        """
        u = self.uniform(paths, segment, SLOT_ROULETTE)
        alive = any_row(paths.beta != 0) & (paths.depth < self.depth_limit)
        # The surface integrators' rule, played once depth > rr_depth (not >=): depth - 1.
        survive, paths.beta = self.roulette_survivors(paths.beta, paths.eta, paths.depth - 1, u)
        return alive & survive

    def trace_segment(self, scene, paths: Paths):
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


def move(paths: Paths, rows: np.ndarray, origin: np.ndarray, normal: np.ndarray,
         wo: np.ndarray) -> None:
    """Start the next segment of paths ``rows`` at ``origin`` along ``wo`` (offset off a
    surface along ``normal``; zero normals for points inside a medium)."""
    put_rows(paths.o, rows, offset_p(origin, normal, wo))
    put_rows(paths.d, rows, wo)
    paths.tmax[rows] = np.inf
