"""``mitsuba-refs compare``: one integrator against Mitsuba on one scene, with verdicts.

Exit code 0 when every verdict agrees, 1 when one disagrees, 3 when the mean is
INCONCLUSIVE (``--tolerance``: the budget ran out before a decision), 2 on bad input
(unknown scene or integrator, malformed -D, an option out of range, a scene
our tracer or Mitsuba refuses, a reference that is neither cached nor
renderable), 130 when interrupted. The scene is loaded by our tracer and
every option checked *before* a reference is looked up or rendered, so bad
input fails in about a second, with the tracer's own message.
"""
from __future__ import annotations

import sys
import warnings

from pathtracer import INTEGRATORS
from pathtracer.scene.defines import parse_defines

from ..errors import RefsInputError
from ..preflight import check_image_size, check_ladder, check_output_folder, check_scene, check_spp, scene_path
from ..reference import config
from ..reference.config import CONVERGENCE_LADDER, CONVERGENCE_REPLICAS
from ..report.outputs import add_output_options, check_output_options, write_outputs
from ..settings import Settings
from .options import (
    add_dask_option,
    add_detect_options,
    add_tolerance_options,
    check_alpha,
    detect_of,
    exit_status,
    on_cluster_of,
    positive_ints,
    resolution,
    tolerance_of,
)


def add_compare(subparsers):
    """Add the ``compare`` subcommand to ``subparsers``; return its handler."""
    p = subparsers.add_parser(
        "compare", help="compare a pathtracer integrator with Mitsuba (mean, variance, convergence)",
        description="Render SCENE with one of pathtracer's integrators and with Mitsuba 3 (or load "
                    "the cached reference), and decide with calibrated tests whether they agree in "
                    "mean and variance and whether the error obeys the N^-1/2 law. On disagreement, "
                    "the first diverging bounce and the likely cause are printed and diagnostic "
                    "pictures are written. Exit code: 0 agree, 1 disagree, 3 inconclusive "
                    "(--tolerance), 2 bad input (one line on stderr), 130 interrupted.")
    p.add_argument("scene", help="built-in scene name or Mitsuba 3 XML file")
    p.add_argument("-D", dest="defines", action="append", default=[], metavar="NAME=VALUE",
                   help="scene parameter for both renderers (repeatable); built-in scenes default "
                        "to the committed references' film size")
    p.add_argument("--integrator", default=None, choices=sorted(INTEGRATORS),
                   help="pathtracer integrator to test (default: the one that renders the file's "
                        "own <integrator>, e.g. volpath, light for ptracer; path if it names none)")
    p.add_argument("--spp", type=int, default=None,
                   help="samples per pixel of the mean/variance render, whatever the file's sampler "
                        f"says (default {config.TEST_MAX_SPP}; the reference has {config.REF_SPP})")
    p.add_argument("--resolution", type=resolution, default=None, metavar="WxH",
                   help="film size for both renderers, replacing the file's (literal or $param), "
                        "e.g. 64x48")
    p.add_argument("--max-depth", type=int, default=None,
                   help="longest path for both renderers, replacing the file's <integrator> value")
    p.add_argument("--rr-depth", type=int, default=None,
                   help="roulette start for both renderers, replacing the file's <integrator> value")
    p.add_argument("--alpha", type=float, default=1e-3,
                   help="significance level of each test (default 1e-3)")
    p.add_argument("--ladder", type=positive_ints, default=CONVERGENCE_LADDER,
                   help="spp ladder of the convergence test, comma-separated "
                        f"(default {','.join(map(str, CONVERGENCE_LADDER))})")
    p.add_argument("--replicas", type=int, default=CONVERGENCE_REPLICAS,
                   help="independent replicas at the top ladder level; lower levels get 4x as many "
                        f"per 4x fewer spp, so every level renders as many samples (default {CONVERGENCE_REPLICAS})")
    p.add_argument("--no-convergence", action="store_true", help="skip the convergence test")
    p.add_argument("--bounces", choices=("auto", "always", "never"), default="auto",
                   help="per-bounce localisation: when the mean disagrees (auto), always or never")
    p.add_argument("--out", default="out/compare", help="folder for the diagnostic pictures")
    p.add_argument("--processes", type=int, default=None, help="worker processes (default: all cores)")
    add_detect_options(p)
    add_tolerance_options(p)
    add_dask_option(p)
    add_output_options(p)
    return run_compare


def run_compare(args) -> int:
    """Handler of ``compare``; input errors propagate to :func:`mitsuba_refs.cli.main.main`
    (one line, exit status 2)."""
    params = parse_defines(args.defines)
    check_options(args)
    detect = detect_of(args)
    loaded = preload(args.scene, params, args.resolution)
    integrator = args.integrator or loaded.integrator.name     # the file's own by default
    # SciPy's statistics (~0.3 s) load inside mitsuba-refs' main, where a Ctrl-C is caught.
    from ..verdicts.compare import compare
    bounces = {"auto": None, "always": True, "never": False}[args.bounces]
    options = {k: v for k, v in (("max_depth", args.max_depth), ("rr_depth", args.rr_depth))
               if v is not None} or None
    settings = Settings(spp=args.spp or config.TEST_MAX_SPP, alpha=args.alpha, detect=detect,
                        convergence=not args.no_convergence, bounces=bounces, out_dir=args.out,
                        processes=args.processes, ladder=args.ladder, replicas=args.replicas,
                        options=options, resolution=args.resolution, **tolerance_of(args))
    with on_cluster_of(args):   # --dask: the references rendered on the cluster
        result = compare(args.scene, integrator, params, settings,
                         log=lambda message: print(message, file=sys.stderr))
    print(result.report())
    for line in write_outputs(args, [result]):
        print(line)
    return exit_status(result)


def check_options(args) -> None:
    """Refuse out-of-range options in one line saying what to change."""
    if args.spp is not None:
        check_spp(args.spp)
    check_alpha(args.alpha)
    if not args.no_convergence:
        check_ladder(args.ladder)
    if args.replicas < 1:
        raise RefsInputError(f"--replicas must be >= 1, got {args.replicas}")
    if args.processes is not None and args.processes < 1:
        raise RefsInputError(f"--processes must be >= 1, got {args.processes}")
    check_output_folder(args.out)
    check_output_options(args)


def preload(scene, params, resolution=None):
    """Load ``scene`` in our tracer first (its messages name file and line), then check
    what Mitsuba will be given, all before any reference is looked up or rendered.

    The loaded scene is kept by :func:`mitsuba_refs.verdicts.scenes.loaded_scene` for the renders,
    and returned (its ``integrator`` is the file's own, the default of ``--integrator``).
    Warnings of the loader (e.g. a parameter the file does not use) are printed as one
    line each once the input is known to be good.
    """
    scene_path(scene)
    # SciPy's statistics (~0.3 s) load inside mitsuba-refs' main, where a Ctrl-C is caught.
    from ..verdicts.scenes import default_params, loaded_scene
    params = {**default_params(scene), **params}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        loaded = loaded_scene(scene, params, resolution)
    check_scene(scene, params)
    check_image_size(loaded.camera.width, loaded.camera.height, scene)
    for warning in caught:
        print(f"mitsuba-refs compare: warning: {warning.message}", file=sys.stderr)
    return loaded
