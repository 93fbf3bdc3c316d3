"""The progress helper (pathtracer.core.progress) with a fake clock and fake streams, and the
plain Mitsuba log: a bar with the time left on a terminal, plain lines in a pipe, never an
escape code in a pipe, NO_COLOR honoured. No waiting, no Mitsuba needed."""
from __future__ import annotations

import io
import os
import subprocess
import sys
from pathlib import Path

import pytest

from mitsuba_refs.reference.mitsuba_log import plain
from mitsuba_refs.reference.render import faster_route
from pathtracer.core.progress import PIPE_INTERVAL, Progress, colour_allowed, duration, is_terminal

ROOT = Path(__file__).resolve().parent.parent


class Clock:
    def __init__(self):
        self.now = 100.0

    def __call__(self):
        return self.now


class Terminal(io.StringIO):
    def isatty(self):
        return True


def test_a_pipe_gets_plain_lines_with_the_time_left_and_no_escape_codes():
    clock, out = Clock(), io.StringIO()
    progress = Progress(100, "reference cornell-box path", "spp", stream=out, clock=clock)
    for _ in range(10):
        clock.now += PIPE_INTERVAL / 2
        progress.advance(10)
    progress.close()
    lines = out.getvalue().splitlines()
    assert lines[0] == "reference cornell-box path: 20/100 spp (20%), 10 s elapsed, about 40 s left"
    assert lines[-1] == "reference cornell-box path: 100/100 spp done in 50 s"
    assert len(lines) == 5
    assert "\x1b" not in out.getvalue() and "\r" not in out.getvalue()


def test_short_work_in_a_pipe_prints_nothing():
    clock, out = Clock(), io.StringIO()
    with Progress(5, "rendering", stream=out, clock=clock) as progress:
        for _ in range(5):
            clock.now += 1
            progress.advance()
    assert out.getvalue() == ""


def test_a_terminal_gets_one_line_redrawn_with_a_bar_and_the_time_left():
    clock, out = Clock(), Terminal()
    progress = Progress(4, "check: renderer runs", "runs", stream=out, clock=clock)
    for _ in range(4):
        clock.now += 30
        progress.advance()
    progress.close()
    text = out.getvalue()
    assert text.count("\n") == 1 and text.endswith("\n")
    assert "\r" in text and "\x1b" not in text
    draws = text.strip("\n").split("\r")[1:]
    assert draws[0].startswith("check: renderer runs [######------------------] 1/4 runs, "
                               "30 s elapsed, about 1 min 30 s left")
    assert "4/4 runs, done in 2 min 00 s" in draws[-1]


def test_long_work_says_its_estimate_and_the_faster_route_once():
    clock, out = Clock(), io.StringIO()
    progress = Progress(3072, "reference cornell-box path_nee", "spp", stream=out, clock=clock,
                        estimate_after=30, faster="the llvm_ad_rgb variant")
    clock.now += 20
    progress.advance(256)
    clock.now += 20
    progress.advance(256)
    first = out.getvalue().splitlines()[0]
    assert first == ("reference cornell-box path_nee: about 4 min 00 s in all at this pace; "
                     "faster: the llvm_ad_rgb variant")
    assert out.getvalue().count("in all at this pace") == 1


def test_quick_work_gives_no_estimate():
    clock, out = Clock(), io.StringIO()
    progress = Progress(10, "x", stream=out, clock=clock, estimate_after=30, faster="y")
    clock.now += 1
    progress.advance()
    assert out.getvalue() == ""


def test_no_color_and_pipes_refuse_colour(monkeypatch):
    monkeypatch.delenv("NO_COLOR", raising=False)
    monkeypatch.setenv("TERM", "xterm")
    assert colour_allowed(Terminal()) and not colour_allowed(io.StringIO())
    monkeypatch.setenv("NO_COLOR", "1")
    assert not colour_allowed(Terminal()) and is_terminal(Terminal())
    monkeypatch.setenv("TERM", "dumb")
    assert not is_terminal(Terminal())


def test_durations_read_as_a_person_says_them():
    assert [duration(s) for s in (8, 65, 3725)] == ["8 s", "1 min 05 s", "1 h 02 min"]


def test_mitsuba_log_lines_are_plain_and_the_python_integrator_warning_is_ours():
    warning = ("2026-12-05 04:29:59 WARN  [integrator_v.cpp:66] SamplingIntegrator Python "
               "implementations will have terrible performance in scalar_* modes.")
    assert plain(warning) is None
    assert plain("\x1b[31mWARN  [x.cpp:1] something\x1b[0m\n") == "mitsuba: WARN  [x.cpp:1] something"


def test_the_faster_route_names_llvm_only_for_scalar_variants():
    scalar = faster_route("scalar_rgb", "batch", "lecture_path_nee")
    assert "llvm_ad_rgb" in scalar and "Python integrator" in scalar and "--resolution" in scalar
    assert "llvm_ad_rgb" not in faster_route("llvm_ad_rgb", "moments", "path")


def test_checks_runs_tell_the_progress_each_run_done(tmp_path):
    from mitsuba_refs.external.runner import Run, Runner

    class Counting:
        done = 0

        def advance(self, n=1):
            self.done += n

    runs = [Run(1, i, None, f"touch {tmp_path}/{i}.exr", tmp_path / f"{i}.exr") for i in range(5)]
    counting = Counting()
    Runner(2, 30.0, cwd=tmp_path).run_all(runs, counting)
    assert counting.done == 5


def test_the_convergence_progress_counts_every_ladder_render():
    from mitsuba_refs.settings import Settings
    from mitsuba_refs.verdicts.compare import ladder_progress
    from mitsuba_refs.verdicts.convergence import level_replicas
    settings = Settings(ladder=(1, 4, 16), replicas=2)
    progress = ladder_progress(settings)
    assert progress.total == sum(level_replicas((1, 4, 16), 2)) and "1,4,16" in progress.label


@pytest.mark.mitsuba
def test_a_scalar_build_of_a_python_integrator_says_no_mitsuba_warning_and_no_colour(tmp_path):
    """Mitsuba's own warning about Python integrators in scalar variants (in red, even in a
    pipe) is not in our output; the build says its own lines, plain."""
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MITSUBA_REFS_VARIANT": "scalar_rgb"}
    env.pop("NO_COLOR", None)
    done = subprocess.run([sys.executable, "-m", "mitsuba_refs", "build", "cornell-box",
                           "--integrators", "path_nee", "--resolution", "8x8", "--spp", "4",
                           "--no-per-bounce", "--cache-dir", str(tmp_path)],
                          env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert "terrible performance" not in done.stderr and "\x1b" not in done.stderr + done.stdout
    assert "built" in done.stdout
