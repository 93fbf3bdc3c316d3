"""Calibration and power of ``mitsuba-refs check`` with a real external renderer.

Runs the whole check (the renderer as separate processes, its images read from files) many
times with independent seeds (``seed_offset``) and records every verdict's p-value. From them:
the false-failure rate of each verdict at several levels, with exact (Clopper-Pearson) 95 %
intervals, for a correct renderer; with ``--bias B`` the renderer's images are scaled by
``1 + B`` and the rate is the verdict's power against that bias.

    python -m experiments.check_calibration --renderer cpp --seeds 200
    python -m experiments.check_calibration --renderer pathtracer --seeds 200 --no-convergence
    python -m experiments.check_calibration --renderer cpp --seeds 100 --bias 0.02 --no-convergence
    python -m experiments.check_calibration --renderer cpp --seeds 50 --bias 0.02 --spp 1024 --no-convergence
    python -m experiments.check_calibration --renderer mitsuba --seeds 100 --no-convergence
    python -m experiments.check_calibration --renderer mitsuba --sampler multijitter --seeds 100

Renderers: ``cpp`` is examples/smallpt-cpp (built here with ``c++``) on the ``smallpt`` scene
against Mitsuba's ``path_bsdf`` (mean and convergence; another estimator, so no variance
verdict); ``pathtracer`` is ``pathtracer render`` on ``cornell-box`` against ``path``, the
same estimator (mean and variance from one run with variance channels); ``mitsuba`` is
Mitsuba's own command line (docs/external.md's recipe, ``scalar_rgb``) on ``cornell-box``
against ``path``, the same estimator, with ``--sampler`` (independent, stratified,
multijitter, orthogonal, ldsampler) set in a copy of the scene file the renderer reads.
Results go to ``--json`` (default docs/data/check_calibration_<renderer>[_<sampler>][_bias].json).
"""
from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from mitsuba_refs.external.check import check
from mitsuba_refs.stats import clopper_pearson
from pathtracer.scene.load import scene_file

from .bench import cpu_name

ROOT = Path(__file__).resolve().parent.parent
LEVELS = (0.05, 0.01, 1e-3)
#: Mitsuba 3's samplers (``--renderer mitsuba --sampler``).
SAMPLERS = ("independent", "stratified", "multijitter", "orthogonal", "ldsampler")
SCALE = Path(__file__).with_name("scale_pfm.py")


def build_cpp(folder: Path) -> Path:
    """examples/smallpt-cpp built with the system compiler."""
    binary = folder / "smallpt"
    subprocess.run(["c++", "-O2", "-std=c++17", "-pthread", "-o", str(binary),
                    str(ROOT / "examples/smallpt-cpp/smallpt.cpp")], check=True)
    return binary


def mitsuba_program() -> str:
    """Mitsuba's command-line renderer: beside this Python, else on PATH."""
    beside = Path(sys.executable).parent / "mitsuba"
    found = str(beside) if beside.is_file() else shutil.which("mitsuba")
    if found is None:
        raise SystemExit("--renderer mitsuba needs Mitsuba's command line (pip install mitsuba)")
    return found


def setup(renderer: str, bias: float, folder: Path, sampler: str = "independent") -> dict:
    """Scene, command and check options of ``renderer`` (``sampler``: Mitsuba's)."""
    if renderer == "cpp":
        binary = build_cpp(folder)
        render = (f"{binary} --width {{width}} --height {{height}} --spp {{spp}} --seed {{seed}} "
                  f"--max-depth {{max_depth}}")
        if bias:
            command = (f"{render} --out {{out}}.raw.pfm && {sys.executable} {SCALE} "
                       f"{{out}}.raw.pfm {{out}} {1 + bias!r}")
        else:
            command = f"{render} --out {{out}}"
        return {"scene": "smallpt", "command": command, "reference": "path_bsdf",
                "output_suffix": ".pfm", "same_estimator": False}
    if bias:
        raise SystemExit("--bias is measured with --renderer cpp (its PFM images are scaled)")
    if renderer == "mitsuba":
        scene_copy = folder / f"cornell-box-{sampler}.xml"
        text = Path(scene_file("cornell-box")).read_text()
        if text.count('<sampler type="independent">') != 1:
            raise SystemExit("cornell-box.xml no longer has one independent sampler to replace")
        scene_copy.write_text(text.replace('<sampler type="independent">',
                                           f'<sampler type="{sampler}">'))
        command = (f"{mitsuba_program()} -m scalar_rgb -o {{out}} {{defines}} -D spp={{spp}} "
                   "-D seed={seed} -D max_depth={max_depth} {scene}")
        return {"scene": "cornell-box", "command": command, "reference": "path",
                "output_suffix": ".exr", "same_estimator": True, "renderer_scene": scene_copy}
    command = (f"{sys.executable} -m pathtracer.cli render {{scene}} --resolution {{width}}x{{height}} "
               "--spp {spp} --seed {seed} --max-depth {max_depth} -o {out}")
    return {"scene": "cornell-box", "command": command, "reference": "path",
            "output_suffix": ".exr", "same_estimator": True}


def main(argv=None) -> int:
    """Run the repetitions and print the rates (command line); exit code 0."""
    parser = argparse.ArgumentParser(prog="python -m experiments.check_calibration", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--renderer", choices=("cpp", "pathtracer", "mitsuba"), default="cpp")
    parser.add_argument("--sampler", choices=SAMPLERS, default="independent",
                        help="Mitsuba's sampler (--renderer mitsuba)")
    parser.add_argument("--seeds", type=int, default=200, help="independent checks")
    parser.add_argument("--first-seed", type=int, default=1, help="seed_offset of the first check")
    parser.add_argument("--bias", type=float, default=0.0, help="relative bias of the images")
    parser.add_argument("--spp", type=int, default=64, help="samples of the mean/variance render")
    parser.add_argument("--no-convergence", action="store_true")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--json", default=None)
    args = parser.parse_args(argv)
    suffix = (f"_{args.sampler}" if args.renderer == "mitsuba" else "")
    suffix += (f"_bias{args.bias:g}" if args.bias else "") + (f"_spp{args.spp}" if args.spp != 64 else "")
    out = Path(args.json or ROOT / f"docs/data/check_calibration_{args.renderer}{suffix}.json")
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        settings = setup(args.renderer, args.bias, Path(folder), args.sampler)
        scene = settings.pop("scene")
        start = time.perf_counter()
        for k in range(args.seeds):
            result = check(scene, **settings, spp=args.spp, convergence=not args.no_convergence,
                           bounces=False,
                           seed_offset=args.first_seed + k, jobs=args.jobs)
            rows.append({"seed_offset": args.first_seed + k,
                         "mean": result.mean.p_value,
                         "variance": result.variance.p_value if result.variance else None,
                         "convergence": result.convergence.p_value if result.convergence else None,
                         "runs": len(result.runs),
                         "cpu_seconds": sum(run["cpu_seconds"] for run in result.runs),
                         "seconds": result.seconds})
            print(f"{k + 1}/{args.seeds}: " + ", ".join(
                f"{name} p={rows[-1][name]:.3g}" for name in ("mean", "variance", "convergence")
                if rows[-1][name] is not None), flush=True)
        elapsed = time.perf_counter() - start
    summary = summarise(rows)
    record = {"renderer": args.renderer, "sampler": args.sampler, "scene": scene, "bias": args.bias, "spp": args.spp,
              "seeds": args.seeds,
              "cpu": cpu_name(), "seconds": round(elapsed, 1), "summary": summary, "checks": rows}
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(record, indent=1))
    for name, rates in summary.items():
        for level, entry in rates.items():
            print(f"{name:12s} alpha={level}: {entry['rejected']}/{entry['n']} rejected "
                  f"[{entry['ci'][0]:.4f}, {entry['ci'][1]:.4f}]")
    print(f"{args.seeds} checks in {elapsed:.0f} s on {cpu_name()}; written {out}")
    return 0


def summarise(rows) -> dict:
    """Per verdict and level: rejections, checks and the 95 % Clopper-Pearson interval."""
    summary = {}
    for name in ("mean", "variance", "convergence"):
        values = [row[name] for row in rows if row[name] is not None]
        if not values:
            continue
        summary[name] = {}
        for level in LEVELS:
            rejected = sum(p <= level for p in values)
            low, high = clopper_pearson(rejected, len(values))
            summary[name][str(level)] = {"rejected": rejected, "n": len(values),
                                         "ci": [round(low, 5), round(high, 5)]}
    return summary



if __name__ == "__main__":
    sys.exit(main())
