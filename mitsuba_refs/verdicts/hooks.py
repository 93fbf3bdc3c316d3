"""Wrappers of the ``render=`` hook of :func:`mitsuba_refs.verdicts.compare.compare`.

A hook is ``render(scene, integrator, params, spp, seed, processes=..., max_depth=...)``
returning ``(mean, variance)``; it may also have ``render_mean(...)`` returning the mean alone
(an external renderer then skips its replicas: :mod:`mitsuba_refs.external.renders`). Every
wrapper here keeps ``render_mean`` when the hook has one.
"""
from __future__ import annotations

import time


class WithOptions:
    """``render`` (and its ``render_mean``, if it has one) called with ``options`` added."""

    def __init__(self, render, options):
        self.render, self.options = render, dict(options)
        if hasattr(render, "render_mean"):
            self.render_mean = lambda *args, **kwargs: render.render_mean(
                *args, **{**self.options, **kwargs})

    def __call__(self, *args, **kwargs):
        return self.render(*args, **{**self.options, **kwargs})


def mean_of(render):
    """A ``render_mean`` for a hook that only gives (mean, variance)."""
    def render_mean(*args, **kwargs):
        return render(*args, **kwargs)[0]
    return render_mean


class RecordingRuns:
    """``render`` that appends one dict per call to ``runs``: ``purpose``, seed, spp, seconds,
    and max_depth where the call sets one (the per-bounce renders); its ``render_mean`` too,
    when ``render`` has one."""

    def __init__(self, render, runs: list, purpose: str, progress=None):
        self.render, self.runs, self.purpose = render, runs, purpose
        self.progress = progress    # a pathtracer.core.progress.Progress told each render done
        if hasattr(render, "render_mean"):
            self.render_mean = lambda *args, **kwargs: self._timed(render.render_mean, *args,
                                                                   **kwargs)

    def __call__(self, *args, **kwargs):
        return self._timed(self.render, *args, **kwargs)

    def _timed(self, render, scene, integrator, params, spp, seed, **kwargs):
        start = time.perf_counter()
        images = render(scene, integrator, params, spp, seed, **kwargs)
        run = {"purpose": self.purpose, "seed": int(seed), "spp": int(spp),
               "seconds": time.perf_counter() - start}
        if kwargs.get("max_depth") is not None:
            run["max_depth"] = int(kwargs["max_depth"])
        self.runs.append(run)
        if self.progress is not None:
            self.progress.advance()
        return images
