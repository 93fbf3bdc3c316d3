"""Jobs: what a worker computes for a group of units of camera samples.

A unit's radiance samples form a (pixels, samples, 3) array; per pixel the job yields
(n, mean, M2) (:func:`.moments.block_statistics`). A film with a tent or gaussian filter
(:mod:`pathtracer.sensors.film`) spreads every sample over the pixels within the filter's
radius: a unit then yields filter-weighted sums over the rows it reaches, added in unit
order (the image does not depend on the number of processes; a different batch size
changes only the float64 rounding).

Units count pixels of the *sample grid*: the image, or with the film's ``sample_border`` the
image and a border of ``b`` pixels around it (:attr:`~pathtracer.sensors.film.ReconstructionFilter.border`),
flat index ``(row + b) * (W + 2b) + column + b``. The random numbers of a sample are keyed
by that index, which for a film without a border (b = 0) is the pixel's own: a border
changes nothing of the images rendered without one.
"""

from __future__ import annotations

import numpy as np

from ..core.rng import RandomStream, sample_keys
from ..sensors.film import splat
from ..sensors.perspective import camera_rays
from ..sensors.primary import sample_camera_rays
from .moments import block_statistics


class CameraJob:
    """Everything a worker needs to render a group of units (inherited through fork)."""

    def __init__(self, scene, integrator, spp, seed, camera=camera_rays):
        self.scene, self.integrator, self.spp, self.seed = scene, integrator, spp, seed
        self.camera = camera

    def run(self, group):
        """Per unit of ``group``, the radiance statistics (count, mean, M2) of its pixels."""
        values, _ = self.samples(group)
        return [block_statistics(v.reshape(p1 - p0, s1 - s0, -1))
                for (p0, p1, s0, s1), v in zip(group, _per_unit(values, group))]

    def samples(self, group):
        """Every camera sample of the units of ``group``, in order, in one radiance call:
        (values (n, channels), film positions (n, 2))."""
        pixel = np.concatenate([np.repeat(np.arange(p0, p1), s1 - s0) for p0, p1, s0, s1 in group])
        sample = np.concatenate([np.tile(np.arange(s0, s1), p1 - p0) for p0, p1, s0, s1 in group])
        rng = RandomStream(sample_keys(self.seed, pixel.astype(np.int64) * self.spp + sample))
        u_film = rng.next_2d()
        camera = self.scene.camera
        if camera.rfilter.border:
            pixel, u_film = border_samples(camera, pixel, u_film)
        rays = sample_camera_rays(camera, pixel, u_film, rng, self.camera)
        return self.estimate(rays, rng), u_film

    def estimate(self, rays, rng):
        """(n, channels) values of the camera rays: the integrator's radiance."""
        return self.integrator.radiance(self.scene, rays, rng)


def sample_grid_size(camera) -> int:
    """Pixels of the sample grid: ``(W + 2b) (H + 2b)`` with the film's sample border ``b``."""
    b = camera.rfilter.border
    return (camera.width + 2 * b) * (camera.height + 2 * b)


def border_samples(camera, pixel: np.ndarray, u_film: np.ndarray):
    """``(pixel, u)`` for the camera of samples of the bordered grid: the nearest image pixel
    and the position relative to it (outside ``[0, 1)`` in the border), so that
    ``pixel % W + u`` is the sample's film position, as Mitsuba's ``pos - border_size``."""
    b, width, height = camera.rfilter.border, camera.width, camera.height
    col, row = pixel % (width + 2 * b) - b, pixel // (width + 2 * b) - b
    col_in, row_in = np.clip(col, 0, width - 1), np.clip(row, 0, height - 1)
    u = u_film + np.stack((col - col_in, row - row_in), axis=1)
    return row_in * width + col_in, u


def _per_unit(rows: np.ndarray, group) -> list[np.ndarray]:
    """``rows`` (one per camera sample of ``group``) cut into the units' parts."""
    ends = np.cumsum([(p1 - p0) * (s1 - s0) for p0, p1, s0, s1 in group])
    return np.split(rows, ends[:-1])


class FilteredJob:
    """Renders a unit exactly as ``job`` does, then splats it through the film's filter."""

    def __init__(self, job):
        self.job = job

    def run(self, group):
        """Per unit of ``group``, (lo, hi, sum w, sum w f, sum w f^2) over the flat pixel
        range ``lo:hi`` it reaches."""
        values, u_film = self.job.samples(group)
        return [self._splat(unit, v, u) for unit, v, u in
                zip(group, _per_unit(values, group), _per_unit(u_film, group))]

    def _splat(self, unit, values, u_film):
        camera, (p0, p1, s0, s1) = self.job.scene.camera, unit
        pixels, samples = p1 - p0, s1 - s0
        reach, b = camera.rfilter.reach, camera.rfilter.border
        grid_width = camera.width + 2 * b   # the image rows the unit's samples reach
        lo = max(0, p0 // grid_width - b - reach) * camera.width
        hi = min(camera.height, (p1 - 1) // grid_width - b + reach + 1) * camera.width
        return (lo, hi) + splat(camera.rfilter, camera.width, camera.height, np.arange(p0, p1),
                                u_film.reshape(pixels, samples, 2),
                                values.reshape(pixels, samples, -1), lo, hi)
