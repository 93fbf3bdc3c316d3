"""What a course full of students and TAs will type: every bad input or fault of
``pathtracer render`` ends in one line on stderr (no traceback), the documented exit code,
and no partial output; no worker process outlives the render. No Mitsuba needed."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pytest

from pathtracer import load_scene, render
from pathtracer.io.exr import PrecisionWarning
from pathtracer.io.output import OutputError, atomic_path, output_paths, read_exr, write_exr
from pathtracer.render.resources import check_memory
from pathtracer.render.workers import set_parent_death_signal

ROOT = Path(__file__).resolve().parent.parent
#: Small, fast renders: 8x8 pixels, 2 spp, one process.
SMALL = ["-D", "width=8", "-D", "height=8", "--spp", "2", "--processes", "1"]
SCENE = """<scene version="3.0.0">
    <sensor type="perspective">
        <float name="fov" value="40"/>
        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/>
            <rfilter type="box"/></film>
    </sensor>
    <shape type="sphere"><emitter type="area"><rgb name="radiance" value="{radiance}"/></emitter></shape>
</scene>
"""


def cli(*args, cwd, timeout=120):
    """``python -m pathtracer.cli render ARGS`` in ``cwd``, with this checkout first on the path."""
    return subprocess.run([sys.executable, "-m", "pathtracer.cli", "render", *args], cwd=cwd,
                          env=_environment(), capture_output=True, text=True, timeout=timeout)


def _environment():
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))
    return env


def assert_one_line(done, code: int, *needles: str) -> str:
    """Exit ``code``, exactly one line on stderr containing every needle, no traceback."""
    assert done.returncode == code, (done.returncode, done.stderr)
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in done.stderr, done.stderr
    for needle in needles:
        assert needle in lines[0], lines[0]
    return lines[0]


def files_in(directory: Path) -> set[str]:
    """Everything under ``directory`` (relative names), temporary files and folders included."""
    return {str(p.relative_to(directory)) for p in directory.rglob("*")}


# -- bad input: exit 2, one line, nothing written -------------------------------------

#: Bad scene arguments, run as ``python -m pathtracer.cli`` (name: arguments, needles).
BAD_SCENES = {
    "missing scene file": (["nosuch.xml"], ["scene file not found", "nosuch.xml"]),
    "scene is a directory": (["sub/"], ["is a directory"]),
    "empty scene file": (["empty.xml"], ["empty.xml:1", "XML syntax error"]),
    "binary scene file": (["binary.xml"], ["binary.xml:", "XML syntax error"]),
    "scene name typo": (["cornell-bx"], ['no built-in scene "cornell-bx"', "did you mean 'cornell-box'"]),
    "nan radiance": (["nan.xml"], ["nan.xml:7", "radiance", "not a finite number"]),
    "-D malformed value": (["cornell-box", "-D", "width=abc"], ["cornell-box.xml:", "abc"]),
    "film too large for memory": (["cornell-box", "-D", "width=100000", "-D", "height=100000"],
                                  ["100000x100000", "needs about", "TB of memory", "available"]),
    "spp abc": (["cornell-box", "--spp", "abc"], ["--spp", "'abc'"]),
}
#: Bad options, checked through ``main()`` in this process (the same code, without paying
#: an interpreter start for each).
BAD_OPTIONS = {
    "unknown integrator": (["cornell-box", "--integrator", "pathh"], ["--integrator", "pathh"]),
    "spp 0": (["cornell-box", "--spp", "0"], ["--spp", "got 0"]),
    "spp -1": (["cornell-box", "--spp", "-1"], ["--spp", "got -1"]),
    "spp beyond the EXR header": (["cornell-box", "--spp", str(2 ** 31)], ["--spp", str(2 ** 31)]),
    "max-depth abc": (["cornell-box", "--max-depth", "abc"], ["--max-depth", "'abc'"]),
    "max-depth -2": (["cornell-box", "--max-depth", "-2"], ["--max-depth", "-1 (unlimited)"]),
    "negative seed": (["cornell-box", "--seed", "-1"], ["--seed", "got -1"]),
    "seed beyond 32 bits": (["cornell-box", "--seed", str(2 ** 70)], ["--seed", str(2 ** 70)]),
    "processes 0": (["cornell-box", "--processes", "0"], ["--processes"]),
    "exposure nan": (["cornell-box", "--exposure", "nan"], ["--exposure", "finite"]),
    "rr-q inf": (["cornell-box", "--rr-q", "inf"], ["--rr-q", "finite"]),
    "-D without =": (["cornell-box", "-D", "width"], ["name=value"]),
    "-D zero width": (["cornell-box", "-D", "width=0"], ["cornell-box.xml:", "width and height must be positive"]),
    "-D negative spp": (["cornell-box", "-D", "spp=-4"], ["cornell-box.xml:", "sample_count must be positive"]),
    "-D negative seed": (["cornell-box", "-D", "seed=-1"], ["cornell-box.xml:", "seed must lie in"]),
    "-D max_depth -5": (["cornell-box", "-D", "max_depth=-5"], ["cornell-box.xml:", "max_depth must be -1"]),
    "bad path expression": (["cornell-box", "--paths", "L(S"], ["path expression"]),
    "paths with another integrator": (["cornell-box", "--paths", "LDE", "--integrator", "direct"],
                                      ["--paths works with the path, light and bdpt integrators only"]),
    "branches 0": (["cornell-box", "--integrator", "recursive", "--branches", "0"], ["--branches"]),
    "branches with path": (["cornell-box", "--branches", "2"], ["branches"]),
    "rr-q with mitsuba roulette out of range": (["cornell-box", "--rr-q", "1.5"], ["rr_q must lie in [0, 1)"]),
}


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    """A folder with the hostile input files the cases name."""
    folder = tmp_path_factory.mktemp("inputs")
    (folder / "sub").mkdir()
    (folder / "empty.xml").write_text("")
    (folder / "binary.xml").write_bytes(bytes(range(256)) * 4)
    (folder / "nan.xml").write_text(SCENE.format(radiance="nan"))
    return folder


@pytest.mark.parametrize("case", sorted(BAD_SCENES))
def test_bad_scene_gives_one_line_exit_2_and_no_output(inputs, tmp_path, case):
    args, needles = BAD_SCENES[case]
    before = files_in(inputs)
    done = cli(*args, "-o", str(tmp_path / "out" / "img.exr"), cwd=inputs)
    assert_one_line(done, 2, *needles)
    assert files_in(tmp_path) == set() and files_in(inputs) == before


@pytest.mark.parametrize("case", sorted(BAD_OPTIONS))
def test_bad_option_gives_one_line_exit_2_and_no_output(tmp_path, capsys, case):
    from pathtracer.cli import main
    args, needles = BAD_OPTIONS[case]
    try:
        code = main(["render", *args, "-o", str(tmp_path / "out" / "img.exr")])
    except SystemExit as stop:      # argparse's own errors
        code = stop.code
    captured = capsys.readouterr()
    assert_one_line(subprocess.CompletedProcess([], code, captured.out, captured.err), 2, *needles)
    assert files_in(tmp_path) == set()


def test_missing_output_option_is_a_usage_error(inputs):
    assert_one_line(cli("cornell-box", cwd=inputs), 2, "-o/--output")


# -- outputs: checked before rendering, never partial -------------------------------

def test_output_problems_are_refused_before_rendering(tmp_path):
    (tmp_path / "taken.exr").mkdir()
    (tmp_path / "afile").write_text("x")
    cases = [
        (tmp_path / "out" / "img.png", "must end in .exr"),
        (tmp_path / "out" / "img", "must end in .exr"),
        (tmp_path / "taken.exr", "is a directory"),
        (tmp_path / "afile" / "img.exr", "is a file, not a directory"),
        # an existing directory where nobody, root included, can create a file
        (Path("/proc/self/img.exr"), "cannot write"),
    ]
    for output, needle in cases:
        with pytest.raises(OutputError, match=needle):
            output_paths(output)
    assert files_in(tmp_path) == {"afile", "taken.exr"}
    # The same through the command line: refused in well under a render's time.
    done = cli("cornell-box", "-o", str(tmp_path / "afile" / "img.exr"), cwd=tmp_path)
    assert_one_line(done, 2, "is a file, not a directory")


def test_png_output_is_refused_not_written_over_itself(tmp_path):
    done = cli("cornell-box", *SMALL, "-o", str(tmp_path / "out" / "img.png"), cwd=tmp_path)
    assert_one_line(done, 2, "must end in .exr", "img.exr")
    assert files_in(tmp_path) == set()


def test_atomic_path_leaves_the_old_file_or_the_new_one_never_a_partial_one(tmp_path):
    target = tmp_path / "img.exr"
    target.write_text("old")
    with pytest.raises(KeyboardInterrupt):
        with atomic_path(target) as temporary:
            temporary.write_text("half")
            raise KeyboardInterrupt
    assert files_in(tmp_path) == {"img.exr"} and target.read_text() == "old"
    with atomic_path(target) as temporary:
        assert temporary.parent == tmp_path and temporary.name.startswith(".img.exr.")
        temporary.write_text("new")
    assert files_in(tmp_path) == {"img.exr"} and target.read_text() == "new"


def test_huge_radiance_and_an_unused_define_give_warning_lines_and_a_finite_exr(tmp_path):
    """1e30 radiance: the variance (~1e58) overflows float32; it is clamped and said so.
    ``-D`` of a ``<default>`` nothing uses is one clean warning line, not a Python
    UserWarning; a ``-D`` the file does not declare at all (a typo) is an error."""
    from pathtracer.scene.load import builtin_scene_path
    scene = tmp_path / "quad.xml"
    text = Path(builtin_scene_path("quad-light")).read_text()
    scene.write_text(text.replace("<default ", '<default name="unused_knob" value="1"/>\n    <default ', 1))
    out = tmp_path / "quad.exr"
    done = cli(str(scene), "-D", "radiance=1e30", "-D", "unused_knob=4", *SMALL, "-o", str(out),
               cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    lines = done.stderr.strip().splitlines()
    assert "Traceback" not in done.stderr and "UserWarning" not in done.stderr
    assert len(lines) == 2 and all(line.startswith("pathtracer: warning: ") for line in lines)
    assert "parameters not used by the scene: unused_knob" in lines[0]
    assert "variance values exceed the EXR's float32 range" in lines[1]
    result = read_exr(out)
    assert np.all(np.isfinite(result.mean)) and np.all(np.isfinite(result.variance))
    assert result.mean.max() > 1e28 and result.variance.max() == np.finfo(np.float32).max
    assert files_in(tmp_path) == {"quad.xml", "quad.exr", "quad.png"}
    typo = cli(str(scene), "-D", "widht=4", *SMALL, "-o", str(tmp_path / "typo.exr"), cwd=tmp_path)
    assert typo.returncode == 2 and "Traceback" not in typo.stderr
    assert typo.stderr.count("\n") == 1 and "widht not declared by the file" in typo.stderr
    assert files_in(tmp_path) == {"quad.xml", "quad.exr", "quad.png"}


def test_write_exr_records_clamped_values_and_seeds_beyond_int32(tmp_path):
    scene = load_scene("quad-light", width=4, height=4, radiance=1e30)
    result = render(scene, spp=2, seed=2 ** 32 - 1, processes=1)
    with pytest.warns(PrecisionWarning, match="clamped_variance"):
        write_exr(tmp_path / "q.exr", result)
    import OpenEXR
    with OpenEXR.File(str(tmp_path / "q.exr")) as exr:
        header = dict(exr.header())
    assert header["clamped_variance"] > 0 and "clamped_mean" not in header
    assert read_exr(tmp_path / "q.exr").seed == 2 ** 32 - 1    # an EXR int would wrap to -1


def test_memory_check_names_what_is_needed():
    check_memory(64, 64, 2, 1 << 15, available=10 ** 9)
    with pytest.raises(ValueError, match=r"a 4000x4000 image needs about 3\.0 GB .* 1\.0 GB"):
        check_memory(4000, 4000, 2, 1 << 15, available=10 ** 9)


# -- interrupts and process hygiene ---------------------------------------------------

def _group_members(pgid: int) -> list[int]:
    """Live (not zombie) processes of process group ``pgid``, from /proc."""
    members = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            stat = Path(f"/proc/{entry}/stat").read_text()
        except OSError:
            continue
        state, _, group = stat[stat.rindex(")") + 2:].split()[:3]
        if int(group) == pgid and state != "Z":
            members.append(int(entry))
    return members


def restore_sigint():
    """In the child before exec: SIGINT back to its default. A process that starts with SIGINT
    ignored (pytest-xdist's workers ignore it, and children inherit that) keeps ignoring it,
    and Ctrl-C would never reach the command under test."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _start_render(tmp_path: Path):
    """A 2-process render that runs for many seconds, in its own process group; returns it
    once both workers are running."""
    process = subprocess.Popen(
        [sys.executable, "-m", "pathtracer.cli", "render", "cornell-box", "-D", "width=64",
         "-D", "height=64", "--spp", "1024", "--processes", "2", "-o", str(tmp_path / "out.exr")],
        cwd=tmp_path, env=_environment(), start_new_session=True,
        preexec_fn=restore_sigint, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while len(_group_members(process.pid)) < 3:
        assert process.poll() is None, process.communicate()
        assert time.monotonic() < deadline, "the workers never started"
        time.sleep(0.05)
    return process


def _assert_no_survivor(pgid: int, seconds: float = 5.0) -> None:
    deadline = time.monotonic() + seconds
    while _group_members(pgid):
        if time.monotonic() > deadline:
            survivors = _group_members(pgid)
            for pid in survivors:   # do not leave them behind for the next test
                os.kill(pid, signal.SIGKILL)
            pytest.fail(f"worker processes {survivors} outlived the render")
        time.sleep(0.05)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
@pytest.mark.parametrize("how", ["SIGTERM", "SIGKILL", "Ctrl-C", "a worker killed"])
def test_killing_the_render_leaves_no_worker_and_no_output(tmp_path, how):
    previous = tmp_path / "out.exr"
    previous.write_text("an older render")          # must survive an interrupted one intact
    process = _start_render(tmp_path)
    started = time.monotonic()
    if how == "Ctrl-C":      # a terminal sends SIGINT to the whole foreground group
        os.killpg(process.pid, signal.SIGINT)
    elif how == "a worker killed":     # as the out-of-memory killer would
        os.kill(max(set(_group_members(process.pid)) - {process.pid}), signal.SIGKILL)
    else:
        process.send_signal(getattr(signal, how))
    _, stderr = process.communicate(timeout=30)
    _assert_no_survivor(process.pid)
    assert time.monotonic() - started < 10
    expected = {"SIGTERM": (143, "terminated"), "SIGKILL": (-9, None), "Ctrl-C": (130, "interrupted"),
                "a worker killed": (1, "a worker process died")}
    code, word = expected[how]
    assert process.returncode == code, stderr
    if word:
        lines = stderr.strip().splitlines()
        assert len(lines) == 1 and word in lines[0] and "Traceback" not in stderr, stderr
    assert files_in(tmp_path) == {"out.exr"} and previous.read_text() == "an older render"


class _SlowJob:
    """A job of worker processes: each group takes a while, so most are still pending."""

    def run(self, group):
        time.sleep(0.05)
        return [None] * len(group)


@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs fork")
def test_an_interrupted_render_cancels_no_future_from_its_own_thread(monkeypatch):
    """The cause of a SIGTERM traceback seen once in CI: pool.map cancels its pending futures
    from the interrupted thread, and the pool's manager thread, seeing its workers killed,
    then fails those cancelled futures (InvalidStateError). Interrupt at the first block,
    deterministically: no future is cancelled from this thread, and every future ends
    settled by the pool (done, cancelled or failed as broken) with no worker left."""
    import concurrent.futures
    import threading

    from pathtracer.render.scheduling import run_units
    cancelling_threads, futures, workers = [], [], set()
    cancel, submit = concurrent.futures.Future.cancel, concurrent.futures.ProcessPoolExecutor.submit

    def recording_cancel(future):
        cancelling_threads.append(threading.current_thread())
        return cancel(future)

    def recording_submit(pool, *args, **kwargs):
        futures.append(submit(pool, *args, **kwargs))
        workers.update(pool._processes or {})     # the forked workers' process ids
        return futures[-1]

    def interrupt(stats, unit, block):
        raise KeyboardInterrupt

    monkeypatch.setattr(concurrent.futures.Future, "cancel", recording_cancel)
    monkeypatch.setattr(concurrent.futures.ProcessPoolExecutor, "submit", recording_submit)
    groups = [((i, i + 1, 0, 1),) for i in range(40)]
    with pytest.raises(KeyboardInterrupt):
        run_units(_SlowJob(), groups, None, processes=2, progress=False, merge=interrupt)
    assert len(futures) == 40 and all(future.done() for future in futures)
    assert threading.main_thread() not in cancelling_threads
    assert len(workers) == 2
    assert not [pid for pid in workers if Path(f"/proc/{pid}").exists() and "Z" not in _state(pid)]


WATCHDOG_CHILD = """
import os, sys, time
from pathtracer.render.workers import start_parent_watchdog
parent = os.getpid()
pid = os.fork()
if pid == 0:
    start_parent_watchdog(parent, period=0.05)
    time.sleep(60)
    os._exit(0)
print(pid, flush=True)
os._exit(0)      # the parent dies at once; its child must follow
"""


@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs fork")
def test_parent_watchdog_ends_an_orphaned_worker(tmp_path):
    """The fallback where prctl is unavailable: the child notices its parent is gone."""
    done = subprocess.run([sys.executable, "-c", WATCHDOG_CHILD], env=_environment(),
                          capture_output=True, text=True, timeout=60)
    child = int(done.stdout.split()[0])
    deadline = time.monotonic() + 5
    while Path(f"/proc/{child}").exists() and "Z" not in _state(child):
        if time.monotonic() > deadline:
            os.kill(child, signal.SIGKILL)
            pytest.fail("the orphaned child kept running")
        time.sleep(0.05)


def _state(pid: int) -> str:
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return "Z"
    return stat[stat.rindex(")") + 2:].split()[0]


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="prctl is Linux's")
def test_parent_death_signal_is_accepted_on_linux():
    # In this test process it is reset right away: pytest's parent must not kill it.
    assert set_parent_death_signal(0)


def test_warnings_filters_are_restored_after_a_cli_call(tmp_path):
    """The CLI shows warnings as one line only inside its own call."""
    from pathtracer.cli import main
    before = warnings.showwarning
    assert main(["render", "cornell-box", *SMALL, "-o", str(tmp_path / "a.exr")]) == 0
    assert warnings.showwarning is before


@pytest.mark.parametrize("command", ["pathtracer", "mitsuba-refs"])
def test_interrupt_while_the_command_imports_is_one_line(command, tmp_path):
    """Ctrl-C before ``main`` runs (NumPy, SciPy still importing): one line, no traceback,
    and the process ends by SIGINT (status 130 in a shell)."""
    code = (f"import sys; sys.argv[0] = {('/usr/bin/' + command)!r}\n"
            "import pathtracer._console\n"
            "raise KeyboardInterrupt")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          cwd=tmp_path, timeout=60)
    assert done.stderr == f"{command}: interrupted\n"
    assert done.returncode == -signal.SIGINT
