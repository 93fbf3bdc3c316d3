"""References on a Dask cluster (docs/cluster.md): the same bits as the serial render, whatever
the number of workers, the order tasks finish in, or a worker killed mid-build; a lost
scheduler is one clear error and leaves nothing in the cache.

The cluster tests start a real ``dask scheduler`` and ``dask worker`` processes on 127.0.0.1
(``--nworkers 1 --nthreads 1``) and kill them with SIGKILL while a task is known to run (the
task's marker file, :data:`mitsuba_refs.reference.split.ENV_FAULT_DIR`), never after a delay.
"""
import os
import random
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from mitsuba_refs.reference.calls import render_calls
from mitsuba_refs.reference.render import render_reference, resolve_scene
from mitsuba_refs.reference.split import ENV_FAULT_DIR, ReferenceJob, calls_split_by, chunks

pytest.importorskip("distributed")

REPO = Path(__file__).resolve().parents[1]
DASK = Path(sys.executable).parent / "dask"
#: cornell-box at 32x32, 1024 spp: 4 render calls of 256 camera copies (0.2 s each here).
SCENE, INTEGRATOR, SPP, SEED, SIZE = "cornell-box", "path", 1024, 7, (32, 32)


def job(fault_dir=None):
    return ReferenceJob(str(resolve_scene(SCENE)), {}, INTEGRATOR, SPP, SEED, "scalar_rgb",
                        None, SIZE, fault_dir)


def render(split=None):
    with calls_split_by(split):
        return render_reference(SCENE, {}, INTEGRATOR, SPP, SEED, variant="scalar_rgb",
                                resolution=SIZE)


@pytest.fixture(scope="module")
def serial():
    pytest.importorskip("mitsuba")
    return render()


def assert_identical(a, b):
    assert a.n == b.n == SPP
    assert a.mean.dtype == np.float64 and np.array_equal(a.mean, b.mean)
    assert np.array_equal(a.var, b.var)


def test_chunks_cover_every_call_once_in_order():
    for calls in (1, 4, 7, 64):
        for tasks in (1, 3, 8, 100):
            runs = chunks(calls, tasks)
            assert [i for run in runs for i in run] == list(range(calls))
            assert len(runs) == min(tasks, calls) and all(runs)


@pytest.mark.mitsuba
def test_calls_rendered_out_of_order_merge_to_the_same_bits(serial):
    """Tasks of any size finishing in any order: the blocks are merged in call order."""
    def split(calls):
        runs = chunks(calls, 3)
        done = {}
        for run in random.Random(5).sample(runs, len(runs)):   # finish in a shuffled order
            done[run[0]] = render_calls(job(), run)
        return [block for run in runs for block in done[run[0]]]
    assert_identical(render(split), serial)


@pytest.mark.mitsuba
@pytest.mark.slow
def test_local_cluster_gives_the_serial_reference(serial):
    from mitsuba_refs.cluster.site import on_cluster
    with on_cluster("local") as site:
        assert_identical(render(site.split_for(job())), serial)


# ------------------------------------------------ a real scheduler and workers, as processes

def _env(**extra):
    env = dict(os.environ, PYTHONPATH=str(REPO), OMP_NUM_THREADS="1", **extra)
    env.pop(ENV_FAULT_DIR, None)
    return env


def _wait_for(condition, what, timeout=90):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = condition()
        if value:
            return value
        time.sleep(0.05)
    raise AssertionError(f"timed out waiting for {what}")


class Cluster:
    """``dask scheduler`` and ``workers`` ``dask worker`` processes on 127.0.0.1."""

    def __init__(self, folder, workers=2):
        self.file = folder / "scheduler.json"
        log = open(folder / "dask.log", "w")
        self.scheduler = subprocess.Popen(
            [str(DASK), "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
             "--scheduler-file", str(self.file)], env=_env(), stdout=log, stderr=log)
        _wait_for(self.file.exists, "the scheduler file")
        self.address = _wait_for(lambda: _address(self.file), "the scheduler address")
        self.workers = [subprocess.Popen(
            [str(DASK), "worker", self.address, "--nworkers", "1", "--nthreads", "1",
             "--no-dashboard", "--host", "127.0.0.1", "--local-directory", str(folder)],
            env=_env(), stdout=log, stderr=log) for _ in range(workers)]

    def wait_for_workers(self, client, n=2):
        client.wait_for_workers(n, timeout=90)

    def close(self):
        for process in [*self.workers, self.scheduler]:
            if process.poll() is None:
                process.kill()
            process.wait()


def _address(file):
    import json
    try:
        return json.loads(file.read_text())["address"]
    except (OSError, ValueError, KeyError):
        return None


@pytest.fixture
def cluster(tmp_path):
    pytest.importorskip("mitsuba")
    started = Cluster(tmp_path)
    yield started
    started.close()


@pytest.mark.mitsuba
@pytest.mark.slow
def test_worker_killed_mid_build_gives_the_serial_reference(cluster, serial, tmp_path,
                                                            monkeypatch):
    """Two workers; one is killed (SIGKILL) while its task runs: that task runs again on a
    worker and the reference is the serial one, bit for bit."""
    from mitsuba_refs.cluster.client import connect
    from mitsuba_refs.cluster.site import ClusterSite

    fault = tmp_path / "fault"
    fault.mkdir()
    monkeypatch.setenv(ENV_FAULT_DIR, str(fault))
    with connect(cluster.address) as client:
        cluster.wait_for_workers(client)
        site = ClusterSite(client, cluster.address, tasks=4)
        result = {}
        thread = threading.Thread(target=lambda: result.update(ref=render(site.split_for(job()))))
        thread.start()
        first = _wait_for(lambda: sorted(fault.glob("started-*")), "a task to start")[0]
        call, pid = (int(v) for v in first.name.split("-")[1:])
        os.kill(pid, signal.SIGKILL)
        (fault / "release").touch()
        thread.join(180)
    assert not thread.is_alive() and "ref" in result
    assert len(list(fault.glob(f"started-{call}-*"))) == 2   # the killed task ran again
    assert_identical(result["ref"], serial)


def _build(address, cache, fault=None):
    env = _env(MITSUBA_REFS_CACHE=str(cache))
    if fault is not None:
        env[ENV_FAULT_DIR] = str(fault)
    return subprocess.Popen(
        [sys.executable, "-m", "mitsuba_refs.cli.main", "build", SCENE, "--integrators",
         INTEGRATOR, "--no-per-bounce", "--resolution", "32x32", "--spp", str(SPP),
         "--seed", str(SEED), "--dask", address], env=env, cwd=REPO,
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


@pytest.mark.mitsuba
@pytest.mark.slow
def test_lost_scheduler_is_one_error_and_stores_nothing(cluster, tmp_path):
    fault = tmp_path / "fault"
    fault.mkdir()
    build = _build(cluster.address, tmp_path / "cache", fault)
    _wait_for(lambda: list(fault.glob("started-*")), "a task to start")
    cluster.scheduler.kill()
    cluster.scheduler.wait()
    (fault / "release").touch()
    out, err = build.communicate(timeout=180)
    assert build.returncode == 2, out + err
    # The build's progress lines may come first; the fault is one line, the last.
    lines = err.strip().splitlines()
    errors = [line for line in lines if "error" in line]
    assert errors == lines[-1:] and "lost the Dask scheduler" in err and cluster.address in err
    assert not list((tmp_path / "cache").glob("*.exr")) and not list((tmp_path / "cache").glob("*.json"))
    assert not list((tmp_path / "cache").glob(".*.tmp"))


@pytest.mark.mitsuba
def test_unreachable_scheduler_is_one_error(tmp_path):
    build = _build("tcp://127.0.0.1:9", tmp_path / "cache")
    out, err = build.communicate(timeout=120)
    assert build.returncode == 2, out + err
    assert len(err.strip().splitlines()) == 1 and "cannot reach the Dask scheduler at " \
        "tcp://127.0.0.1:9" in err


def _verdicts(path):
    """The JSON results without the seconds (which differ from run to run)."""
    import json

    def scrub(value):
        if isinstance(value, dict):
            return {k: scrub(v) for k, v in value.items() if "seconds" not in k}
        if isinstance(value, list):
            return [scrub(v) for v in value]
        return value
    return scrub(json.loads(path.read_text()))


def _serial_and_cluster(tmp_path, arguments):
    """``mitsuba-refs ARGUMENTS`` on a copy of the Cornell box (a user's scene: its reference
    must be rendered), serially and with ``--dask local``, each with a cache of its own: the
    same exit status and the same reference file, byte for byte. Returns both JSON records."""
    scene = tmp_path / "box.xml"
    scene.write_text(resolve_scene("cornell-box").read_text())
    runs = {}
    for name, extra in (("serial", []), ("cluster", ["--dask", "local"])):
        folder = tmp_path / name
        folder.mkdir()
        env = _env(MITSUBA_REFS_CACHE=str(folder / "cache"), MITSUBA_REFS_VARIANT="scalar_rgb")
        runs[name] = subprocess.run(
            [sys.executable, "-m", "mitsuba_refs", arguments[0], str(scene), *arguments[1:],
             "--out", "out", "--json", "results.json", *extra], cwd=folder, env=env,
            capture_output=True, text=True, timeout=300)
        assert runs[name].returncode in (0, 1), runs[name].stderr
    assert runs["serial"].returncode == runs["cluster"].returncode
    exr = {name: list((tmp_path / name / "cache").glob("*.exr")) for name in runs}
    assert len(exr["serial"]) == len(exr["cluster"]) == 1
    assert exr["serial"][0].read_bytes() == exr["cluster"][0].read_bytes()
    return tuple(_verdicts(tmp_path / name / "results.json") for name in runs)


@pytest.mark.mitsuba
@pytest.mark.slow
def test_compare_through_a_local_cluster_gives_the_serial_verdicts(tmp_path):
    """``compare`` of a user's scene: serially and with ``--dask local``, the same reference
    file, exit status and verdicts."""
    pytest.importorskip("mitsuba")
    serial, cluster = _serial_and_cluster(tmp_path, ["compare", "-D", "width=32", "-D", "height=32",
                                                     "--no-convergence", "--spp", "16"])
    assert serial == cluster


@pytest.mark.mitsuba
@pytest.mark.slow
def test_check_through_a_local_cluster_gives_the_serial_verdicts(tmp_path):
    """``check`` of an external renderer (``pathtracer render`` through its command line) on a
    user's scene: serially and with ``--dask local``, the same reference file, exit status and
    verdicts (the runs' seeds do not depend on where the reference was rendered)."""
    pytest.importorskip("mitsuba")
    command = (f"{sys.executable} -m pathtracer render {{scene}} --resolution {{width}}x{{height}} "
               "--spp {spp} --seed {seed} --max-depth {max_depth} -o {out}")
    serial, cluster = _serial_and_cluster(tmp_path, [
        "check", "--resolution", "32x32", "--no-convergence", "--bounces", "never", "--spp", "16",
        "--jobs", "1", "--command", command])
    for record in (serial, cluster):      # the runs' commands (paths) and clocks differ
        for result in record["results"]:
            result.pop("runs", None)
            result["notes"] = [note for note in result["notes"] if "CPU-seconds" not in note]
    assert serial == cluster


@pytest.mark.mitsuba
@pytest.mark.slow
def test_coverage_run_on_a_local_cluster_gives_the_serial_verdicts(tmp_path):
    pytest.importorskip("mitsuba")
    scenes = tmp_path / "scenes"
    scenes.mkdir()
    for name, builtin in (("a.xml", "cornell-box"), ("b.xml", "quad-light")):
        (scenes / name).write_text(resolve_scene(builtin).read_text())
    verdicts = {}
    for name, extra in (("serial", []), ("cluster", ["--dask", "local"])):
        env = _env(MITSUBA_REFS_CACHE=str(tmp_path / f"cache-{name}"),
                   MITSUBA_REFS_VARIANT="scalar_rgb")
        out = subprocess.run(
            [sys.executable, "-m", "experiments.scene_coverage", str(scenes), "--no-mitsuba",
             "--compare", "--no-convergence", "--resolution", "24x18", "--quiet", "--json",
             str(tmp_path / f"{name}.json"), *extra], cwd=REPO, env=env, capture_output=True,
            text=True, timeout=300)
        assert out.returncode == 0, out.stderr
        import json
        files = json.loads((tmp_path / f"{name}.json").read_text())["files"]
        verdicts[name] = {e["file"]: (e["compare"]["verdict"], e["compare"]["summary"])
                          for e in files}
    assert set(verdicts["serial"]) == {"a.xml", "b.xml"}
    assert verdicts["serial"] == verdicts["cluster"]


@pytest.mark.slow
def test_grader_batch_on_a_local_cluster_gives_the_serial_grades(tmp_path):
    """``python -m autograder.batch``: one submission per task, each check in its sandbox on
    the worker; the same grades as the serial batch, one line per submission."""
    folder = tmp_path / "submissions"
    folder.mkdir()
    for name in ("alice.py", "bob.py"):
        (folder / name).write_text((REPO / "autograder" / "solution.py").read_text())
    grades = {}
    for name, extra in (("serial", []), ("cluster", ["--dask", "local"])):
        out = subprocess.run(
            [sys.executable, "-m", "autograder.batch", str(folder), "--out",
             str(tmp_path / f"{name}.jsonl"), "--checks", "camera", "--solution-runtime",
             *extra], cwd=REPO, env=_env(), capture_output=True, text=True, timeout=300)
        assert out.returncode == 0, out.stderr
        import json
        lines = [json.loads(line) for line in (tmp_path / f"{name}.jsonl").read_text().splitlines()]
        grades[name] = {Path(r["submission"]).name: (r["score"], r["max_score"], r["checks"])
                        for r in lines}
    assert set(grades["serial"]) == {"alice.py", "bob.py"}
    assert grades["serial"] == grades["cluster"]
    assert all(score == best > 0 for score, best, _ in grades["serial"].values())
