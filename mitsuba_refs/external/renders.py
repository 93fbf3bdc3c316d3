"""An external renderer as the ``render=`` hook of :func:`mitsuba_refs.verdicts.compare.compare`.

The comparison asks for images by ``(spp, seed, max_depth)``: a mean and per-sample variance
for the mean and variance verdicts, a mean alone for each render of the convergence ladder.
:class:`ExternalRenders` answers from runs of the user's command:

* **Variance from the renderer.** When its image carries ``var.R var.G var.B`` channels (or
  the template writes ``{out_variance}``), one run at ``spp`` gives mean and variance.
* **Variance from replicas.** Otherwise ``K`` runs (``--replicas``, default 8) at ``spp / K``
  samples each, with seeds of their own: the mean is their average and the per-sample
  variance their spread times ``spp / K``, so that ``variance / spp`` is the variance of the
  mean, as for our splatting integrators (:mod:`pathtracer.render.splats`). The first run of
  a check is the probe that tells which case holds.

Requests the comparison will make are *planned* ahead (:meth:`ExternalRenders.plan`), so that
the first one asked for runs together with the rest of its group, ``--jobs`` at a time.
Every image is checked before it is used: its size is the film's, a sample count in its header
is the one asked for, no two runs gave the same non-constant image (a renderer that ignores
``{seed}``), and
replicas do not share their noise. Non-finite or negative radiance is not bad input but a wrong
renderer: :class:`RendererFault`, which the check reports as a disagreement.
"""
from __future__ import annotations

import dataclasses
import hashlib
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pathtracer.render.splats import replica_count

from ..errors import RefsInputError
from ..stats import replicas as stats_replicas
from .images import ExternalImage, ImageError, image_faults, read_image
from .runner import Run, Runner, quoted

#: Replicas of a mean-and-variance request when the renderer writes no variance.
DEFAULT_REPLICAS = 8
#: Seeds of replicas: REPLICA_SEED_BASE + REPLICA_STRIDE * request seed + replica, far above the
#: comparison's own seeds (< 10^6), so no two runs of a check share one.
REPLICA_SEED_BASE = 10_000_000
REPLICA_STRIDE = 64
#: Replicas whose deviations from their median correlate above this share one source of noise
#: (independent ones correlate near 0, :func:`mitsuba_refs.stats.replicas.shared_noise`): refused.
MAX_SHARED_NOISE = 0.5
#: Seeds are 32-bit (Mitsuba's sampler seed). With a ``seed_offset`` (repeated checks, e.g. a
#: calibration), every seed goes through ``seed * SEED_MULTIPLIER + offset * SEED_INCREMENT``
#: modulo 2^32: one bijection per offset, so the seeds of one check stay distinct.
SEED_MULTIPLIER = 0x9E3779B1
SEED_INCREMENT = 0x7F4A7C15


class RendererFault(Exception):
    """The renderer's images hold values no radiance has (NaN, Inf, negative): a wrong
    renderer, reported as a disagreement with these lines."""

    def __init__(self, lines):
        super().__init__("; ".join(lines))
        self.lines = list(lines)


@dataclass(frozen=True)
class Request:
    """One image the comparison asks for: mean and variance (``variance``) or the mean alone."""

    spp: int
    seed: int
    max_depth: int | None
    variance: bool


class ExternalRenders:
    """Images of an external command, in the shape :func:`~mitsuba_refs.verdicts.compare.compare` asks.

    Parameters
    ----------
    template : CommandTemplate
        The user's command.
    runner : Runner
        Runs the commands (jobs, timeout).
    scene_file : Path
        What ``{scene}`` is.
    size : (int, int)
        The film's (width, height): every image must have it.
    defines : dict
        Scene parameters for ``{defines}``.
    max_depth : int
        ``{max_depth}`` of the renders that do not ask for another.
    replicas : int
        ``K`` of variance from replicas.
    suffix : str
        File name suffix of ``{out}`` (the renderer may choose its format by it).
    """

    def __init__(self, template, runner: Runner, scene_file, size, defines=None, max_depth=-1,
                 replicas=DEFAULT_REPLICAS, suffix=".exr", log=None, seed_offset=0):
        self.template, self.runner = template, runner
        self.scene_file, self.size = Path(scene_file), tuple(size)
        self.defines, self.max_depth = dict(defines or {}), max_depth
        self.replicas, self.suffix, self.log = int(replicas), suffix, log
        self.seed_offset = int(seed_offset)
        #: None until the probe says whether the renderer writes per-pixel variance.
        self.has_variance = True if template.writes_variance else None
        self._results: dict = {}           # Request -> (mean, variance or None)
        self._plans: list[list[Request]] = []
        self._extend = None
        self._seen: dict = {}              # sha256 of an image -> the run that made it
        self._runs_by_key: dict = {}       # (spp, seed, max_depth) asked for -> its Run
        self._workdir = Path(tempfile.mkdtemp(prefix="mitsuba-refs-check-"))

    @property
    def runs(self) -> list[Run]:
        """Every run made so far, in the order they were made."""
        return list(self._runs_by_key.values())

    # ---- the render hook ------------------------------------------------------------------
    def __call__(self, scene, integrator, params, spp, seed, processes=None, max_depth=None,
                 resolution=None):
        """Mean and per-sample variance of a render at ``spp`` (the hook's signature; the film
        size is the one the renderer was set up with)."""
        return self.get(self.request(spp, seed, max_depth, True))

    def render_mean(self, scene, integrator, params, spp, seed, processes=None, max_depth=None,
                    resolution=None):
        """The mean image alone of a render at ``spp`` (one run)."""
        return self.get(self.request(spp, seed, max_depth, False))[0]

    def request(self, spp, seed, max_depth=None, variance=True) -> Request:
        """The :class:`Request` of a render; ``max_depth`` None is the renders' own."""
        depth = self.max_depth if max_depth is None else int(max_depth)
        return Request(int(spp), int(seed), depth, variance)

    def plan(self, requests) -> None:
        """Requests to be made later, run together with the first of them that is asked for."""
        self._plans.append(list(requests))

    def extend_with(self, function) -> None:
        """``function(request)`` gives the group of an unplanned request (e.g. the convergence
        test's next, larger batch), or None."""
        self._extend = function

    def get(self, request: Request):
        """``(mean, variance)`` of ``request``, running its group first if needed."""
        if request not in self._results:
            group = next((plan for plan in self._plans if request in plan), None)
            if group is None and self._extend is not None:
                group = self._extend(request)
                if group:
                    self._plans.append(group)
            batch = [request] + [r for r in (group or []) if r != request and r not in self._results]
            self._render(batch)
        return self._results[request]

    def close(self) -> None:
        """Remove the temporary files of the runs."""
        shutil.rmtree(self._workdir, ignore_errors=True)

    # ---- runs -----------------------------------------------------------------------------
    def _render(self, requests) -> None:
        if self.has_variance is None and any(r.variance for r in requests):
            self._probe(next(r for r in requests if r.variance))
        pieces = {request: self._runs_of(request) for request in requests}
        todo = [run for runs in pieces.values() for run in runs if run.image is None]
        if self.log and todo:
            self.log(f"check: {len(todo)} renderer runs, {self.runner.jobs} at a time")
        self.runner.run_all(todo)
        for run in todo:
            run.image = self._read(run)
        for request, runs in pieces.items():
            self._results[request] = self._combine(request, runs)

    def _probe(self, request: Request) -> None:
        """Run the first replica of ``request`` alone: its image says whether the renderer
        writes per-pixel variance (then the replicas are not needed)."""
        first = self._runs_of(request, probe=True)[0]
        self.runner.run_all([first])
        first.image = self._read(first)
        self.has_variance = first.image.variance is not None

    def _runs_of(self, request: Request, probe=False) -> list[Run]:
        if not request.variance or self.has_variance:
            return [self._reuse(request.spp, request.seed, request.max_depth)]
        count = replica_count(request.spp, self.replicas)
        seeds = [REPLICA_SEED_BASE + REPLICA_STRIDE * request.seed + r for r in range(count)]
        return [self._reuse(request.spp // count, seed, request.max_depth)
                for seed in (seeds[:1] if probe else seeds)]

    def _reuse(self, spp, seed, max_depth) -> Run:
        """The run of (spp, seed, max_depth): the one made already (the probe's), else a new one."""
        key = (spp, seed, max_depth)
        if key not in self._runs_by_key:
            self._runs_by_key[key] = self._new_run(spp, seed, max_depth)
        return self._runs_by_key[key]

    def _new_run(self, spp, seed, max_depth) -> Run:
        folder = Path(tempfile.mkdtemp(prefix=f"run-{seed}-", dir=self._workdir))
        out = folder / f"image{self.suffix}"
        out_variance = folder / f"variance{self.suffix}" if self.template.writes_variance else None
        width, height = self.size
        if self.seed_offset:
            seed = (seed * SEED_MULTIPLIER + self.seed_offset * SEED_INCREMENT) % 2 ** 32
        values = {"scene": self.scene_file, "spp": spp, "seed": seed, "out": out,
                  "out_variance": out_variance, "width": width, "height": height,
                  "max_depth": max_depth, "defines": self.defines}
        return Run(spp, seed, max_depth if self.template.takes_max_depth else None,
                   self.template.fill(values), out, out_variance)

    # ---- images ---------------------------------------------------------------------------
    def _read(self, run: Run) -> ExternalImage:
        image = self._read_file(run, run.out)
        if run.out_variance is not None:
            variance = self._read_file(run, run.out_variance)
            image = dataclasses.replace(image, variance=variance.mean)
        faults = image_faults(image)
        if faults:
            raise RendererFault([f"{run.describe()}: {fault}" for fault in faults])
        digest = hashlib.sha256(np.ascontiguousarray(image.mean).tobytes()).hexdigest()
        twin = self._seen.setdefault(digest, run)
        # A constant image (black at max_depth 0, say) has no noise to repeat: it may recur.
        if twin is not run and np.ptp(image.mean) > 0:
            raise RefsInputError(
                f"renderer runs with seeds {twin.seed} and {run.seed} wrote identical images: the "
                f"renderer ignores {{seed}} or its seed does not reach its random numbers; the "
                f"checks need independent renders: {quoted(run.command)}")
        return image

    def _read_file(self, run: Run, path: Path) -> ExternalImage:
        try:
            image = read_image(path)
        except ImageError as error:
            raise RefsInputError(f"{run.describe()}: {error}") from None
        if image.size != self.size:
            raise RefsInputError(f"{run.describe()} wrote a {image.size[0]}x{image.size[1]} image; "
                                 f"the scene's film is {self.size[0]}x{self.size[1]}: "
                                 f"{quoted(run.command)}")
        if image.spp is not None and image.spp != run.spp:
            raise RefsInputError(f"{run.describe()}: its image says spp={image.spp}, the run was asked "
                                 f"for {run.spp}: {quoted(run.command)}")
        return image

    def _combine(self, request: Request, runs: list[Run]):
        images = [run.image for run in runs]
        if not request.variance:
            return images[0].mean, None
        if len(images) == 1:
            return images[0].mean, images[0].variance
        return replica_moments([image.mean for image in images], runs)


def replica_moments(means, runs=None):
    """Mean and per-sample variance of ``K`` independent replica images of ``spp / K`` samples
    each (:func:`mitsuba_refs.stats.replicas.replica_moments`).

    Raises
    ------
    RefsInputError
        When two replicas share most of their noise (they are not independent).
    """
    stack = np.stack([np.asarray(m, dtype=np.float64) for m in means])
    check_independent(stack, runs)
    return stats_replicas.replica_moments(stack, runs[0].spp if runs else 1)


def check_independent(stack: np.ndarray, runs=None) -> None:
    """Refuse replicas (K, H, W, C) of which two correlate above :data:`MAX_SHARED_NOISE`
    (:func:`mitsuba_refs.stats.replicas.shared_noise`)."""
    pair = stats_replicas.shared_noise(stack)
    if pair is None:
        return                                 # too few, or a noiseless image
    k, l, correlation = pair
    if correlation > MAX_SHARED_NOISE:
        which = (f"seeds {runs[k].seed} and {runs[l].seed}" if runs
                 else f"images {k + 1} and {l + 1}")
        raise RefsInputError(f"replicas with {which} are not independent: their noise correlates "
                             f"at {correlation:.2f} (independent ones: near 0); "
                             "each render needs random numbers of its own")
