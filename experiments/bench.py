"""Benchmark: camera paths per second per process, ``pathtracer`` against Mitsuba 3.

Run ``python -m experiments.bench [--quick] [--json OUT]``. In one run, on the
same scene files at the same resolution and spp:

* ``pathtracer`` (the integrator named in :data:`CASES`), Mitsuba
  ``scalar_rgb`` and Mitsuba ``llvm_ad_rgb`` (its ``path`` integrator), each in
  a fresh child process pinned to one core, so every figure is *per process*;
  Mitsuba's first render (llvm_ad_rgb: with an empty kernel cache, so it
  includes the JIT compilation) is reported apart from the steady state (the
  best of the repeats);
* the scaling of ``pathtracer`` from one to two worker processes (all cores);
* the peak memory of a ``pathtracer`` render at 1024 x 1024, 64 spp (two
  processes): the peak over time of the summed proportional set size (PSS)
  of the parent and its workers, sampled every 20 ms, and each one's peak RSS.

Each timing is repeated (``--repeats``); the table shows the best, and the JSON
holds every repeat, so the spread can be judged on a shared machine. Mitsuba
is optional: without it (or without a working libLLVM) those columns say why.
"""
from __future__ import annotations

import argparse
import contextlib
import datetime
import json
import os
import platform
import resource
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

from pathtracer import load_scene, render
from pathtracer.core.machine import this_machine
from pathtracer.integrators import INTEGRATORS
from pathtracer.render import sizes
from pathtracer.render.classes import class_batch, render_classes
from pathtracer.shapes import intersect

ROOT = Path(__file__).resolve().parents[1]
SCENES = ROOT / "pathtracer" / "data" / "scenes"

#: (label, scene file stem, our integrator, Mitsuba's integrator, aspect height/width).
CASES = [
    ("cornell-box", "cornell-box", "path", "path", 1.0),
    ("smallpt", "smallpt", "smallpt", "path", 0.75),
    ("mesh", "mesh", "path", "path", 1.0),
]

#: The speed targets (issue 28; issue 15's were 0.6, 0.6 and 0.35): the least ratio of our
#: paths per CPU-second to Mitsuba ``scalar_rgb``'s, per scene.
TARGETS = {"cornell-box": 0.8, "smallpt": 0.8, "mesh": 0.5}

#: The integrators that still run batch by batch, timed as users time them: (label, scene,
#: ours, Mitsuba's counterpart or None, height / width). ``pathclass`` is
#: :func:`pathtracer.render.classes.render_classes` with :data:`PATH_CLASSES`.
BATCH_CASES = [
    ("direct", "cornell-box", "direct", "direct", 1.0),
    ("recursive", "cornell-box", "recursive", None, 1.0),
    ("pathclass", "cornell-box", "pathclass", None, 1.0),
    ("light", "cornell-box", "light", "ptracer", 1.0),
    ("bdpt", "cornell-box", "bdpt", None, 1.0),
    ("volpath", "media-box", "volpath", "volpath", 1.0),
    ("volpath_phase", "media-box", "volpath_phase", None, 1.0),
]
#: Path classes of the ``pathclass`` row: everything, and three classes of it.
PATH_CLASSES = ["L.*E", "LDE", "LS+DE", "L.*SE"]
#: The volume integrators' target: at least this fraction of ``path``'s paths per CPU-second on
#: the Cornell box at the same resolution and spp (a scene of the same size).
VOLUME_TARGET = 0.5
VOLUME_INTEGRATORS = ("volpath", "volpath_phase")


# ---------------------------------------------------------------------------------------
# measurements, each in a child process


def _pin(core: int | None) -> None:
    if core is not None and hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {core})


def _peak_rss_mb() -> tuple[float, float]:
    """Peak resident set size of this process and of its largest waited-for child, MB."""
    own = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    child = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024.0
    return own, child


def _pss_mb(pid: int) -> float:
    """Proportional set size of one process, MB (pages shared by k processes count 1/k)."""
    try:
        with open(f"/proc/{pid}/smaps_rollup") as f:
            for line in f:
                if line.startswith("Pss:"):
                    return int(line.split()[1]) / 1024.0
    except OSError:   # the process has just exited
        pass
    return 0.0


def _descendants(pid: int) -> list[int]:
    """``pid`` and every process below it (from /proc/PID/task/*/children)."""
    found, todo = [], [pid]
    while todo:
        p = todo.pop()
        found.append(p)
        try:
            for task in os.listdir(f"/proc/{p}/task"):
                with open(f"/proc/{p}/task/{task}/children") as f:
                    todo.extend(int(c) for c in f.read().split())
        except OSError:
            pass
    return found


class PeakPss:
    """Samples the summed PSS of this process and its children every ``interval`` seconds.

    The sum of PSS over a process tree is its true footprint: forked workers'
    pages shared with the parent are counted once, unlike a sum of RSS.
    """

    def __init__(self, interval: float = 0.02):
        self.interval, self.peak_mb, self.peak_processes = interval, 0.0, 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def sample(self):
        pids = _descendants(os.getpid())
        total = sum(_pss_mb(p) for p in pids)
        if total > self.peak_mb:
            self.peak_mb, self.peak_processes = total, len(pids)

    def _run(self):
        while not self._stop.wait(self.interval):
            self.sample()

    def __enter__(self):
        self.sample()
        self._thread.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._thread.join()
        self.sample()


def _render_case(scene, integrator: str, spp: int, seed: int, processes: int) -> None:
    """One timed render: ``pathtracer.render``, or the path-class render for ``pathclass``."""
    if integrator == "pathclass":
        render_classes(scene, PATH_CLASSES, spp=spp, seed=seed, processes=processes)
    else:
        render(scene, integrator=integrator, spp=spp, seed=seed, processes=processes,
               progress=False)


def warmed_scene(stem: str, integrator: str, width: int, height: int):
    """The benchmark scene ``stem`` after one warm-up render (builds the accelerator, touches
    every code path once), so that timings and profiles see the steady state."""
    scene = load_scene(str(SCENES / f"{stem}.xml"), width=width, height=height)
    _render_case(scene, integrator, 1, 99, 1)
    return scene


def measure_ours(spec: dict) -> dict:
    """Time ``pathtracer.render`` on one scene (``spec``: see :func:`main`)."""
    _pin(spec.get("core"))
    scene = warmed_scene(spec["scene"], spec["integrator"], spec["width"], spec["height"])
    processes = spec.get("processes", 1)
    times, cpu = [], []
    # Sampling /proc every 20 ms takes CPU from the workers: only in the memory run.
    with (PeakPss() if spec.get("memory") else contextlib.nullcontext()) as pss:
        for r in range(spec["repeats"]):
            start, start_cpu = time.perf_counter(), time.process_time()
            _render_case(scene, spec["integrator"], spec["spp"], r, processes)
            times.append(time.perf_counter() - start)
            cpu.append(time.process_time() - start_cpu)
    paths = spec["width"] * spec["height"] * spec["spp"]
    own, child = _peak_rss_mb()
    if spec["integrator"] == "pathclass":
        batch = class_batch(len(PATH_CLASSES), processes)
    else:
        batch = sizes.render_batch(processes, INTEGRATORS[spec["integrator"]].splats)
    found = dict(times=times, cpu=cpu, paths=paths, rss_mb=own, child_rss_mb=child,
                 sizes=sizes.describe(batch, intersect.prepare(scene))[1:])
    if pss is not None:
        found.update(pss_mb=pss.peak_mb, pss_processes=pss.peak_processes)
    return found


def measure_mitsuba(spec: dict) -> dict:
    """Time ``mi.render`` on one scene in variant ``spec['variant']``, one thread."""
    _pin(spec.get("core"))
    import drjit as dr  # Mitsuba's drjit: optional and heavy, imported where it renders
    import mitsuba as mi
    mi.set_variant(spec["variant"])
    try:
        dr.set_thread_count(1)
    except Exception:   # pragma: no cover - older drjit
        pass
    scene = mi.load_file(str(SCENES / f"{spec['scene']}.xml"), width=spec["width"],
                         height=spec["height"], spp=spec["spp"])
    integrator = mi.load_dict({"type": spec["mi_integrator"]})
    times, cpu = [], []
    for r in range(spec["repeats"] + 1):   # the first render includes JIT compilation
        start, start_cpu = time.perf_counter(), time.process_time()
        image = mi.render(scene, integrator=integrator, spp=spec["spp"], seed=r)
        _ = image.numpy() if hasattr(image, "numpy") else image   # forces evaluation
        times.append(time.perf_counter() - start)
        cpu.append(time.process_time() - start_cpu)
    paths = spec["width"] * spec["height"] * spec["spp"]
    return dict(first=times[0], times=times[1:], cpu=cpu[1:], paths=paths)


def _child(kind: str, spec: dict, timeout: float) -> dict:
    """Run a measurement in a fresh interpreter; its result or {'error': why}."""
    cmd = [sys.executable, "-m", "experiments.bench", "--_child", kind, json.dumps(spec)]
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    with tempfile.TemporaryDirectory() as home:
        if spec.get("variant") == "llvm_ad_rgb":
            # Dr.Jit keeps compiled kernels in ~/.drjit: an empty home makes the first
            # render pay the real JIT compilation, as on a fresh machine.
            env["HOME"] = home
        try:
            proc = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True,
                                  timeout=timeout)
        except subprocess.TimeoutExpired:
            return {"error": f"timed out after {timeout:.0f} s"}
    for line in reversed(proc.stdout.splitlines()):
        if line.startswith("{"):
            return json.loads(line)
    tail = (proc.stderr or proc.stdout).strip().splitlines()
    return {"error": f"exit {proc.returncode}: " + (tail[-1] if tail else "no output")}


# ---------------------------------------------------------------------------------------
# the run


def _rate(result: dict, best: bool = True) -> float | None:
    if not result or "error" in result or not result.get("times"):
        return None
    t = min(result["times"]) if best else statistics.median(result["times"])
    return result["paths"] / t


def _cpu_rate(result: dict) -> float | None:
    """Paths per CPU-second (best repeat): robust to other jobs on a shared machine."""
    if not result or "error" in result or not result.get("cpu"):
        return None
    return result["paths"] / max(min(result["cpu"]), 1e-9)


def _spread(result: dict) -> str:
    if not result or "error" in result or len(result.get("times", [])) < 2:
        return ""
    rates = sorted(result["paths"] / t for t in result["times"])
    return f"{rates[0] / 1e3:.0f}-{rates[-1] / 1e3:.0f}k"


def _case_spec(args, stem: str, aspect: float) -> dict:
    """A measurement of scene ``stem`` at the run's width, spp and repeats (height: width x
    ``aspect``), pinned to ``--core``."""
    return dict(scene=stem, width=args.resolution, height=max(1, int(round(args.resolution * aspect))),
                spp=args.spp, repeats=args.repeats, core=args.core)


def run(args) -> dict:
    """Time every scene in the tracer and in Mitsuba; the report as a dict."""
    res = args.resolution
    report = dict(
        date=datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
        machine=f"{platform.machine()}, {this_machine().describe()},"
                f" Python {platform.python_version()}",
        resolution=res, spp=args.spp, repeats=args.repeats, scenes={})
    mitsuba_variants = [] if args.no_mitsuba else ["scalar_rgb", "llvm_ad_rgb"]
    for label, stem, ours, theirs, aspect in CASES:
        if args.scenes is not None and label not in args.scenes:
            continue
        spec = _case_spec(args, stem, aspect)
        row = dict(integrator=ours, mitsuba_integrator=theirs, width=spec["width"],
                   height=spec["height"])
        _log(f"{label}: pathtracer {ours}")
        row["ours"] = _child("ours", dict(spec, integrator=ours), args.timeout)
        for variant in mitsuba_variants:
            _log(f"{label}: mitsuba {variant} {theirs}")
            row[variant] = _child("mitsuba", dict(spec, variant=variant, mi_integrator=theirs),
                                  args.timeout)
        report["scenes"][label] = row
    report["batch"] = {}
    for label, stem, ours, theirs, aspect in BATCH_CASES if args.batch else ():
        if args.scenes is not None and label not in args.scenes:
            continue
        spec = _case_spec(args, stem, aspect)
        row = dict(scene=stem, integrator=ours, mitsuba_integrator=theirs,
                   width=spec["width"], height=spec["height"])
        _log(f"batch {label}: pathtracer {ours} on {stem}")
        row["ours"] = _child("ours", dict(spec, integrator=ours), args.timeout)
        if theirs and not args.no_mitsuba:
            # scalar_rgb only: the batch integrators are compared with the compiled renderer
            # at its one-path-at-a-time speed, as the main table's targets are.
            _log(f"batch {label}: mitsuba scalar_rgb {theirs}")
            row["scalar_rgb"] = _child("mitsuba", dict(spec, variant="scalar_rgb",
                                                       mi_integrator=theirs), args.timeout)
        report["batch"][label] = row
    if not args.no_scaling:
        # 4x the spp of the table: forking the workers and merging in the parent are fixed
        # costs that a short render would charge to the scaling.
        spec = dict(scene="cornell-box", width=res, height=res, spp=args.spp * 4,
                    repeats=args.repeats, integrator="path", core=None)
        _log("scaling: 1 and 2 processes")
        one = _child("ours", dict(spec, processes=1), args.timeout)
        two = _child("ours", dict(spec, processes=2), args.timeout)
        report["scaling"] = dict(one=one, two=two)
    if not args.no_memory:
        mres, mspp = args.memory
        spec = dict(scene="cornell-box", width=mres, height=mres, spp=mspp, repeats=1,
                    integrator="path", processes=2, core=None, memory=True)
        _log(f"memory: {mres}x{mres}, {mspp} spp, 2 processes")
        report["memory"] = _child("ours", spec, max(args.timeout, 3600))
    summarise(report)
    return report


def cpu_name() -> str:
    """The CPU's model name (every speed figure names its CPU)."""
    return this_machine().cpu


def _log(text: str) -> None:
    print(f"[bench] {text}", file=sys.stderr, flush=True)


def summarise(report: dict) -> None:
    """Add the derived figures (rates, ratios, targets met) to ``report``."""
    for label, row in report["scenes"].items():
        ours = _rate(row["ours"])
        scalar, llvm = _rate(row.get("scalar_rgb")), _rate(row.get("llvm_ad_rgb"))
        row["rate"] = dict(ours=ours, scalar_rgb=scalar, llvm_ad_rgb=llvm)
        row["cpu_rate"] = {k: _cpu_rate(row.get(k)) for k in ("ours", "scalar_rgb", "llvm_ad_rgb")}
        # Ratios of paths per CPU-second: on a shared machine the wall-clock figures of
        # runs made minutes apart see different loads; CPU time does not.
        cpu = row["cpu_rate"]
        ours_c, scalar_c, llvm_c = cpu["ours"], cpu["scalar_rgb"], cpu["llvm_ad_rgb"]
        row["ratio"] = dict(scalar_rgb=ours_c / scalar_c if ours_c and scalar_c else None,
                            llvm_ad_rgb=ours_c / llvm_c if ours_c and llvm_c else None)
        rs = row["ratio"]["scalar_rgb"]
        row["target"] = f"ours >= {TARGETS[label]} x scalar"
        row["target_met"] = None if rs is None else rs >= TARGETS[label]
    path_rate = report["scenes"].get("cornell-box", {}).get("cpu_rate", {}).get("ours")
    for label, row in report.get("batch", {}).items():
        ours, scalar = _cpu_rate(row["ours"]), _cpu_rate(row.get("scalar_rgb"))
        row["cpu_rate"] = dict(ours=ours, scalar_rgb=scalar)
        row["ratio"] = dict(scalar_rgb=ours / scalar if ours and scalar else None)
        # Our own path tracer on the Cornell box at the same size: how much a user pays for
        # choosing this integrator.
        row["vs_path"] = ours / path_rate if ours and path_rate else None
        if row["integrator"] in VOLUME_INTEGRATORS:
            row["target"] = f"ours >= {VOLUME_TARGET} x our path (cornell-box, same size)"
            row["target_met"] = None if row["vs_path"] is None else row["vs_path"] >= VOLUME_TARGET
        else:
            row["target"], row["target_met"] = None, None
    if "scaling" in report:
        one, two = _rate(report["scaling"]["one"]), _rate(report["scaling"]["two"])
        report["scaling"]["rate_one"], report["scaling"]["rate_two"] = one, two
        report["scaling"]["speedup"] = two / one if one and two else None
    if "memory" in report and "error" not in report["memory"]:
        m = report["memory"]
        m["rss_sum_mb"] = m["rss_mb"] + m["child_rss_mb"] * 2  # parent + both workers (bound)
        # The sampled PSS of the whole tree; a sum of RSS counts shared pages twice.
        m["peak_mb"] = m.get("pss_mb") or m["rss_sum_mb"]
        m["target_met"] = m["peak_mb"] <= 300


def _fmt(x, unit=1e3, digits=0, suffix="k") -> str:
    return "n/a" if x is None else f"{x / unit:.{digits}f}{suffix}"


def _num(x) -> str:
    return "n/a" if x is None else f"{x:.2f}"


def table(report: dict) -> str:
    """The results as a Markdown table (and a few lines below it)."""
    lines = [f"Benchmark {report['date']} on {report['machine']}; "
             f"{report['spp']} spp, width {report['resolution']}, best of {report['repeats']}; "
             "camera paths/s per process (1 core each), wall clock; in brackets paths per "
             "CPU-second (less sensitive to other jobs on the machine).", "",
             "| scene | ours (integrator) | Mitsuba scalar_rgb | Mitsuba llvm_ad_rgb (JIT, first render) "
             "| ours / scalar (CPU) | ours / llvm (CPU) | target | met |",
             "|---|---|---|---|---|---|---|---|"]
    for label, row in report["scenes"].items():
        rate = row["rate"]
        llvm = row.get("llvm_ad_rgb") or {}
        jit = "" if "first" not in llvm else \
            f" ({llvm['first'] - min(llvm['times']):.2f} s, {llvm['first']:.2f} s)"
        if "error" in llvm:
            jit = f" ({llvm['error'][:60]})"
        scalar = row.get("scalar_rgb") or {}
        scalar_err = f" ({scalar['error'][:60]})" if "error" in scalar else ""
        ours_err = f" ({row['ours']['error'][:80]})" if "error" in row["ours"] else ""
        ratio = row["ratio"]
        met = {True: "yes", False: "**no**", None: "n/a"}[row["target_met"]]
        lines.append(
            f"| {label} ({row['width']}x{row['height']}) | {_fmt(rate['ours'])} "
            f"[{_fmt(row['cpu_rate']['ours'])}] ({row['integrator']}, "
            f"spread {_spread(row['ours'])}){ours_err} | {_fmt(rate['scalar_rgb'])} "
            f"[{_fmt(row['cpu_rate']['scalar_rgb'])}]{scalar_err} | "
            f"{_fmt(rate['llvm_ad_rgb'])} [{_fmt(row['cpu_rate']['llvm_ad_rgb'])}]{jit} | "
            f"{_num(ratio['scalar_rgb'])} | {_num(ratio['llvm_ad_rgb'])} | "
            f"{row['target']} | {met} |")
    chosen = sorted({f"{label}: " + "; ".join(row["ours"]["sizes"])
                     for label, row in report["scenes"].items() if "sizes" in row["ours"]})
    if chosen:
        lines += ["", "Sizes chosen from the machine (pathtracer render --verbose): "
                  + " | ".join(chosen) + "."]
    if report.get("batch"):
        lines += ["", "Integrators that run batch by batch (paths per CPU-second, best repeat; "
                  "light and BDPT: light paths or camera samples per pixel x pixels):", "",
                  "| integrator (scene) | ours | Mitsuba scalar_rgb (its counterpart) "
                  "| ours / scalar | ours / our path (cornell-box) | target | met |",
                  "|---|---|---|---|---|---|---|"]
        for label, row in report["batch"].items():
            theirs = row.get("mitsuba_integrator")
            scalar = row.get("scalar_rgb") or {}
            counterpart = "none" if not theirs else \
                (f"{scalar['error'][:60]}" if "error" in scalar else
                 f"{_fmt(row['cpu_rate']['scalar_rgb'])} ({theirs})")
            ours_err = f" ({row['ours']['error'][:80]})" if "error" in row["ours"] else ""
            met = {True: "yes", False: "**no**", None: "n/a"}[row["target_met"]]
            lines.append(
                f"| {label} ({row['scene']}, {row['width']}x{row['height']}) | "
                f"{_fmt(row['cpu_rate']['ours'])}{ours_err} | {counterpart} | "
                f"{_num(row['ratio']['scalar_rgb'])} | {_num(row['vs_path'])} | "
                f"{row['target'] or '-'} | {met} |")
    if "scaling" in report:
        s = report["scaling"]
        sp = s.get("speedup")
        lines.append("")
        lines.append(f"Scaling (cornell-box, path, {4 * report['spp']} spp, all cores): 1 process "
                     f"{_fmt(s.get('rate_one'))} paths/s, "
                     f"2 processes {_fmt(s.get('rate_two'))} paths/s: "
                     f"{_num(sp)}x (target >= 1.8x: "
                     f"{'n/a' if sp is None else ('yes' if sp >= 1.8 else 'no')}).")
    if "memory" in report:
        m = report["memory"]
        if "error" in m:
            lines.append(f"Peak memory: {m['error']}")
        else:
            lines.append(f"Peak memory (cornell-box path, {m['paths']:,} paths, 2 processes): "
                         f"{m['peak_mb']:.0f} MB summed PSS of the {m.get('pss_processes', 0)} "
                         f"processes (target <= 300 MB: {'yes' if m['target_met'] else 'no'}); "
                         f"peak RSS parent {m['rss_mb']:.0f} MB, worker {m['child_rss_mb']:.0f} MB "
                         f"(their sum {m['rss_sum_mb']:.0f} MB counts shared pages twice); "
                         f"{m['paths'] / min(m['times']) / 1e3:.0f}k paths/s.")
    return "\n".join(lines)


def main(argv=None) -> int:
    """Run the benchmark (command line) and write its report; exit code."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true",
                        help="tiny renders, one repeat, small memory run (a smoke test)")
    parser.add_argument("--json", type=Path, default=None, help="write the results here")
    parser.add_argument("--resolution", type=int, default=None,
                        help="film width (default 128; --quick: 32)")
    parser.add_argument("--spp", type=int, default=None, help="samples per pixel (default 16; --quick: 4)")
    parser.add_argument("--repeats", type=int, default=None,
                        help="timed renders per measurement (default 3; --quick: 1)")
    parser.add_argument("--core", type=int, default=0, help="core the per-process runs are pinned to")
    parser.add_argument("--memory", type=int, nargs=2, default=None, metavar=("RES", "SPP"),
                        help="resolution and spp of the peak-memory render (default 1024 64; "
                             "--quick: 128 2)")
    parser.add_argument("--scenes", type=lambda text: [x for x in text.split(",") if x],
                        default=None, help="comma-separated subset of the scenes ('' for none)")
    parser.add_argument("--no-mitsuba", action="store_true", help="skip Mitsuba")
    parser.add_argument("--no-scaling", action="store_true", help="skip the 1 -> 2 process run")
    parser.add_argument("--no-batch", dest="batch", action="store_false",
                        help="skip the integrators that run batch by batch (BATCH_CASES)")
    parser.add_argument("--no-memory", action="store_true", help="skip the peak-memory run")
    parser.add_argument("--timeout", type=float, default=900, help="seconds per measurement")
    parser.add_argument("--_child", nargs=2, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args._child:
        kind, spec = args._child
        result = (measure_ours if kind == "ours" else measure_mitsuba)(json.loads(spec))
        print("\n" + json.dumps(result))  # on a line of its own: a progress bar may precede it
        return 0
    defaults = dict(resolution=(128, 32), spp=(16, 4), repeats=(3, 1), memory=((1024, 64), (128, 2)))
    for name, (full, quick) in defaults.items():
        if getattr(args, name) is None:
            setattr(args, name, quick if args.quick else full)
    if args.core is not None and hasattr(os, "sched_getaffinity") \
            and args.core not in os.sched_getaffinity(0):
        args.core = None
    report = run(args)
    print(table(report))
    write_report(report, args.json)
    return 0


def write_report(report: dict, path: Path | None) -> None:
    """Write ``report`` as JSON to ``path`` (folders made), and say so; nothing without a path."""
    if path:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(report, indent=1))
        print(f"wrote {path}")


if __name__ == "__main__":
    sys.exit(main())
