"""What the experiment scripts share: tasks, executors, a resumable result store, metrics, figures.

A *task* is one render: (scene, parameters, integrator, options, spp, seed).
:func:`run_tasks` runs a list of tasks on any ``concurrent.futures`` executor
(a local process pool by default, a Dask cluster with ``dask=ADDRESS``), and
appends one JSON line per finished task to a :class:`ResultStore`; tasks
already in the store are skipped, so an interrupted experiment resumes where
it stopped. Workers return images; metrics against a reference are computed
by the driver, so remote workers need the scene files but not the references.
"""
from __future__ import annotations

import argparse
import csv
import hashlib
import json
import math
import multiprocessing
import os
import sys
from concurrent.futures import Future, ProcessPoolExecutor, as_completed
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mitsuba_refs.errors import ReferenceUnavailable
from mitsuba_refs.reference.cache import get_reference as lookup
from mitsuba_refs.stats import image_mse
from mitsuba_refs.verdicts.estimators import reference_integrator
from mitsuba_refs.verdicts.scenes import default_params, loaded_scene
from pathtracer import render
from pathtracer.core.color import LUMINANCE
from pathtracer.core.progress import Progress, Quiet
from pathtracer.scene.defines import parse_define

#: Colours per integrator, the same in every figure.
COLOURS = {"path": "C0", "path_nee": "C1", "path_bsdf": "C2", "direct": "C3", "recursive": "C4",
           "smallpt": "C5", "pathclass": "C6"}
#: Long names for legends.
LABELS = {"path": "path (MIS: BSDF + shadow rays)", "path_nee": "path_nee (shadow rays)",
          "path_bsdf": "path_bsdf (BSDF sampling only)", "direct": "direct (MIS, 1 bounce)",
          "recursive": "recursive ray tracing", "smallpt": "smallpt"}
#: relMSE = mean((t - r)^2 / (r^2 + RELMSE_EPS)), per pixel and channel.
RELMSE_EPS = 1e-2


# ---------------------------------------------------------------------------------------
# command line

def define(text: str) -> tuple[str, str]:
    """argparse type of ``-D name=value`` (:func:`pathtracer.scene.defines.parse_define`)."""
    try:
        return parse_define(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def add_run_args(parser: argparse.ArgumentParser, out: str, workers: bool = True) -> None:
    """The options every script has: --out, -D, --workers, --dask, --no-progress."""
    parser.add_argument("--out", type=Path, default=Path(out),
                        help=f"output folder for figures and numbers (default: {out})")
    parser.add_argument("-D", dest="defines", action="append", type=define, default=[],
                        metavar="NAME=VALUE", help="scene parameter, e.g. -D width=128; repeatable")
    if workers:
        parser.add_argument("--workers", type=int, default=None,
                            help="local worker processes (default: every core)")
        parser.add_argument("--dask", metavar="ADDRESS", default=None,
                            help="run the renders on a Dask cluster (scheduler address such as "
                                 "tcp://host:8786, or 'local' for a LocalCluster); needs "
                                 "`pip install dask distributed`")
    parser.add_argument("--no-progress", action="store_true", help="no progress bars")


def scene_params(scene: str, defines=()) -> dict:
    """A built-in scene's test film size (where the committed references are), overridden by -D."""
    return {**default_params(scene), **dict(defines)}


def cpu_count() -> int:
    """Cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:   # pragma: no cover - not Linux
        return os.cpu_count() or 1


def progress_bar(total: int, desc: str, enabled: bool = True):
    """The commands' progress on stderr (:mod:`pathtracer.core.progress`: a bar with the time
    left on a terminal, plain lines in a pipe); a no-op object when disabled."""
    return Progress(total, desc, "renders") if enabled else Quiet()


def run_with_progress(keys, run, per_key: int, desc: str, enabled: bool = True):
    """``{key: run(key, bar)}`` for every key, under one progress bar of ``per_key`` steps per key.

    Returns None after printing the error when a Mitsuba reference is missing (the caller exits
    with 2): an experiment compares against references and has nothing to show without them.
    """
    keys = list(keys)
    bar = progress_bar(len(keys) * per_key, desc, enabled)
    try:
        return {key: run(key, bar) for key in keys}
    except ReferenceUnavailable as error:
        print(f"error: {error}", file=sys.stderr)
        return None
    finally:
        bar.close()


# ---------------------------------------------------------------------------------------
# files

def out_dir(path) -> Path:
    """``path`` as a folder that exists."""
    path = Path(path)
    path.mkdir(parents=True, exist_ok=True)
    return path


def save_figure(fig, out, stem: str) -> list[str]:
    """Write ``stem.png`` and ``stem.svg`` into ``out``; close the figure; return the paths."""
    import matplotlib.pyplot as plt  # matplotlib: heavy, imported only to draw
    out = out_dir(out)
    paths = []
    for ext in ("png", "svg"):
        path = out / f"{stem}.{ext}"
        fig.savefig(path, dpi=120, bbox_inches="tight")
        paths.append(str(path))
    plt.close(fig)
    return paths


def _plain(value):
    """JSON-able version of NumPy scalars, arrays, tuples, paths."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return _plain(value.tolist())
    if isinstance(value, (np.bool_,)):
        return bool(value)
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, (float, np.floating)):
        value = float(value)
        return value if math.isfinite(value) else None
    if isinstance(value, Path):
        return str(value)
    return value


def write_json(path, obj) -> str:
    """Write ``obj`` (NumPy values included) as indented JSON; return the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(_plain(obj), indent=1) + "\n")
    return str(path)


def write_csv(path, rows: list[dict]) -> str:
    """Rows of dicts to CSV (columns: the union of keys, in first-seen order)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    columns = []
    for row in rows:
        columns += [k for k in row if k not in columns]
    with open(path, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=columns)
        writer.writeheader()
        for row in rows:
            writer.writerow({k: _plain(v) for k, v in row.items()})
    return str(path)


# ---------------------------------------------------------------------------------------
# references and metrics

def get_reference(scene, params, integrator="path", quiet=False):
    """The Mitsuba reference (cached or rendered), or None with a note on stderr."""
    try:
        return lookup(scene, params, reference_integrator(integrator),
                      log=None if quiet else (lambda m: print(m, file=sys.stderr)))
    except (ReferenceUnavailable, FileNotFoundError, KeyError, ValueError) as error:
        if not quiet:
            print(f"note: no Mitsuba reference for {scene} {params} {integrator}: {error}",
                  file=sys.stderr)
        return None


def error_metrics(mean, reference) -> dict:
    """MSE, RMSE and relMSE of an image against a reference, the reference's own noise removed.

    relMSE = mean((t - r)^2 / (r^2 + eps)) - mean(v_r / n_r / (r^2 + eps)), eps = RELMSE_EPS:
    the squared error relative to the pixel's brightness, so dark and bright regions count alike.
    """
    mse = image_mse(mean, reference.mean, reference.var, reference.n)
    weight = 1.0 / (reference.mean ** 2 + RELMSE_EPS)
    relmse = float(np.mean((mean - reference.mean) ** 2 * weight)
                   - np.mean(np.maximum(reference.var, 0) / reference.n * weight))
    return dict(mse=mse, rmse=math.sqrt(max(mse, 0.0)), relmse=relmse)


def luminance(image) -> np.ndarray:
    """Rec. 709 luminance of an (..., 3) linear RGB image (Mitsuba's weights)."""
    return np.asarray(image) @ LUMINANCE


# ---------------------------------------------------------------------------------------
# tasks

@dataclass(frozen=True)
class Task:
    """One render. ``labels`` carry bookkeeping (replica, level...) into the result record."""

    scene: str
    integrator: str
    spp: int
    seed: int
    params: tuple = ()
    options: tuple = ()
    labels: tuple = ()

    @staticmethod
    def make(scene, integrator, spp, seed, params=None, options=None, **labels) -> "Task":
        return Task(str(scene), str(integrator), int(spp), int(seed),
                    tuple(sorted((str(k), str(v)) for k, v in (params or {}).items())),
                    tuple(sorted((options or {}).items())), tuple(sorted(labels.items())))

    @property
    def key(self) -> str:
        """Content hash of the render (labels excluded: they do not change the image)."""
        blob = json.dumps([self.scene, self.integrator, self.spp, self.seed,
                           list(self.params), [list(o) for o in self.options]], default=str)
        return hashlib.sha1(blob.encode()).hexdigest()[:20]

    def as_dict(self) -> dict:
        return dict(scene=self.scene, integrator=self.integrator, spp=self.spp, seed=self.seed,
                    params=dict(self.params), options=dict(self.options), **dict(self.labels))


def run_task(task: Task) -> dict:
    """Render a task in this process (one core): mean, variance, seconds."""
    scene = loaded_scene(task.scene, dict(task.params))
    result = render(scene, task.integrator, spp=task.spp, seed=task.seed, processes=1,
                    progress=False, **dict(task.options))
    return dict(mean=result.mean, variance=result.variance, seconds=result.seconds,
                host=os.uname().nodename)


class ResultStore:
    """Append-only JSON-lines file of finished tasks, keyed by :attr:`Task.key`.

    Each line is flushed and fsynced as soon as its task finishes; a torn last
    line (the process was killed mid-write) is ignored on reload.
    """

    def __init__(self, path):
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.records: dict[str, dict] = {}
        if self.path.exists():
            text = self.path.read_text()
            good = []
            for line in text.splitlines():
                try:
                    record = json.loads(line)
                except ValueError:
                    continue
                self.records[record["key"]] = record
                good.append(line)
            if len(good) != len(text.splitlines()) or (text and not text.endswith("\n")):
                # drop the torn line, so that new records start on a line of their own
                tmp = self.path.with_suffix(".tmp")
                tmp.write_text("".join(line + "\n" for line in good))
                os.replace(tmp, self.path)

    def __contains__(self, key) -> bool:
        return key in self.records

    def __len__(self) -> int:
        return len(self.records)

    def get(self, task: Task) -> dict | None:
        return self.records.get(task.key)

    def add(self, record: dict) -> None:
        record = _plain(record)
        with open(self.path, "a") as f:
            f.write(json.dumps(record) + "\n")
            f.flush()
            os.fsync(f.fileno())
        self.records[record["key"]] = record


class _InlineExecutor:
    """Runs tasks in this process (workers=1): no pickling, exact single-core timings."""

    def submit(self, fn, *args, **kwargs):
        future = Future()
        future.set_running_or_notify_cancel()
        try:
            future.set_result(fn(*args, **kwargs))
        except BaseException as error:   # forwarded to the caller
            future.set_exception(error)
        return future

    def shutdown(self, wait=True, cancel_futures=False):
        pass


@contextmanager
def executor(workers: int | None = None, dask: str | None = None):
    """A ``concurrent.futures`` executor.

    ``dask`` = a scheduler address (``tcp://host:8786``) uses that Dask cluster
    through ``Client.get_executor()``; ``'local'`` starts a LocalCluster with
    ``workers`` single-threaded worker processes. Otherwise a local process
    pool with ``workers`` processes (default: every core); ``workers=1`` runs inline.
    """
    if dask:
        try:
            from distributed import Client, LocalCluster  # Dask: optional, imported only for --dask
        except ImportError:
            raise SystemExit("--dask needs `pip install dask distributed` "
                             "(or the project's [dask] extra)") from None
        cluster = None
        if dask == "local":
            cluster = LocalCluster(n_workers=workers or cpu_count(), threads_per_worker=1,
                                   dashboard_address=None)
            client = Client(cluster)
        else:
            client = Client(dask)
        pool = client.get_executor()
        try:
            yield pool
        finally:
            pool.shutdown(wait=False)
            client.close()
            if cluster is not None:
                cluster.close()
        return
    workers = cpu_count() if workers is None else max(1, int(workers))
    if workers == 1:
        yield _InlineExecutor()
        return
    pool = ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("fork"))
    try:
        yield pool
    except BaseException:
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    else:
        pool.shutdown(wait=True)


def run_tasks(tasks, store: ResultStore, on_result, *, workers=None, dask=None, pool=None,
              progress=True, desc="rendering") -> ResultStore:
    """Run the tasks not yet in ``store``; record ``on_result(task, output)`` for each.

    ``on_result`` turns a worker's output (mean, variance, seconds) into the
    JSON-able fields of the record (metrics); the record also holds the task
    and its key. Larger renders are submitted first (shorter tail).
    ``pool`` is an executor to use instead of starting one.
    """
    pending = [t for t in dict.fromkeys(tasks) if t.key not in store]
    pending.sort(key=lambda t: -t.spp * dict(t.options).get("branches", 1))
    bar = progress_bar(len(pending), desc, progress)
    if not pending:
        bar.close()
        return store

    def consume(ex):
        futures = {ex.submit(run_task, t): t for t in pending}
        for future in as_completed(futures):
            task = futures[future]
            output = future.result()
            record = dict(key=task.key, task=task.as_dict(), seconds=output["seconds"],
                          host=output.get("host"))
            record.update(on_result(task, output) or {})
            store.add(record)
            bar.update()

    try:
        if pool is not None:
            consume(pool)
        else:
            with executor(workers, dask) as ex:
                consume(ex)
    finally:
        bar.close()
    return store
