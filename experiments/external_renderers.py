"""Renderers nobody here wrote, judged by ``check`` as a user brings them: the table of
docs/external.md ("Renderers people bring").

Every renderer runs through its documented ``--command`` recipe, at a square and a
non-square film, with the check's own seeds (no ``seed_offset``): what a user gets the first
time. One row per (renderer, film) with each verdict, its p-value, the relative bias and the
convergence rate; ``--json`` keeps them (default docs/data/external_renderers.json).

    python -m experiments.external_renderers
    python -m experiments.external_renderers --only mitsuba-ldsampler --cycles-python .venv-cycles/bin/python

Renderers: Mitsuba's command line with each of its samplers (``cornell-box`` against
``path``, the same estimator; sample counts each sampler renders exactly, as
``experiments.samplers`` plans them: Mitsuba rounds others up without a word in the image),
``pathtracer render`` (the same), the compiled smallpt of
examples/smallpt-cpp (``smallpt`` against ``path``: another estimator, so mean and
convergence), a Mitsuba Python plugin through examples/mitsuba-plugin (``cornell-box``
against ``path_bsdf``) and, with ``--cycles-python`` (a Python that has ``bpy``), Blender's
Cycles through examples/cycles.
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

from mitsuba_refs.errors import RefsInputError
from mitsuba_refs.external.check import check

from .bench import cpu_name
from .check_calibration import SAMPLERS, build_cpp, mitsuba_program
from .check_calibration import setup as calibration_setup
from .samplers import CHECK_PLANS

ROOT = Path(__file__).resolve().parent.parent
#: (label, width, height) of the films every renderer is checked at.
FILMS = (("square", 64, 64), ("non-square", 48, 40))


def renderers(folder: Path, cycles_python: str | None) -> dict:
    """name -> check keywords (scene, command, reference, ...) of every renderer."""
    table = {}
    for sampler in SAMPLERS:
        spp, replicas, ladder = CHECK_PLANS[sampler]
        table[f"mitsuba-{sampler}"] = {**calibration_setup("mitsuba", 0.0, folder, sampler),
                                       "spp": spp, "variance_replicas": replicas,
                                       "ladder": ladder, "ladder_replicas": 4}
    table["pathtracer"] = calibration_setup("pathtracer", 0.0, folder)
    binary = build_cpp(folder)
    table["smallpt-cpp"] = {
        "scene": "smallpt", "reference": "path", "output_suffix": ".pfm", "same_estimator": False,
        "command": f"{binary} --width {{width}} --height {{height}} --spp {{spp}} --seed {{seed}} "
                   "--max-depth {max_depth} --out {out}"}
    table["mitsuba-plugin"] = {
        "scene": "cornell-box", "reference": "path_bsdf", "same_estimator": True,
        "command": f"{sys.executable} {ROOT / 'examples/mitsuba-plugin/render.py'} {{scene}} "
                   "--plugin mitsuba_refs.reference.integrators --integrator lecture_path_bsdf "
                   "--max-depth {max_depth} --spp {spp} --seed {seed} {defines} -o {out}"}
    if cycles_python:
        table["cycles"] = {
            "scene": "cornell-box", "reference": "path", "same_estimator": False,
            "command": f"{cycles_python} {ROOT / 'examples/cycles/render.py'} {{scene}} "
                       "--spp {spp} --seed {seed} --width {width} --height {height} "
                       "--max-depth {max_depth} -o {out}"}
    return table


def row(name: str, film: tuple, keywords: dict, jobs: int) -> dict:
    """One check of ``name`` at ``film``, as numbers."""
    label, width, height = film
    keywords = dict(keywords)
    scene = keywords.pop("scene")
    start = time.perf_counter()
    try:
        result = check(scene, **keywords, resolution=(width, height), bounces=False, jobs=jobs)
    except RefsInputError as error:       # a refusal is a row too: it is what the user meets
        return {"renderer": name, "film": f"{width}x{height}", "refused": str(error)}
    law = result.convergence
    return {
        "renderer": name, "film": f"{width}x{height}", "shape": label, "scene": scene,
        "agree": bool(result.agree),
        "mean_p": result.mean.p_value, "rel_bias": result.mean.rel_bias,
        "rel_bias_ci": list(result.mean.rel_bias_ci),
        "variance_p": result.variance.p_value if result.variance is not None else None,
        "variance_ratio": result.variance.ratio if result.variance is not None else None,
        "variance_skipped": result.variance_skipped,
        "convergence_p": law.p_value if law is not None else None,
        "convergence_passed": law.passed if law is not None else None,
        "mse_slope": law.slope if law is not None else None,
        "report": result.report(), "runs": len(result.runs),
        "seconds": round(time.perf_counter() - start, 1)}


def main(argv=None) -> int:
    """Run every renderer at every film; print the table; exit code 0."""
    parser = argparse.ArgumentParser(prog="python -m experiments.external_renderers",
                                     description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--only", action="append", default=None, help="renderer(s) to run")
    parser.add_argument("--cycles-python", default=None, help="a Python with bpy, for Cycles")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--json", default=str(ROOT / "docs/data/external_renderers.json"))
    args = parser.parse_args(argv)
    mitsuba_program()                       # fail early without Mitsuba's command line
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        for name, keywords in renderers(Path(folder), args.cycles_python).items():
            if args.only and name not in args.only:
                continue
            for film in FILMS:
                rows.append(row(name, film, keywords, args.jobs))
                entry = rows[-1]
                verdict = ("refused: " + entry["refused"] if "refused" in entry
                           else ("AGREES" if entry["agree"] else "DISAGREES"))
                print(f"{name:22s} {entry['film']:6s} {verdict}", flush=True)
    Path(args.json).parent.mkdir(parents=True, exist_ok=True)
    Path(args.json).write_text(json.dumps({"cpu": cpu_name(), "rows": rows}, indent=1))
    print(f"written {args.json} ({cpu_name()})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
