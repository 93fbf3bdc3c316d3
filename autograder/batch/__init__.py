"""Grade a folder of submissions: one submission's checks per task, here or on a Dask cluster.

``python -m autograder.batch SUBMISSIONS --out grades.jsonl [--dask ADDRESS] [--workers N]``

Every ``.py`` file and every package folder (with ``__init__.py``) directly inside
``SUBMISSIONS`` is one submission. Each is graded by :func:`autograder.grading.grade`, every
check in the student's isolated process (:mod:`autograder.isolation`) on the machine that runs
the task: a thread of this process (``--workers`` at once), or a worker of the Dask cluster at
``--dask`` (a scheduler address, or ``local``). A finished submission's line is appended to
the JSONL at once, so an interrupted or lost run goes on with the same command (the finished
ones are skipped). The workers need the submissions folder and the references at the same
paths (a shared file system, ``MITSUBA_REFS_CACHE``) and, for isolation as root, the
``student`` user (docs/cluster.md, docs/autograder.md).
"""
from __future__ import annotations

import argparse
import json
import socket
import sys
import time
from concurrent.futures import ThreadPoolExecutor, as_completed
from pathlib import Path

from mitsuba_refs.cluster.client import connect, lost

from .. import grading


def submissions(folder: Path) -> list[str]:
    """The submissions in ``folder``: its ``.py`` files and package folders, sorted."""
    found = [p for p in sorted(Path(folder).iterdir())
             if (p.suffix == ".py" and p.is_file()) or (p / "__init__.py").is_file()]
    return [str(p.resolve()) for p in found]


def grade_submission(impl: str, assignment: str, check_ids: tuple = (), trusted: bool = False,
                     time_scale: float | None = None) -> dict:
    """Grade one submission (a task): its score, each check's, the seconds and the host."""
    checks = grading.checks_of(assignment)
    if check_ids:
        checks = tuple(c for c in checks if c.id in check_ids)
    started = time.perf_counter()
    results = grading.grade(impl, checks, trusted=trusted, time_scale=time_scale)
    return {
        "submission": impl,
        "score": sum(r.score for r in results),
        "max_score": sum(r.max_score for r in results),
        "checks": {r.check.id: {"score": r.score, "max_score": r.max_score, "passed": r.passed,
                                "failure": r.failure} for r in results},
        "seconds": round(time.perf_counter() - started, 2),
        "host": socket.gethostname(),
    }


def _finished(path: Path) -> set:
    """The submissions the JSONL ``path`` already holds a line of."""
    if not path.exists():
        return set()
    return {json.loads(line)["submission"] for line in path.read_text().splitlines() if line}


def _graded(todo, arguments, workers, dask):
    """``(record)`` of every submission in ``todo``, as they finish."""
    if dask:
        from distributed import as_completed as finished  # Dask: optional, only for --dask
        with connect(dask) as client:
            futures = [client.submit(grade_submission, impl, *arguments, pure=False)
                       for impl in todo]
            try:
                for future in finished(futures):
                    yield future.result()
            except Exception as error:
                if client.status not in ("running", "connecting"):
                    raise lost(dask, error) from None
                raise
        return
    with ThreadPoolExecutor(max(1, workers)) as pool:
        for future in as_completed([pool.submit(grade_submission, impl, *arguments)
                                    for impl in todo]):
            yield future.result()


def build_parser() -> argparse.ArgumentParser:
    """The options of ``python -m autograder.batch``."""
    p = argparse.ArgumentParser(prog="python -m autograder.batch", description=__doc__.split("\n\n")[0])
    p.add_argument("folder", type=Path, help="folder of submissions (.py files, package folders)")
    p.add_argument("--out", type=Path, required=True, help="JSONL of grades (appended, resumable)")
    p.add_argument("--assignment", default=grading.DEFAULT_ASSIGNMENT, choices=list(grading.ASSIGNMENTS))
    p.add_argument("--checks", nargs="+", default=(), metavar="ID", help="only these check ids")
    p.add_argument("--workers", type=int, default=1, help="submissions at once here (default 1)")
    p.add_argument("--dask", metavar="ADDRESS", default=None,
                   help="grade on a Dask cluster: scheduler address, or 'local' (docs/cluster.md)")
    p.add_argument("--time-scale", type=float, default=None, help="stretch the checks' time limits")
    p.add_argument("--solution-runtime", action="store_true",
                   help="instructors only: submissions built on the reference solution")
    return p


def main(argv=None) -> int:
    """Grade the submissions not yet in ``--out``; 2 for a bad folder or a lost scheduler."""
    args = build_parser().parse_args(argv)
    if not args.folder.is_dir():
        print(f"error: {args.folder} is not a folder", file=sys.stderr)
        return 2
    done = _finished(args.out)
    todo = [impl for impl in submissions(args.folder) if impl not in done]
    print(f"{len(done)} submissions already in {args.out}; grading {len(todo)}", flush=True)
    arguments = (args.assignment, tuple(args.checks), args.solution_runtime, args.time_scale)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    try:
        with args.out.open("a") as out:
            for record in _graded(todo, arguments, args.workers, args.dask):
                out.write(json.dumps(record) + "\n")
                out.flush()
                print(f"{Path(record['submission']).name}: {record['score']:g}/"
                      f"{record['max_score']:g} ({record['seconds']:.0f} s, {record['host']})",
                      flush=True)
    except ConnectionError as error:   # an unreachable or lost scheduler; finished lines kept
        print(f"error: {error}", file=sys.stderr)
        return 2
    return 0
