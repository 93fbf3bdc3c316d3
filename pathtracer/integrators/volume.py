"""What the two volumetric path tracers share: the state of a batch of paths.

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

from ..camera import Rays
from ..geometry import offset_p
from ..media import camera_medium, choose_channel, next_medium, null_event, sample_free_flight
from ..shading import sample_bsdf
from .base import Integrator, replace_hits, skip_emitters, subset_hit, trace

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


class VolumeIntegrator(Integrator):
    """Base of ``volpath`` and ``volpath_phase``: path setup, random numbers, roulette."""

    #: Renders participating media (render() refuses media scenes for the others).
    handles_media = True

    def radiance(self, scene, rays, rng):
        return walk(self, scene, rays, rng)

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
        if self.roulette == "off":
            return np.flatnonzero(alive)
        perform = paths.depth > self.rr_depth
        if self.roulette == "constant":
            q = np.full(len(paths), 1.0 - self.rr_q)
        else:
            q = np.minimum(paths.beta.max(axis=1) * paths.eta ** 2, 0.95)
        alive &= ~perform | (u < q)
        paths.beta = np.where(perform[:, None], paths.beta / np.where(q > 0, q, 1.0)[:, None],
                              paths.beta)
        return np.flatnonzero(alive)

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

    def bounce(self, scene, paths: PathBatch, rows: np.ndarray, hit, segment: int) -> np.ndarray:
        """Continue paths ``rows`` at their surface hits by sampling the BSDF -> which go on.

        Updates throughput and eta, and the medium on the other side (medium tracking). A
        null crossing (a ``null`` BSDF, a ``thindielectric``'s straight transmission) keeps
        the depth, the last scattering vertex, its pdf and the specular flag (it is not a
        scattering event, as in Mitsuba); any other sampled lobe updates them.
        """
        valid = hit.valid.copy()
        on = np.flatnonzero(valid)
        rows, hit = rows[on], subset_hit(hit, on)
        bs = sample_bsdf(scene, hit, -paths.d[rows], self.uniform(paths, segment, SLOT_LOBE)[rows],
                         self.uniform(paths, segment, SLOT_DIRECTION, 2)[rows], self.hemisphere)
        real = ~null_event(scene, hit, -paths.d[rows], bs.wo)
        paths.beta[rows] *= bs.weight
        paths.eta[rows] *= bs.eta
        paths.depth[rows] += real
        paths.last_p[rows] = np.where(real[:, None], hit.p, paths.last_p[rows])
        paths.last_pdf[rows] = np.where(real, bs.pdf, paths.last_pdf[rows])
        paths.specular[rows] = np.where(real, bs.delta, paths.specular[rows])
        paths.medium[rows] = next_medium(scene, hit, paths.medium[rows], bs.wo)
        move(paths, rows, hit.p, hit.n, bs.wo)
        return valid


def move(paths: PathBatch, rows: np.ndarray, origin: np.ndarray, normal: np.ndarray,
         wo: np.ndarray) -> None:
    """Start the next segment of paths ``rows`` at ``origin`` along ``wo`` (offset off a
    surface along ``normal``; zero normals for points inside a medium)."""
    paths.o[rows] = offset_p(origin, normal, wo)
    paths.d[rows] = wo
    paths.tmax[rows] = np.inf


def walk(integrator: VolumeIntegrator, scene, rays, rng) -> np.ndarray:
    """The segment loop both volumetric integrators share -> radiance (n, 3).

    Each segment: roulette, trace to the next surface, sample a free flight in
    the current medium; paths that scatter in the medium go to
    ``integrator.in_medium``, the others to ``integrator.on_surface``. Both add
    their estimates to ``L`` and return which of their paths continue.
    """
    L = np.zeros((len(rays), 3))
    if integrator.max_depth == 0:
        return L
    paths = integrator.start(scene, rays, rng)
    for segment in range(MAX_SEGMENTS):
        paths = paths.keep(integrator.survivors(paths, segment))
        if not len(paths):
            break
        hit = integrator.trace_segment(scene, paths)
        flight = sample_free_flight(scene, paths.medium, paths.channel, hit.t,
                                    integrator.uniform(paths, segment, SLOT_FLIGHT))
        paths.beta = paths.beta * flight.weight
        goes_on = np.zeros(len(paths), dtype=bool)
        medium_rows = np.flatnonzero(flight.scattered)
        if len(medium_rows):
            goes_on[medium_rows] = integrator.in_medium(scene, paths, medium_rows,
                                                        flight.t[medium_rows], segment, L)
        surface_rows = np.flatnonzero(~flight.scattered)
        if len(surface_rows):
            goes_on[surface_rows] = integrator.on_surface(scene, paths, surface_rows,
                                                          subset_hit(hit, surface_rows), segment, L)
        paths = paths.keep(np.flatnonzero(goes_on))
    return L
