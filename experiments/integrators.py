"""The lecture's four unbiased methods side by side: efficiency on every built-in scene.

``recursive`` (recursive Monte Carlo ray tracing, the slide's N rays per hit),
``path`` (path tracing with shadow rays and MIS), ``light`` (light tracing) and
``bdpt`` (bidirectional path tracing) each render every built-in scene
(:data:`mitsuba_refs.reference.config.BUILTIN_SCENES`, at the committed references' film size)
for the same CPU time on one core (progressive batches, :func:`experiments.caustics.equal_time_render`).
Each image is compared with the committed Mitsuba ``path`` reference of its scene
(4096 spp; every one of the four has the same expectation where it is unbiased):

``rmse``        sqrt(MSE), MSE = the image's own variance + whatever of the squared error
                against the reference (its noise removed) exceeds it
                (:func:`experiments.caustics.masked_mse`);
``spp``         samples (camera samples, or light paths, per pixel) reached in the time;
``efficiency``  1 / (MSE x seconds), and relative to ``path`` on the same scene
                (2x = the same error in half the time);
``agrees``      the harness's mean test at ``--alpha`` against the reference the test suite
                uses for that integrator (``path_nee``'s for ``recursive``, which has no MIS;
                splatting integrators without the whole-image components, docs/statistics.md).

Where an integrator cannot run on a scene (light paths cannot start on environment or
directional lights) the table says why instead of a number. A light tracer joins every
vertex to the camera, so it cannot image paths whose vertex next to the camera is a
Dirac one (a mirror or glass seen directly, ``...SE``): it converges to a different
image there, and its mean test says so.

Writes ``integrators.json`` (every number) into ``--out`` and prints the Markdown table
of docs/experiments.md.
Run: ``python -m experiments.integrators [--seconds 3] [--scenes cornell-box ...]``.
"""
from __future__ import annotations

import argparse
import sys

import numpy as np

from mitsuba_refs.reference.cache import get_reference
from mitsuba_refs.reference.config import BUILTIN_SCENES
from mitsuba_refs.report.wording import verdict_line
from mitsuba_refs.verdicts.estimators import CLOSEST_ESTIMATOR
from pathtracer import load_scene

from . import caustics, common

INTEGRATORS = ("recursive", "path", "light", "bdpt")


def build_parser():
    """The command line of the four-integrator comparison."""
    parser = argparse.ArgumentParser(
        prog="python -m experiments.integrators", description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scenes", nargs="+", default=list(BUILTIN_SCENES), choices=BUILTIN_SCENES,
                        metavar="SCENE", help="built-in scenes (default: all of BUILTIN_SCENES)")
    parser.add_argument("--integrators", nargs="+", default=list(INTEGRATORS), choices=INTEGRATORS,
                        help="integrators to compare (default: all four)")
    parser.add_argument("--seconds", type=float, default=3.0,
                        help="CPU seconds per integrator and scene (default: %(default)s)")
    parser.add_argument("--alpha", type=float, default=1e-3,
                        help="level of the mean test against the reference (default: %(default)s)")
    parser.add_argument("--seed", type=int, default=47000, help="base seed (default: %(default)s)")
    common.add_run_args(parser, "out/integrators", workers=False)
    return parser


def compare_one(scene, name, reference, test_reference, args, seed) -> dict:
    """One integrator on one scene at equal time: the row of the table, or why it cannot run.

    ``reference`` gives the errors; ``test_reference`` the mean test's verdict (the Mitsuba
    estimator the harness compares a mean-only ``name`` with,
    :data:`mitsuba_refs.verdicts.estimators.CLOSEST_ESTIMATOR`).
    """
    try:
        pool, points = caustics.equal_time_render(scene, name, args.seconds, seed)
    except ValueError as error:          # e.g. light paths cannot start on an environment map
        return dict(ran=False, reason=str(error))
    seconds, spp, mean, variance_of_mean = points[-1]
    everywhere = np.ones(mean.shape[:2], dtype=bool)
    errors = caustics.masked_mse(mean, variance_of_mean, reference, everywhere)
    test = caustics.verdict(pool, test_reference, everywhere, name, args.alpha)
    return dict(ran=True, seconds=seconds, spp=spp, **errors,
                efficiency=1.0 / (errors["mse"] * seconds), agree=bool(test.agree),
                p_value=test.p_value, verdict=verdict_line(test))


def run_scene(scene_name, args, bar) -> dict:
    """Every integrator on one scene against its Mitsuba ``path`` reference."""
    params = common.scene_params(scene_name, args.defines)
    reference = get_reference(scene_name, params, "path", render=False)
    scene = load_scene(scene_name, **params)
    rows = {}
    for k, name in enumerate(args.integrators):
        estimator = CLOSEST_ESTIMATOR.get(name, "path")
        test_reference = reference if estimator == "path" else get_reference(
            scene_name, params, estimator, render=False)
        rows[name] = compare_one(scene, name, reference, test_reference, args, args.seed + 1000 * k)
        bar.update()
    base = rows.get("path", {})
    for row in rows.values():
        if row["ran"] and base.get("ran"):
            row["efficiency_relative"] = row["efficiency"] / base["efficiency"]
    return dict(params=params, integrators=rows)


def cell(row: dict) -> str:
    """One table cell: RMSE, spp, relative efficiency, and the mean test's verdict."""
    if not row["ran"]:
        return "cannot run: " + row["reason"].split(" (")[0]
    text = f"{row['rmse']:.3g} / {row['spp']} / "
    relative = row.get("efficiency_relative")
    text += f"{relative:.2g}×" if relative is not None else f"{row['efficiency']:.3g}"
    return text + ("" if row["agree"] else " (mean test fails)")


def markdown(results, integrators) -> str:
    """The Markdown table: a row per scene, a column per integrator."""
    lines = ["| scene (film) | " + " | ".join(f"`{name}`" for name in integrators) + " |",
             "|---|" + "---|" * len(integrators)]
    for scene, result in results.items():
        size = f"{result['params']['width']}×{result['params']['height']}"
        lines.append(f"| `{scene}` ({size}) | "
                     + " | ".join(cell(result["integrators"][name]) for name in integrators) + " |")
    return "\n".join(lines)


def main(argv=None) -> int:
    """Render every scene with every integrator; write the JSON; print the table."""
    args = build_parser().parse_args(argv)
    if args.seconds <= 0:
        print("error: --seconds must be positive", file=sys.stderr)
        return 2
    results = common.run_with_progress(args.scenes, lambda key, bar: run_scene(key, args, bar),
                                       len(args.integrators), "integrators", not args.no_progress)
    if results is None:
        return 2
    path = common.write_json(common.out_dir(args.out) / "integrators.json",
                             dict(seconds=args.seconds, alpha=args.alpha, seed=args.seed,
                                  reference="Mitsuba path, 4096 spp", scenes=results))
    print(markdown(results, args.integrators))
    print(f"wrote {path}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
