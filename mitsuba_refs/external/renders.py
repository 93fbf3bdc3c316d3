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
Every run gets a seed of :mod:`.seeding`'s rule, far enough from every other that no known
scheme of deriving random streams from a seed makes two runs share one. Every image is checked
before it is used: its size is the film's, a sample count in its header is the one asked for,
no two runs gave the same non-constant image (a renderer that ignores ``{seed}``), and replicas
do not share their noise at the same pixel or at a pixel offset (streams replayed shifted).
Non-finite or negative radiance is not bad input but a wrong renderer: :class:`RendererFault`,
which the check reports as a disagreement.
"""
from __future__ import annotations

import dataclasses
import hashlib
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.stats import norm

from pathtracer.core.progress import Progress
from pathtracer.render.splats import replica_count

from ..errors import RefsInputError
from ..stats import replicas as stats_replicas
from .images import ExternalImage, ImageError, image_faults, read_image
from .runner import Run, Runner, quoted
from .seeding import SeedRule, SeedSpaceError, seed_rule

#: Replicas of a mean-and-variance request when the renderer writes no variance.
DEFAULT_REPLICAS = 8
#: Two replicas share their noise when the significance ``z`` of their most correlated pixel
#: offset (:func:`mitsuba_refs.stats.replicas.offset_shared_noise`, about a standard normal for
#: independent ones) exceeds the largest of its ``tests`` standard normals with probability
#: FALSE_REFUSAL (Bonferroni; calibration in docs/external.md) ...
FALSE_REFUSAL = 1e-6
#: ... and their correlation exceeds this (a tiny correlation is harmless on a large film).
MIN_SHARED_CORRELATION = 0.1
#: What a renderer whose runs share noise at the harness's seeds should change.
RUN_STREAMS_ADVICE = ("the harness's seeds are far enough apart for streams seeded from {seed} plus "
                      "a pixel or sample index, or {seed} times the pixel count: derive the "
                      "renderer's random streams from a hash of {seed} and the pixel")
#: The largest sample count a run of a check is assumed to take when nothing larger is known.
DEFAULT_MAX_SPP = 4096
#: The runs a check is assumed to make when nothing else is known.
DEFAULT_RUNS = 4096


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
    log : callable, optional
        Called with progress lines.
    seeds : SeedRule, optional
        The seeds of the runs, one slot per run in the order they are made, in the range of
        its ``offset`` (repeated checks: fresh randomness for each). Default: the rule of the
        film for :data:`DEFAULT_RUNS` runs of up to :data:`DEFAULT_MAX_SPP` spp, offset 0.
    """

    def __init__(self, template, runner: Runner, scene_file, size, defines=None, max_depth=-1,
                 replicas=DEFAULT_REPLICAS, suffix=".exr", log=None,
                 seeds: SeedRule | None = None):
        self.template, self.runner = template, runner
        self.scene_file, self.size = Path(scene_file), tuple(size)
        self.defines, self.max_depth = dict(defines or {}), max_depth
        self.replicas, self.suffix, self.log = int(replicas), suffix, log
        self.seeds = seeds or seed_rule(*self.size, DEFAULT_MAX_SPP, DEFAULT_RUNS, fit=True)
        #: None until the probe says whether the renderer writes per-pixel variance.
        self.has_variance = True if template.writes_variance else None
        self._results: dict = {}           # Request -> (mean, variance or None)
        self._plans: list[list[Request]] = []
        self._extend = None
        self._seen: dict = {}              # sha256 of an image -> the run that made it
        self._runs_by_key: dict = {}       # (spp, request seed, replica, depth) -> its Run
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
        progress = None
        if self.log and todo:
            self.log(f"check: {len(todo)} renderer runs, {self.runner.jobs} at a time")
            progress = Progress(len(todo), "check: renderer runs", "runs")
        self.runner.run_all(todo, progress)
        if progress is not None:
            progress.close()
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
            return [self._reuse(request.spp, request.seed, None, request.max_depth)]
        count = replica_count(request.spp, self.replicas)
        return [self._reuse(request.spp // count, request.seed, r, request.max_depth)
                for r in range(1 if probe else count)]

    def _reuse(self, spp, request_seed, replica, max_depth) -> Run:
        """The run of replica ``replica`` (None: the only run) of the request ``(spp,
        request_seed, max_depth)``: the one made already (the probe's), else a new one."""
        key = (spp, request_seed, replica, max_depth)
        if key not in self._runs_by_key:
            self._runs_by_key[key] = self._new_run(spp, max_depth, request_seed)
        return self._runs_by_key[key]

    def _new_run(self, spp, max_depth, request_seed) -> Run:
        """A run with the next seed of the check's rule (the comparison's own seeds only name
        the renders it asks for: the renderer gets seeds no stream scheme can overlap)."""
        try:
            seed = self.seeds.seed(len(self._runs_by_key))
        except SeedSpaceError as error:
            raise RefsInputError(f"check: {error}; a {self.size[0]}x{self.size[1]} film leaves no "
                                 "room for more runs with disjoint random streams (fewer "
                                 "--replicas, or a smaller --resolution)") from None
        folder = Path(tempfile.mkdtemp(prefix=f"run-{seed}-", dir=self._workdir))
        out = folder / f"image{self.suffix}"
        out_variance = folder / f"variance{self.suffix}" if self.template.writes_variance else None
        width, height = self.size
        values = {"scene": self.scene_file, "spp": spp, "seed": seed, "out": out,
                  "out_variance": out_variance, "width": width, "height": height,
                  "max_depth": max_depth, "defines": self.defines}
        return Run(spp, seed, max_depth if self.template.takes_max_depth else None,
                   self.template.fill(values), out, out_variance, request_seed)

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
                                 f"the scene's film is {self.size[0]}x{self.size[1]} (what {{width}} "
                                 f"{{height}} told it; --resolution WxH sets both sides): "
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


def replica_moments(means, runs=None, check=True):
    """Mean and per-sample variance of ``K`` independent replica images of ``spp / K`` samples
    each (:func:`mitsuba_refs.stats.replicas.replica_moments`); ``check`` False: their
    independence was checked already.

    Raises
    ------
    RefsInputError
        When two replicas share their noise (they are not independent).
    """
    stack = np.stack([np.asarray(m, dtype=np.float64) for m in means])
    if check:
        check_independent(stack, runs, advice=RUN_STREAMS_ADVICE if runs else None)
    return stats_replicas.replica_moments(stack, runs[0].spp if runs else 1)


def check_independent(stack: np.ndarray, runs=None, names=None, advice=None) -> None:
    """Refuse replicas (K, H, W, C) of which two share their noise at the same pixel or at a
    pixel offset (:func:`mitsuba_refs.stats.replicas.offset_shared_noise`, thresholds
    :data:`MIN_SHARED_CORRELATION` and :func:`shared_noise_limit`).

    Parameters
    ----------
    runs : list of Run, optional
        The runs that made the replicas (the message names their seeds).
    names : list of str, optional
        Otherwise the images' names (default "images 1, 2, ...").
    advice : str, optional
        What to do instead (default: give each render random numbers of its own).
    """
    found = stats_replicas.offset_shared_noise(stack)
    if not shares_noise(found):
        return
    k, l = found.first, found.second
    if runs:
        which = f"replicas with seeds {runs[k].seed} and {runs[l].seed}"
    elif names:
        which = f"{names[k]} and {names[l]}"
    else:
        which = f"replicas with images {k + 1} and {l + 1}"
    where = ("at the same pixel" if (found.dx, found.dy) == (0, 0)
             else f"at pixel offset (dx, dy) = ({found.dx}, {found.dy})")
    raise RefsInputError(
        f"{which} are not independent: their noise correlates at {found.correlation:.2f} "
        f"{where} over {found.pixels} pixels (independent ones: near 0); "
        + (advice or "each render needs random numbers of its own"))


def shares_noise(found) -> bool:
    """Whether an :func:`~mitsuba_refs.stats.replicas.offset_shared_noise` result is shared
    noise by the thresholds."""
    return (found is not None and found.correlation > MIN_SHARED_CORRELATION
            and found.z > shared_noise_limit(found.tests))


def shared_noise_limit(tests: int) -> float:
    """The ``z`` above which shared noise is refused, for ``tests`` (pair, offset) compared."""
    return float(norm.isf(FALSE_REFUSAL / max(1, tests)))
