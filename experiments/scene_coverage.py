"""Which of a folder's Mitsuba scene files the tracer loads, and what blocks the others.

    python -m experiments.scene_coverage DIR [--json OUT] [--compare [--tolerance [PCT]]
                                        [--max-spp N] [--max-seconds S]]

Every ``*.xml`` file under ``DIR`` falls in the first of these classes that applies:

* ``fragment``: included by another file of the folder, or its root is not ``<scene>``;
* ``malformed``: not well-formed XML;
* ``polarized``: uses a plugin of Mitsuba's ``*_polarized`` variants only;
* ``assets missing``: a file it reads (mesh, texture, include) is not there;
* ``refused by Mitsuba``: Mitsuba's ``scalar_rgb`` variant does not load it, or loads a scene
  without a sensor, which its renderer refuses (checked when Mitsuba is importable, in a
  subprocess with a timeout; its message is recorded);
  ``Mitsuba timed out`` when loading took longer than ``--timeout``;
* ``loads``: the tracer loads it and its integrator accepts it (no rendering);
* ``blocked``: the tracer refuses it; the *feature* is the element and reason of the
  tracer's first refusal (``<bsdf type="hair">: unsupported BSDF``).

The share printed is ``loads / (loads + blocked)``: of the files Mitsuba's RGB variants
load (not fragments, not polarized, assets present), the part the tracer loads. Without
Mitsuba the files it would refuse count as blocked. ``--compare`` then runs
``mitsuba-refs compare FILE --integrator NAME --resolution 64x48`` on each file that loads
(``NAME``: the tracer's integrator for the file's own ``<integrator>``) and records the
verdict (exit code 0 agree, 1 disagree, 2 refused, 3 inconclusive); ``--compare-only
PATTERN...`` limits the compares to the files matching a pattern, ``--no-convergence`` skips
compare's convergence test. ``--tolerance [PCT]``, ``--max-spp N`` and ``--max-seconds S`` are
given to every compare (docs/statistics.md section 9: the mean AGREES within +-PCT %,
DISAGREES, or is INCONCLUSIVE when the rounds' budget ends first); each compare record then
holds the outcome, the spp of the last look (where the mean was decided), the number of
rounds, what stopped them and, when undecided, the spp that would decide (from compare's
``--json``, read in a temporary folder). ``--resume JSON`` keeps an earlier run's classes
(its ``blocked`` files are loaded again; a file compared now gets its integrator chosen
again) and compare verdicts, so that a campaign of hours goes on where it stopped (the JSON
is rewritten after every compare).
"""
from __future__ import annotations

import argparse
import contextlib
import fnmatch
import functools
import json
import os
import re
import signal
import subprocess
import sys
import threading
import time
import warnings
from collections import Counter
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass, field

from experiments.coverage_compare import compare_file
from mitsuba_refs.cli.options import add_tolerance_options, tolerance_of
from mitsuba_refs.cluster.client import connect, lost
from mitsuba_refs.errors import RefsInputError
from pathtracer.render.driver import integrator_for
from pathtracer.scene.errors import SceneError
from pathtracer.scene.load import load_scene
from pathtracer.scene.xml_files import XMLSyntaxError, read_elements, scene_files, scene_tree, walk

#: Plugin types that only Mitsuba's polarized variants render.
POLARIZED_TYPES = {"polarizer", "retarder", "measured_polarized", "pplastic", "stokes"}
#: The classes, in the order of the table.
CLASSES = ("fragment", "malformed", "polarized", "assets missing", "refused by Mitsuba",
           "Mitsuba timed out", "loads", "blocked")
MITSUBA_LOAD = ("import sys, mitsuba as mi\n"
                "mi.set_variant('scalar_rgb')\n"
                "try:\n"
                "    scene = mi.load_file(sys.argv[1])\n"
                "except Exception as e:\n"
                "    print('MITSUBA-REFUSES', str(e).strip().splitlines()[0]); sys.exit(3)\n"
                # Loads, but the mitsuba renderer stops at it: nothing to render.
                "if not scene.sensors():\n"
                "    print('MITSUBA-REFUSES', 'no sensor: the mitsuba renderer refuses to render "
                "it'); sys.exit(3)\n")


@dataclass
class Entry:
    """One file's class, the tracer's feature and messages."""

    file: str
    cls: str = ""
    feature: str = ""
    message: str = ""
    mitsuba: str = ""
    seconds: float = 0.0
    missing: list = field(default_factory=list)
    #: The tracer integrator that renders the file's <integrator> (``compare --integrator``).
    integrator: str = ""
    compare: dict = field(default_factory=dict)


def xml_files(folder: str) -> list[str]:
    """Every ``*.xml`` under ``folder``, sorted, as paths relative to it."""
    found = []
    for root, dirs, files in os.walk(folder):
        dirs.sort()
        found += [os.path.relpath(os.path.join(root, f), folder) for f in files if f.endswith(".xml")]
    return sorted(found)


def read_files(folder: str, names: list[str]) -> tuple[dict, set, dict]:
    """``(roots, included, reads)``: each file's root tag (or the syntax error), the real
    paths of the files some scene includes, and the files each scene reads."""
    roots, included, reads = {}, set(), {}
    for name in names:
        path = os.path.join(folder, name)
        try:
            roots[name] = read_elements(path, name).tag
        except SceneError as e:
            roots[name] = e
            continue
        if roots[name] != "scene":
            continue
        try:
            reads[name] = scene_files(path)
        except SceneError:
            reads[name] = []
        included.update(p for p in reads[name] if p.endswith(".xml"))
    return roots, included, reads


def is_polarized(path: str) -> bool:
    """Whether the scene (its includes spliced in) has a plugin of the polarized variants."""
    try:
        tree = scene_tree(path)
    except SceneError:
        return False
    return any(el.attrs.get("type") in POLARIZED_TYPES for el in walk(tree))


#: Plugin kinds whose types :func:`plugins_of` names (the parts of a scene a verdict is about).
PLUGIN_KINDS = ("bsdf", "emitter", "shape", "texture", "medium", "phase", "volume", "sensor",
                "film", "rfilter", "sampler", "integrator")


@functools.lru_cache(maxsize=None)
def plugins_of(path: str) -> tuple[str, ...]:
    """The plugins a scene file uses, its includes spliced in, as ``kind:type`` (sorted).
    Cached: the JSON, rewritten after every compare, asks for every compared file again."""
    try:
        tree = scene_tree(path)
    except SceneError:
        return ()
    return tuple(sorted({f"{el.tag}:{el.attrs['type']}" for el in walk(tree)
                         if el.tag in PLUGIN_KINDS and not el.attrs.get("type", "$").startswith("$")}))


def verdicts_by_plugin(folder: str, entries: list[Entry]) -> dict:
    """plugin -> {verdict: files} over the compared files that use it (:func:`plugins_of`)."""
    table: dict[str, Counter] = {}
    for entry in entries:
        if entry.compare:
            for plugin in plugins_of(os.path.join(folder, entry.file)):
                table.setdefault(plugin, Counter())[entry.compare["verdict"]] += 1
    return {plugin: dict(counts) for plugin, counts in sorted(table.items())}


def feature_of(error: Exception) -> str:
    """The feature a refusal names: its element and the reason's first words."""
    if not isinstance(error, SceneError):
        return f"tracer error: {type(error).__name__}"
    reason = error.reason
    m = re.match(r'unsupported property "([^"]+)"', reason)
    if m:
        return f'{error.plugin or ""} property "{m.group(1)}"'.strip()
    m = re.match(r"unknown element <([^>]+)>", reason)
    if m:
        return f"<{m.group(1)}>"
    short = re.split(r" \(|; |: ", reason, maxsplit=1)[0][:70]
    return f"{error.plugin}: {short}" if error.plugin else short


@contextlib.contextmanager
def time_limit(seconds: float):
    """Raise TimeoutError after ``seconds`` (Unix, main thread; no limit elsewhere)."""
    if (not hasattr(signal, "SIGALRM") or seconds <= 0
            or threading.current_thread() is not threading.main_thread()):
        yield
        return

    def stop(signum, frame):
        raise TimeoutError(f"loading took more than {seconds:g} s")

    old = signal.signal(signal.SIGALRM, stop)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


def tracer_verdict(path: str, timeout: float) -> tuple[bool, str, str, str]:
    """``(loads, feature, message, integrator)``: load the scene and choose its integrator
    (the name of the tracer's that renders the file's), nothing more."""
    try:
        with warnings.catch_warnings(), time_limit(timeout):
            warnings.simplefilter("ignore")
            integrator = integrator_for(load_scene(path)).name
    except TimeoutError as e:
        return False, "tracer timed out", str(e), ""
    except Exception as e:   # any refusal or crash is recorded, not raised
        return False, feature_of(e), str(e).splitlines()[0] if str(e) else type(e).__name__, ""
    return True, "", "", integrator


def mitsuba_python() -> str | None:
    """An interpreter that imports Mitsuba: this one, or None."""
    probe = subprocess.run([sys.executable, "-c", "import mitsuba"], capture_output=True)
    return sys.executable if probe.returncode == 0 else None


def mitsuba_verdict(python: str, path: str, timeout: float) -> tuple[str, str]:
    """``("loads" | "refuses" | "timeout", message)`` of Mitsuba's scalar_rgb on ``path``."""
    try:
        out = subprocess.run([python, "-c", MITSUBA_LOAD, path], capture_output=True, text=True,
                             timeout=timeout, cwd=os.path.dirname(os.path.abspath(path)))
    except subprocess.TimeoutExpired:
        return "timeout", f"no answer within {timeout:g} s"
    if out.returncode == 0:
        return "loads", ""
    lines = [line for line in out.stdout.splitlines() if line.startswith("MITSUBA-REFUSES")]
    text = lines[0][len("MITSUBA-REFUSES "):] if lines else (out.stderr.strip().splitlines() or
                                                             [f"exit code {out.returncode}"])[-1]
    return "refuses", text


def classify(folder: str, timeout: float, use_mitsuba: bool, jobs: int,
             progress: bool = False, previous: dict | None = None) -> tuple[list[Entry], bool]:
    """The class of every XML file under ``folder``, and whether Mitsuba was asked
    (``progress``: a line on stderr per file loaded). ``previous`` (file -> Entry of an
    earlier run, ``--resume``) is kept as it was for every file it classed, except those it
    found ``blocked``, which are loaded again (the tracer may have learnt their feature)."""
    names = xml_files(folder)
    roots, included, reads = read_files(folder, names)
    entries = {name: Entry(name) for name in names}
    kept = {n: e for n, e in (previous or {}).items() if n in entries and e.cls != "blocked"}
    entries.update(kept)
    candidates = []
    for name, entry in entries.items():
        if name in kept:
            continue
        path = os.path.join(folder, name)
        root = roots[name]
        if isinstance(root, XMLSyntaxError):
            entry.cls, entry.message = "malformed", str(root)
        elif isinstance(root, Exception):
            entry.cls, entry.message = "malformed", str(root)
        elif root != "scene" or os.path.realpath(path) in included:
            entry.cls = "fragment"
        elif is_polarized(path):
            entry.cls = "polarized"
        else:
            missing = list(dict.fromkeys(p for p in reads.get(name, []) if not os.path.exists(p)))
            if missing:
                entry.cls = "assets missing"
                entry.missing = [os.path.relpath(p, folder) for p in missing]
            else:
                candidates.append(name)
    python = mitsuba_python() if use_mitsuba else None
    if python is not None:
        with ThreadPoolExecutor(max(1, jobs)) as pool:
            answers = pool.map(lambda n: mitsuba_verdict(python, os.path.join(folder, n), timeout),
                               candidates)
            for i, (name, (verdict, text)) in enumerate(zip(candidates, answers)):
                entries[name].mitsuba = text or verdict
                if progress:
                    print(f"[Mitsuba {i + 1}/{len(candidates)}] {name}: {verdict}",
                          file=sys.stderr, flush=True)
                if verdict == "refuses":
                    entries[name].cls = "refused by Mitsuba"
                elif verdict == "timeout":
                    entries[name].cls = "Mitsuba timed out"
    for i, name in enumerate(candidates):
        entry = entries[name]
        start = time.perf_counter()
        loads, feature, message, entry.integrator = tracer_verdict(os.path.join(folder, name),
                                                                   timeout)
        entry.seconds = round(time.perf_counter() - start, 3)
        if progress:
            print(f"[{i + 1}/{len(candidates)}] {name}: {'loads' if loads else feature} "
                  f"({entry.seconds:.1f} s)", file=sys.stderr, flush=True)
        if not entry.cls:
            entry.cls = "loads" if loads else "blocked"
            entry.feature, entry.message = feature, message
        elif not loads:   # Mitsuba refused it too: the tracer's reason is kept beside Mitsuba's
            entry.feature, entry.message = feature, message
    return list(entries.values()), python is not None


def compare_loaded(folder: str, entries: list[Entry], timeout: float, resolution: str,
                   done: dict | None = None, progress: bool = False, saved=None,
                   only: tuple = (), convergence: bool = True, dask: str | None = None,
                   rounds: dict | None = None) -> None:
    """``mitsuba-refs compare FILE --integrator NAME --resolution WxH`` on every file that loads,
    with the tracer's integrator for the file's own: its verdict. ``done`` (file -> compare
    record of an earlier run, ``--resume``) is kept instead of comparing again; ``saved`` is
    called after each compare (the JSON is rewritten, so a long run loses nothing); ``only``
    (shell patterns of paths relative to ``folder``) limits the compares to the files matching
    one of them; ``convergence`` False skips compare's convergence test (``--no-convergence``:
    mean and variance verdicts only, about a third of the time). ``dask`` (a scheduler address
    or ``local``) runs one compare per task on that cluster, in the order they finish
    (docs/cluster.md: the workers see ``folder`` and the reference cache at the same paths).
    ``rounds`` (``tolerance``, ``max_spp``, ``max_seconds``) gives every compare the options of
    the rounds (:func:`experiments.coverage_compare.compare_file`)."""
    for entry in entries:
        if done and entry.file in done:
            entry.compare = done[entry.file]
    todo = [e for e in entries if e.cls == "loads" and not e.compare
            and (not only or any(fnmatch.fnmatch(e.file, pattern) for pattern in only))]
    for entry in todo:
        # The integrator is chosen again: a resumed entry's may predate the tracer's own
        # estimator for the file's (volpathmis files were rendered by volpath until 12-03).
        loads, _, _, integrator = tracer_verdict(os.path.join(folder, entry.file), timeout)
        entry.integrator = integrator if loads else entry.integrator
    jobs = {entry.file: (os.path.join(folder, entry.file), entry.integrator, resolution,
                         convergence, timeout, rounds) for entry in todo}
    by_file = {entry.file: entry for entry in todo}
    for i, (file, record) in enumerate(_compares(jobs, dask)):
        entry = by_file[file]
        entry.compare = record
        if progress:
            print(f"[compare {i + 1}/{len(todo)}] {entry.file} ({entry.integrator}): "
                  f"{record['verdict']}{decided_at(record)} ({record['seconds']} s) "
                  f"{record['summary']}",
                  file=sys.stderr, flush=True)
        if saved:
            saved()


def _compares(jobs: dict, dask: str | None):
    """``(file, compare_file record)`` of every job (file -> arguments of
    :func:`compare_file`): here in order, or on the Dask cluster ``dask`` as they finish."""
    if not dask:
        for file, arguments in jobs.items():
            yield file, compare_file(*arguments)
        return
    from distributed import as_completed  # Dask: optional, imported only for --dask
    with connect(dask) as client:
        futures = {client.submit(compare_file, *arguments, pure=False): file
                   for file, arguments in jobs.items()}
        try:
            for future in as_completed(futures):
                yield futures[future], future.result()
        except Exception as error:   # the finished compares are saved: --resume goes on
            if client.status not in ("running", "connecting"):
                raise lost(dask, error) from None
            raise


def decided_at(record: dict) -> str:
    """`` at N spp, R rounds``: where the mean was decided (or, undecided, the rounds stopped)
    when the record says so, else ``""`` (records of runs before the rounds have no ``spp``)."""
    if record.get("spp") is None:
        return ""
    rounds = record.get("rounds", 1)
    return f" at {record['spp']} spp, {rounds} round{'s' if rounds != 1 else ''}"


def tolerance_of_record(record: dict) -> str:
    """`` (+-T %)`` for a compare given ``--tolerance`` (what its outcome is about), else ``""``."""
    return "" if record.get("tolerance") is None else f" (+-{record['tolerance']:g} %)"


def summary(entries: list[Entry]) -> dict:
    """Counts per class and per blocking feature, and the share that loads."""
    classes = Counter(e.cls for e in entries)
    features = Counter(e.feature for e in entries if e.cls == "blocked")
    considered = classes["loads"] + classes["blocked"]
    share = classes["loads"] / considered if considered else None
    return {"classes": {c: classes[c] for c in CLASSES if classes[c]},
            "features": dict(features.most_common()), "considered": considered, "share": share}


def table(entries: list[Entry], folder: str, mitsuba_checked: bool) -> str:
    """The Markdown table of :func:`summary`, with the blocked files under their feature."""
    s = summary(entries)
    lines = [f"Scene coverage of {folder} ({len(entries)} XML files; Mitsuba "
             f"{'checked (scalar_rgb)' if mitsuba_checked else 'not checked'})", "",
             "| class / blocking feature | files |", "|---|---|"]
    for cls, count in s["classes"].items():
        lines.append(f"| {cls} | {count} |")
        if cls == "blocked":
            for feature, n in s["features"].items():
                files = ", ".join(e.file for e in entries if e.cls == "blocked" and e.feature == feature)
                lines.append(f"| &nbsp;&nbsp;{feature.replace('|', '/')} | {n} ({files}) |")
    if s["share"] is not None:
        lines += ["", f"The tracer loads {s['classes'].get('loads', 0)} of the {s['considered']} "
                      f"files Mitsuba's RGB variants load ({100 * s['share']:.0f} %)."]
    compared = [e for e in entries if e.compare]
    if compared:
        verdicts = Counter(e.compare["verdict"] for e in compared)
        lines += ["", "compare --resolution 64x48: " + ", ".join(f"{v} {n}" for v, n in verdicts.items())]
        lines += [f"- {e.file}: {e.compare['verdict']}{tolerance_of_record(e.compare)}"
                  f"{decided_at(e.compare)} ({e.compare['summary']})" for e in compared]
        names = sorted(verdicts)
        lines += ["", "| plugin | files compared | " + " | ".join(names) + " |",
                  "|---|---|" + "---|" * len(names)]
        for plugin, counts in verdicts_by_plugin(folder, entries).items():
            lines.append(f"| `{plugin}` | {sum(counts.values())} | "
                         + " | ".join(str(counts.get(v, 0)) for v in names) + " |")
    return "\n".join(lines)


def build_parser() -> argparse.ArgumentParser:
    """The command line of the script."""
    p = argparse.ArgumentParser(prog="python -m experiments.scene_coverage",
                                description=__doc__.split("\n\n")[0])
    p.add_argument("folder", metavar="DIR", help="folder of Mitsuba XML files (searched recursively)")
    p.add_argument("--json", metavar="OUT", help="write every file's class and messages here")
    p.add_argument("--timeout", type=float, default=120.0,
                   help="seconds for one load, by Mitsuba or the tracer (default 120)")
    p.add_argument("--no-mitsuba", action="store_true", help="do not ask Mitsuba, even if importable")
    p.add_argument("--jobs", type=int, default=2, help="Mitsuba loads at once (default 2)")
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    p.add_argument("--compare", action="store_true",
                   help="run mitsuba-refs compare on every file that loads (renders: slow)")
    p.add_argument("--resolution", default="64x48", help="film size of --compare (default 64x48)")
    p.add_argument("--compare-timeout", type=float, default=3600.0,
                   help="seconds for one compare (default 3600)")
    p.add_argument("--compare-only", nargs="+", default=(), metavar="PATTERN",
                   help="compare only the files matching one of these shell patterns (paths "
                        "relative to DIR, e.g. 'tests/scenes/*')")
    p.add_argument("--no-convergence", action="store_true",
                   help="compare without the convergence test (mean and variance verdicts)")
    add_tolerance_options(p)   # compare's own options and help: given to every compare
    p.add_argument("--dask", metavar="ADDRESS", default=None,
                   help="with --compare: one compare per task on a Dask cluster (scheduler "
                        "address, or 'local'); workers see DIR and MITSUBA_REFS_CACHE at the "
                        "same paths (docs/cluster.md)")
    p.add_argument("--resume", metavar="JSON",
                   help="an earlier run's --json: keep its classes (files it found blocked are "
                        "loaded again) and its compare verdicts (compare the rest)")
    return p


def main(argv=None) -> int:
    """Classify, optionally compare, print the table, write the JSON; 2 for a bad folder."""
    args = build_parser().parse_args(argv)
    if not os.path.isdir(args.folder):
        print(f"error: {args.folder} is not a folder", file=sys.stderr)
        return 2
    try:
        rounds = tolerance_of(args) or None
    except RefsInputError as error:   # e.g. --max-spp without --tolerance: before any loading
        print(f"error: {error}", file=sys.stderr)
        return 2
    earlier = {}
    if args.resume:
        with open(args.resume) as f:
            earlier = json.load(f)
    previous = {e["file"]: Entry(**{k: v for k, v in e.items() if k != "compare"})
                for e in earlier.get("files", [])}
    entries, mitsuba_checked = classify(args.folder, args.timeout, not args.no_mitsuba, args.jobs,
                                        progress=not args.quiet, previous=previous)
    def save():
        if args.json:
            with open(args.json, "w") as f:
                json.dump({"folder": args.folder, "date": time.strftime("%Y-%m-%d"),
                           "mitsuba_checked": mitsuba_checked, **summary(entries),
                           "verdicts_by_plugin": verdicts_by_plugin(args.folder, entries),
                           "files": [asdict(e) for e in entries]}, f, indent=1)
    if args.compare:
        done = {e["file"]: e["compare"] for e in earlier.get("files", []) if e.get("compare")}
        try:
            compare_loaded(args.folder, entries, args.compare_timeout, args.resolution, done,
                           progress=not args.quiet, saved=save, only=tuple(args.compare_only),
                           convergence=not args.no_convergence, dask=args.dask, rounds=rounds)
        except ConnectionError as error:   # an unreachable or lost Dask scheduler
            save()
            print(f"error: {error}", file=sys.stderr)
            return 2
    print(table(entries, args.folder, mitsuba_checked))
    save()
    return 0


if __name__ == "__main__":
    sys.exit(main())
