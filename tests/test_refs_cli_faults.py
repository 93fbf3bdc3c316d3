"""Faults a course's students and TAs meet with ``mitsuba-refs compare`` and ``build``.

Each case asserts the exit status (2: bad input or usage, 130: interrupted; 1 means
"disagrees" and must never signal an error), one error line without a traceback, and that
nothing was left in the reference cache or the ``--out`` folder. The cases in
:data:`SUBPROCESS_CASES` run the real entry point, ``python -m mitsuba_refs.cli.main``, as
subprocesses started together by one module fixture; those in :data:`IN_PROCESS_CASES` call
:func:`mitsuba_refs.cli.main.main` (what the entry point runs) in this process, to share the
interpreter's start-up and imports. Cases marked ``mitsuba`` need a live Mitsuba 3 (it has
to load or render the file; tests/conftest.py skips them without it); the others pass
without it.
"""
import json
import multiprocessing
import os
import re
import shutil
import signal
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

from mitsuba_refs.cli.main import main
from mitsuba_refs.errors import RefsInputError, mitsuba_error_line
from mitsuba_refs.reference import cache
from mitsuba_refs.reference.cache import LOCK_NAME, check_finite, store, validate
from mitsuba_refs.reference.render import Reference
from tests.test_cli_faults import restore_sigint

REPO = Path(__file__).resolve().parent.parent
QUAD_LIGHT = REPO / "pathtracer" / "data" / "scenes" / "quad-light.xml"
COMMITTED = REPO / "mitsuba_refs" / "references"

def write_scenes(folder: Path) -> None:
    """Broken variants of quad-light.xml, as students write them."""
    text = QUAD_LIGHT.read_text()
    film_start = text.index('<film type="hdrfilm">')
    film_end = text.index("</film>") + len("</film>")
    film = text[film_start:film_end]
    plane_bsdf = '<bsdf type="diffuse">\n            <float name="reflectance" value="$albedo"/>'
    assert plane_bsdf in text
    variants = {
        "ok.xml": text,
        "notwf.xml": text.replace("</scene>", ""),
        "unknownplugin.xml": text.replace(plane_bsdf, plane_bsdf.replace("diffuse", "nosuchbsdf")),
        "missingmesh.xml": text.replace(
            '<shape type="rectangle" id="plane">',
            '<shape type="ply"><string name="filename" value="missing.ply"/></shape>\n'
            '    <shape type="rectangle" id="plane">'),
        "envmap.xml": text.replace(
            "</scene>", '<emitter type="envmap"><string name="filename" value="sky.exr"/>'
                        "</emitter>\n</scene>"),
        "huge.xml": text.replace('<default name="radiance" value="10"/>',
                                 '<default name="radiance" value="1e30"/>'),
        "gauss.xml": text.replace('<rfilter type="box"/>', '<rfilter type="gaussian"/>'),
        "lanczos.xml": text.replace('<rfilter type="box"/>', '<rfilter type="lanczos"/>'),
        "film.xml": f'<scene version="3.0.0">\n{film}\n</scene>\n',
        "incfilm.xml": text[:film_start] + '<include filename="film.xml"/>' + text[film_end:],
        "film_gauss.xml": f'<scene version="3.0.0">\n{film}\n</scene>\n'.replace(
            '<rfilter type="box"/>', '<rfilter type="gaussian"/>'),
        "incgauss.xml": text[:film_start] + '<include filename="film_gauss.xml"/>'
                        + text[film_end:],
        "film_lanczos.xml": f'<scene version="3.0.0">\n{film}\n</scene>\n'.replace(
            '<rfilter type="box"/>', '<rfilter type="lanczos"/>'),
        "inclanczos.xml": text[:film_start] + '<include filename="film_lanczos.xml"/>'
                          + text[film_end:],
    }
    for name, content in variants.items():
        (folder / name).write_text(content)
    (folder / "notes.txt").write_text("not a scene\n")
    (folder / "a-file").write_text("a file where a cache folder is expected\n")


def leftovers(folder: Path) -> list:
    """Files under ``folder`` (the cache's lock file excepted)."""
    if not folder.exists():
        return []
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*")
                  if p.is_file() and p.name != LOCK_NAME)


SMALL = ["-D", "width=32", "-D", "height=16"]
TINY_BUILD = ["-D", "width=8", "-D", "height=8", "--spp", "4", "--integrators", "path",
              "--no-per-bounce", "--variant", "scalar_rgb"]

#: name -> (arguments, exit status, texts the error line must contain, needs Mitsuba).
#: These run as subprocesses of the real entry point, all at once (module fixture).
SUBPROCESS_CASES = {
    "compare-not-well-formed": (["compare", "notwf.xml"], 2, ["notwf.xml:76", "XML syntax"], False),
    "compare-no-such-scene": (["compare", "nosuch.xml.xml"], 2,
                              ["nosuch.xml.xml", "no such file"], False),
    "compare-spp-1": (["compare", "quad-light", "--spp", "1"], 2, ["--spp must be >= 2"], False),
    # 40x48: no committed reference (read first), so it has to be rendered into the cache.
    "compare-cache-under-a-file": (["compare", "quad-light", "--no-convergence", "-D",
                                    "width=40"], 2,
                                   ["a-file", "MITSUBA_REFS_CACHE", "writable"], False),
    "build-not-well-formed": (["build", "notwf.xml"], 2, ["notwf.xml:76:1", "not well-formed"],
                              False),
    "build-missing-envmap": (["build", "envmap.xml"], 2, ["envmap.xml", "sky.exr"], False),
}
#: The same through :func:`mitsuba_refs.cli.main.main` in this process (which the entry point
#: calls): the scene work is the same, the interpreter and its imports are shared.
IN_PROCESS_CASES = {
    # compare: the tracer loads the scene first and its message is the one shown
    "compare-unknown-plugin": (["compare", "unknownplugin.xml"], 2,
                               ["unknownplugin.xml:58", "nosuchbsdf"], False),
    "compare-missing-mesh": (["compare", "missingmesh.xml"], 2,
                             ["missingmesh.xml:", "missing.ply"], False),
    "compare-undeclared-D": (["compare", "quad-light", "-D", "nosuch=1"], 2,
                             ["nosuch not declared", "quad-light.xml"], False),
    "compare-unknown-integrator": (["compare", "quad-light", "--integrator", "pathh"], 2,
                                   ["--integrator", "pathh", "path_nee"], False),
    "compare-image-too-small": (["compare", "quad-light", "-D", "width=4", "-D", "height=4"], 2,
                                ["4x4", "at least 32x16"], False),
    "compare-lanczos-film-in-include": (["compare", "inclanczos.xml"], 2,
                                        ["film_lanczos.xml:", "lanczos", "box, tent, gaussian"],
                                        False),
    "compare-bad-D-value": (["compare", "quad-light", "-D", "width=abc"], 2,
                            ["quad-light.xml:", "abc"], False),
    "compare-text-file": (["compare", "notes.txt"], 2, ["notes.txt", ".xml"], False),
    "build-unknown-integrator": (["build", "quad-light", "--integrators", "path", "nee"], 2,
                                 ["--integrators", "'nee'"], False),
    "build-undeclared-D": (["build", "quad-light", "-D", "albedoo=0.5"], 2,
                           ["albedoo not declared", "quad-light.xml"], False),
    "build-missing-mesh": (["build", "missingmesh.xml"], 2, ["missingmesh.xml", "missing.ply"],
                           False),
    "build-no-such-scene": (["build", "nosuch.xml.xml"], 2, ["nosuch.xml.xml"], False),
    "build-lanczos-filter": (["build", "lanczos.xml"], 2,
                             ["lanczos.xml", "lanczos", "box, tent, gaussian"], False),
    "build-spp-1": (["build", "quad-light", "--spp", "1"], 2, ["--spp must be >= 2"], False),
    # Mitsuba's own refusals, translated
    "build-mitsuba-unknown-plugin": (["build", "unknownplugin.xml", *TINY_BUILD], 2,
                                     ["unknownplugin.xml:58:", "nosuchbsdf"], True),
    "build-huge-radiance": (["build", "huge.xml", *TINY_BUILD], 2,
                            ["huge.xml", "overflows", "scale the emitters"], True),
    "build-unknown-variant": (["build", "quad-light", "--variant", "nosuch_rgb"], 2,
                              ["'nosuch_rgb'", "not available"], True),
}
#: concurrent builders of one reference (needs Mitsuba)
BUILDERS = 3


def cli_env(cache_folder: Path) -> dict:
    return dict(os.environ, MITSUBA_REFS_CACHE=str(cache_folder), MITSUBA_REFS_VARIANT="scalar_rgb",
                PYTHONPATH=os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]))


def run_cli(args, cwd: Path, cache_folder: Path, timeout=300):
    return subprocess.run([sys.executable, "-m", "mitsuba_refs.cli.main", *args], cwd=cwd,
                          env=cli_env(cache_folder), capture_output=True, text=True,
                          timeout=timeout)


def case_folders(root: Path, name: str, args: list):
    """(arguments with --out for compare, cache folder, out folder) of one case."""
    cache_folder = root / "a-file" / "refs" if name == "compare-cache-under-a-file" \
        else root / f"cache-{name}"
    out = root / f"out-{name}"
    extra = ["--out", str(out)] if args[0] == "compare" else []
    return args + extra, cache_folder, out


@pytest.fixture(scope="module")
def scenes(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("refs-cli-faults")
    write_scenes(root)
    return root


@pytest.fixture(scope="module")
def runs(scenes):
    """The subprocess cases that need no Mitsuba, run at once:
    name -> (CompletedProcess, cache folder, out folder)."""
    return run_cases(scenes, {name: case_folders(scenes, name, args)
                              for name, (args, _, _, live) in SUBPROCESS_CASES.items()
                              if not live})


@pytest.fixture(scope="module")
def live_runs(scenes):
    """The cases that render with Mitsuba, and the concurrent builders, run at once. Only
    tests marked ``mitsuba`` take it: where those skip (tests/conftest.py), nothing runs."""
    jobs = {name: case_folders(scenes, name, args)
            for name, (args, _, _, live) in SUBPROCESS_CASES.items() if live}
    for k in range(BUILDERS):
        jobs[f"builder-{k}"] = (["build", "ok.xml", *TINY_BUILD, "--force"],
                                scenes / "cache-concurrent", scenes / "no-out")
    return run_cases(scenes, jobs)


def run_cases(scenes, jobs):
    """``jobs`` (name -> (args, cache folder, out folder)) through the CLI, four at a time."""
    with ThreadPoolExecutor(max_workers=4) as pool:
        futures = {name: pool.submit(run_cli, args, scenes, cache_folder)
                   for name, (args, cache_folder, _) in jobs.items()}
        return {name: (futures[name].result(), jobs[name][1], jobs[name][2]) for name in jobs}


def assert_one_line_error(returncode, stdout, stderr, status, needles):
    """Exit ``status``, no traceback, and one error line containing ``needles``: the only
    line on stderr, or, where Mitsuba ran, the last one after its own (coloured) warnings
    and the progress line of the reference being rendered."""
    assert "Traceback" not in stdout + stderr, stdout + stderr
    assert returncode == status, stdout + stderr
    plain = re.sub(r"\x1b\[[0-9;]*m", "", stderr)
    lines = [line for line in plain.splitlines() if line.strip() and " WARN " not in line
             and not line.endswith("), rendering")]
    assert len(lines) == 1, stderr
    assert lines[0].startswith("mitsuba-refs "), lines[0]
    for needle in needles:
        assert needle in lines[0], (needle, lines[0])


def _params(cases):
    return [pytest.param(name, marks=[pytest.mark.mitsuba] if live else [])
            for name, (_, _, _, live) in cases.items()]


@pytest.mark.parametrize("name", _params(SUBPROCESS_CASES))
def test_bad_input_gives_one_line_exit_2_and_leaves_nothing(name, request):
    _, status, needles, live = SUBPROCESS_CASES[name]
    done, cache_folder, out = request.getfixturevalue("live_runs" if live else "runs")[name]
    assert_one_line_error(done.returncode, done.stdout, done.stderr, status, needles)
    assert leftovers(cache_folder) == []
    assert leftovers(out) == []


@pytest.mark.parametrize("name", _params(IN_PROCESS_CASES))
def test_bad_input_in_process_one_line_exit_2_and_leaves_nothing(name, scenes, capfd,
                                                                 monkeypatch):
    args, status, needles, _ = IN_PROCESS_CASES[name]
    args, cache_folder, out = case_folders(scenes, name, args)
    monkeypatch.chdir(scenes)
    for key, value in cli_env(cache_folder).items():
        monkeypatch.setenv(key, value)
    returncode = exit_status(args)
    captured = capfd.readouterr()
    assert_one_line_error(returncode, captured.out, captured.err, status, needles)
    assert leftovers(cache_folder) == []
    assert leftovers(out) == []


def exit_status(args) -> int:
    """What ``python -m mitsuba_refs.cli.main ARGS`` exits with (argparse exits by itself)."""
    try:
        return main(args)
    except SystemExit as done:
        return done.code


def test_a_film_in_an_include_is_not_reported_as_missing(scenes):
    """The reference side's own film check used to miss a <film> in an <include>d file
    and say "no <film>"; it now follows includes (and compare lets the tracer speak
    first: case compare-lanczos-film-in-include names the included file and line)."""
    from mitsuba_refs.reference.render import check_box_filter, check_film_filter
    check_box_filter(scenes / "incfilm.xml")  # finds the included box film: no exception
    with pytest.raises(ValueError, match="gaussian"):
        check_box_filter(scenes / "incgauss.xml")
    check_film_filter(scenes / "incgauss.xml")   # a gaussian film is supported
    with pytest.raises(ValueError, match="lanczos"):
        check_film_filter(scenes / "inclanczos.xml")


@pytest.mark.mitsuba
def test_build_accepts_a_film_in_an_include(scenes, tmp_path, capfd, monkeypatch):
    monkeypatch.setenv("MITSUBA_REFS_CACHE", str(tmp_path))
    assert exit_status(["build", str(scenes / "incfilm.xml"), *TINY_BUILD]) == 0, \
        capfd.readouterr().err
    status, detail, _ = validate(scenes / "incfilm.xml", {"width": "8", "height": "8"}, "path",
                                 4, 1, tmp_path)
    assert status == "ok", detail


@pytest.mark.mitsuba
def test_concurrent_builders_leave_one_valid_reference_and_no_temporary_files(live_runs, scenes):
    for k in range(BUILDERS):
        done = live_runs[f"builder-{k}"][0]
        assert done.returncode == 0 and "Traceback" not in done.stderr, done.stderr
    shared = live_runs["builder-0"][1]
    params = {"width": "8", "height": "8"}
    status, detail, _ = validate(scenes / "ok.xml", params, "path", 4, 1, shared)
    assert status == "ok", detail
    assert sorted(p.suffix for p in shared.iterdir() if p.name != LOCK_NAME) == [".exr", ".json"]


# ----------------------------------------------------------------------------------
# In-process: the same entry function, for option checks that need no scene work


@pytest.mark.parametrize("args,needle", [
    (["compare", "quad-light", "--alpha", "0"], "--alpha must be between 0 and 1"),
    (["compare", "quad-light", "--alpha", "1.5"], "--alpha must be between 0 and 1"),
    (["compare", "quad-light", "--ladder", "4,1,16"], "--ladder needs at least 3 increasing"),
    (["compare", "quad-light", "--ladder", "1,4"], "--ladder needs at least 3 increasing"),
    (["compare", "quad-light", "--ladder", "1,x,16"], "argument --ladder"),
    (["compare", "quad-light", "--ladder", "0,4,16"], "argument --ladder"),
    (["compare", "quad-light", "--replicas", "0"], "--replicas must be >= 1"),
    (["compare", "quad-light", "--processes", "0"], "--processes must be >= 1"),
    (["compare", "quad-light", "--spp", "0"], "--spp must be >= 2"),
    (["compare", "quad-light", "--spp", "lots"], "argument --spp"),
    (["compare", "quad-light", "-D", "width"], "-D expects name=value"),
    (["compare", "quad-light", "-D", "=3"], "-D expects name=value"),
    (["compare", "quad-light", "--bounces", "sometimes"], "argument --bounces"),
    (["compare", "pathtracer"], "is a folder"),
    (["compare", "quad-light", "--out", "README.md"], "--out README.md: is a file"),
    (["compare", "quad-light", "--out", "README.md/pictures"], "README.md is a file"),
    (["build", "quad-light", "--seed", "-1"], "--seed must be >= 0"),
    (["build", "quad-light", "-D", "oops"], "-D expects name=value"),
    (["compare"], "required: scene"),
    ([], "required: command"),
    (["render", "quad-light"], "invalid choice: 'render'"),
])
def test_option_errors_are_one_line_with_exit_2(args, needle, capsys, monkeypatch):
    monkeypatch.chdir(REPO)
    assert exit_status(args) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and needle in err, err


def test_ladder_is_not_checked_without_the_convergence_test(capsys, monkeypatch):
    """--no-convergence makes --ladder irrelevant; the run then fails on the next check."""
    monkeypatch.chdir(REPO)
    assert main(["compare", "quad-light", "--no-convergence", "--ladder", "1,4",
                 "--spp", "1"]) == 2
    assert "--spp" in capsys.readouterr().err


# ----------------------------------------------------------------------------------
# The cache: unwritable, concurrent, overflowing


def corrupt_copy_of_committed(folder: Path) -> Path:
    """quad-light's committed ``path`` reference copied into ``folder``, its EXR truncated."""
    stem = "quad-light__path__height-48_width-64__4096spp-s1"
    folder.mkdir(parents=True)
    for suffix in (".exr", ".json"):
        shutil.copy(COMMITTED / f"{stem}{suffix}", folder / f"{stem}{suffix}")
    exr = folder / f"{stem}.exr"
    exr.write_bytes(exr.read_bytes()[:-200])
    return exr


def test_corrupt_reference_in_read_only_cache_is_refused_before_rendering(
        tmp_path, capsys, monkeypatch):
    """A corrupt reference must be re-rendered, but the cache folder cannot be written:
    refused in one line (exit 2) before minutes of rendering are spent.

    What this proves: the handling of the operating system's "permission denied" when the
    cache is probed, and that no render starts. It does not prove that the OS refuses the
    write (root ignores permission bits, so ``chmod`` cannot make a folder read-only for
    these tests): the probe's ``mkstemp`` is made to fail as it would in a read-only folder.
    test_bad_input_gives_one_line_exit_2_and_leaves_nothing[compare-cache-under-a-file]
    makes the OS itself refuse (a cache path under a file), as root too.
    """
    cache_folder = tmp_path / "cache"
    exr = corrupt_copy_of_committed(cache_folder)
    before = exr.read_bytes()

    def read_only(*args, **kwargs):
        raise PermissionError(13, "Permission denied")

    def no_render(*args, **kwargs):
        raise AssertionError("rendered although the cache cannot be written")

    monkeypatch.setattr(cache.tempfile, "mkstemp", read_only)
    monkeypatch.setattr("mitsuba_refs.reference.render.render_reference", no_render)
    monkeypatch.setenv("MITSUBA_REFS_CACHE", str(cache_folder))
    # As if the package held no committed copy (which lookups read before the user cache).
    monkeypatch.setattr(cache, "lookup_dirs", lambda directory=None: [cache.cache_dir()])
    monkeypatch.chdir(REPO)
    status = main(["compare", "quad-light", "--no-convergence", "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err.strip()
    assert status == 2
    assert len(err.splitlines()) == 1
    assert str(cache_folder) in err and "Permission denied" in err and "MITSUBA_REFS_CACHE" in err
    assert exr.read_bytes() == before
    assert not (tmp_path / "out").exists()


def fake_reference(value: float, h=8, w=8) -> Reference:
    mean = np.full((h, w, 3), value)
    var = np.full((h, w, 3), value / 10)
    meta = {"scene": "quad-light", "width": w, "height": h, "spp": 16, "integrator": "path",
            "variant": "none", "mitsuba_version": "test"}
    return Reference(mean=mean, var=var, n=16, metadata=meta)


PARAMS = {"width": "8", "height": "8"}


def _store_repeatedly(writer: int, folder: str, rounds: int) -> None:
    for k in range(rounds):
        store(fake_reference(1.0 + writer + k / 100), "quad-light", PARAMS, "path", 16, 1, folder)


def _validate_repeatedly(folder: str, rounds: int, results) -> None:
    for _ in range(rounds):
        results.append(validate("quad-light", PARAMS, "path", 16, 1, folder)[0])


def test_concurrent_writers_and_readers_never_see_a_torn_reference(tmp_path):
    """Four processes store *different* images under one reference while two validate it:
    every read sees a whole pair (ok or missing, never corrupt), the final pair is valid
    and one writer's, and no temporary file is left."""
    ctx = multiprocessing.get_context("fork")
    folder = str(tmp_path / "cache")
    reads = ctx.Manager().list()
    writers = [ctx.Process(target=_store_repeatedly, args=(w, folder, 15)) for w in range(4)]
    readers = [ctx.Process(target=_validate_repeatedly, args=(folder, 40, reads)) for _ in range(2)]
    for p in writers + readers:
        p.start()
    for p in writers + readers:
        p.join(120)
        assert p.exitcode == 0
    assert set(reads) <= {"ok", "missing"} and "ok" in reads, sorted(set(reads))
    status, detail, ref = validate("quad-light", PARAMS, "path", 16, 1, folder)
    assert status == "ok", detail
    assert ref.mean[0, 0, 0] in {1.0 + w + 14 / 100 for w in range(4)} | \
        {np.float32(1.0 + w + 14 / 100) for w in range(4)}
    assert sorted(p.suffix for p in Path(folder).iterdir() if p.name != LOCK_NAME) == \
        [".exr", ".json"]


def test_failed_store_leaves_no_temporary_file_and_says_where(tmp_path, monkeypatch):
    folder = tmp_path / "cache"

    def full_disk(src, dst):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(cache.os, "replace", full_disk)
    with pytest.raises(RefsInputError, match="No space left on device.*MITSUBA_REFS_CACHE"):
        store(fake_reference(1.0), "quad-light", PARAMS, "path", 16, 1, folder)
    assert leftovers(folder) == []


def test_stored_reference_is_readable_by_others(tmp_path):
    """Temporary files are private (mkstemp); the renamed reference gets the umask's mode."""
    exr, sidecar = store(fake_reference(1.0), "quad-light", PARAMS, "path", 16, 1, tmp_path)
    umask = os.umask(0)
    os.umask(umask)
    assert exr.stat().st_mode & 0o777 == 0o666 & ~umask
    assert json.loads(sidecar.read_text())["key"]


def test_overflowing_variance_is_refused_with_the_reason():
    """Radiance 1e30: Mitsuba's float32 film holds the mean but not the squared radiance,
    so the variance is inf; refused before it is stored, saying why and what to do."""
    ref = fake_reference(1e30)
    ref.var[:4] = np.inf
    with pytest.raises(RefsInputError, match=r"quad-light.xml: the reference variance overflows "
                                             r"in 96 of 192 .* scale the emitters"):
        check_finite(ref, "quad-light")
    ref.mean[0, 0, 0] = np.nan
    with pytest.raises(RefsInputError, match="NaN or infinite radiance in 1 of 192"):
        check_finite(ref, "quad-light")


def test_mitsuba_messages_become_one_line_naming_the_file():
    located = RuntimeError('[parser.cpp:1718] At /s/a.xml (line 58, col 10): failed to '
                           'instantiate bsdf plugin of type "x": [PluginManager] Plugin "x" '
                           'not found!')
    assert mitsuba_error_line(located, "/s/a.xml") == (
        '/s/a.xml:58:10: Mitsuba cannot load the scene: failed to instantiate bsdf plugin of '
        'type "x": [PluginManager] Plugin "x" not found!')
    unused = RuntimeError("[parser.cpp:111] Found unused parameters:\n  - $spp=1024")
    line = mitsuba_error_line(unused, "b.xml")
    assert "\n" not in line and line.startswith("b.xml:") and 'value="$spp"' in line


# ----------------------------------------------------------------------------------
# Ctrl-C


def test_ctrl_c_gives_one_line_and_exit_130(tmp_path):
    """SIGINT (Ctrl-C) in the middle of ``compare``: one line, status 130, no pictures."""
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "mitsuba_refs.cli.main", "compare", "quad-light",
                             "--processes", "1", "--out", str(out)],
                            env=cli_env(COMMITTED), cwd=REPO, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, preexec_fn=restore_sigint)
    # The stage line that opens the mean render is printed inside main(), seconds before the
    # render ends: the interrupt lands in it, whatever the machine's speed.
    seen = ""
    while "compare:" not in seen and proc.poll() is None:
        seen += proc.stderr.readline()
    proc.send_signal(signal.SIGINT)
    stdout, rest = proc.communicate(timeout=30)
    stderr = seen + rest
    # main() returns 130. When the interrupt lands while a module is being imported,
    # CPython records it as unhandled and, after our line, ends the process by SIGINT
    # instead: a shell reports that as 130 too (128 + 2).
    assert proc.returncode in (130, -signal.SIGINT), stderr
    # The stage lines printed before the interrupt come first; the interrupt itself is one
    # line, the last.
    lines = stderr.strip().splitlines()
    assert "Traceback" not in stderr and lines[-1] == "mitsuba-refs: interrupted", stderr
    assert sum("interrupted" in line for line in lines) == 1
    assert leftovers(out) == []


@pytest.mark.parametrize("args,needle", [
    (["compare", "ok.xml", *SMALL, "--no-convergence"], "Mitsuba 3 is not installed"),
    (["build", "ok.xml", *SMALL], "which is not installed: pip install mitsuba"),
])
def test_without_mitsuba_a_missing_reference_is_one_line(args, needle, scenes, tmp_path, capfd,
                                                         monkeypatch):
    """A reference nobody committed, on a machine without Mitsuba (simulated here, also where
    it is installed: ``build`` asks through the name the CLI imported)."""
    from mitsuba_refs.cli import main as cli
    monkeypatch.setattr(cache, "mitsuba_available", lambda: False)
    monkeypatch.setattr(cli, "mitsuba_available", lambda: False)
    monkeypatch.setenv("MITSUBA_REFS_CACHE", str(tmp_path / "cache"))
    monkeypatch.chdir(scenes)
    out = ["--out", str(tmp_path / "out")] if args[0] == "compare" else []
    assert exit_status(args + out) == 2
    err = capfd.readouterr().err
    assert len(err.strip().splitlines()) == 1 and needle in err, err
    assert leftovers(tmp_path / "cache") == [] and leftovers(tmp_path / "out") == []
