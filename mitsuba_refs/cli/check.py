"""``mitsuba-refs check``: any renderer (a command, or images it wrote) against Mitsuba.

Exit code 0 when every verdict agrees, 1 when one disagrees (also when the renderer's images
hold NaN, Inf or negative values), 3 when the mean is INCONCLUSIVE (``--tolerance``: the
budget ran out before a decision), 2 on bad input (an unknown placeholder, a run that fails or
times out, an image that is missing, unreadable or of the wrong size, replicas that are not
independent), 130 when interrupted (every run killed, no partial reference).
"""
from __future__ import annotations

import sys

from pathtracer.scene.defines import parse_defines

from ..errors import RefsInputError
from ..external.template import PLACEHOLDERS, CommandTemplate
from ..preflight import check_ladder, check_output_folder, check_spp
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

PLACEHOLDER_HELP = "placeholders: " + "; ".join(f"{{{name}}} {text}" for name, text in PLACEHOLDERS.items())


#: ``--seeds-for``'s largest sample count when ``--spp`` gives none.
SEEDS_FOR_SPP = 4096


def add_check(subparsers):
    """Add the ``check`` subcommand to ``subparsers``; return its handler."""
    p = subparsers.add_parser(
        "check", help="judge any renderer (a command or its images) against Mitsuba",
        description="Render SCENE in Mitsuba 3 (or load the cached reference) and judge an external "
                    "renderer with the verdicts of compare: mean, variance (with --same-estimator), "
                    "convergence, and the first diverging bounce when the command takes "
                    "{max_depth}. Exit code: 0 agree, 1 disagree, 3 inconclusive (--tolerance), 2 "
                    "bad input (one line on stderr), 130 interrupted.",
        epilog=PLACEHOLDER_HELP + ". Example: --command './smallpt --width {width} --height {height} "
               "--spp {spp} --seed {seed} --max-depth {max_depth} --out {out}'")
    p.add_argument("scene", help="built-in scene name or Mitsuba 3 XML file (what Mitsuba renders)")
    source = p.add_mutually_exclusive_group(required=True)
    source.add_argument("--command", metavar="TEMPLATE",
                        help="the renderer's command line, run through /bin/sh once per render; "
                             "see the placeholders below")
    source.add_argument("--images", nargs="+", metavar="FILE",
                        help="images rendered elsewhere (EXR, PFM, HDR; glob patterns allowed), "
                             "see docs/external.md")
    source.add_argument("--seeds-for", type=int, metavar="N",
                        help="print seeds for N images of the scene's film (--resolution) up to "
                             "--spp samples (default 4096), far enough apart that no two share "
                             "a random stream, and exit")
    p.add_argument("-D", dest="defines", action="append", default=[], metavar="NAME=VALUE",
                   help="scene parameter for Mitsuba (and {defines}); repeatable")
    p.add_argument("--spp", type=int, default=None,
                   help=f"--command: samples per pixel of the mean/variance render (default "
                        f"{config.TEST_MAX_SPP}); --images: the sample count of images whose header "
                        "and sidecar give none")
    p.add_argument("--resolution", type=resolution, default=None, metavar="WxH",
                   help="film size for both sides, replacing the file's")
    p.add_argument("--max-depth", type=int, default=None,
                   help="longest path for both sides ({max_depth}), replacing the file's")
    p.add_argument("--reference-integrator", default=None, metavar="NAME",
                   help="Mitsuba estimator of the reference (path, volpath, direct, ptracer, "
                        "path_bsdf, path_nee; default: the file's <integrator>)")
    p.add_argument("--same-estimator", action="store_true",
                   help="the renderer runs the reference's estimator, so the variance verdict "
                        "applies (otherwise it is reported as not applicable, with the ratio)")
    p.add_argument("--splatting", action="store_true", default=None,
                   help="the renderer's paths splat into many pixels (light tracing, BDPT): the "
                        "whole-image components are left out (default with ptracer)")
    p.add_argument("--name", default=None,
                   help="the renderer's name in the verdicts, records and picture names (default: "
                        "the program of --command, wrappers such as nice or env skipped; "
                        "'images' with --images)")
    p.add_argument("--renderer-scene", default=None, metavar="FILE",
                   help="the file the renderer reads ({scene}) when it does not read Mitsuba XML")
    p.add_argument("--jobs", type=int, default=None, help="renderer runs at once (default: the cores)")
    p.add_argument("--timeout", type=float, default=600.0,
                   help="seconds one run may take before it is killed with its children (default 600)")
    p.add_argument("--variance-replicas", type=int, default=8, metavar="K",
                   help="independent runs giving the variance when the images carry none (default 8)")
    p.add_argument("--output-suffix", default=".exr",
                   help="file name suffix of {out} (.exr, .pfm, .hdr; default .exr)")
    p.add_argument("--alpha", type=float, default=1e-3, help="level of each verdict (default 1e-3)")
    p.add_argument("--ladder", type=positive_ints, default=CONVERGENCE_LADDER,
                   help=f"spp ladder of the convergence test (default "
                        f"{','.join(map(str, CONVERGENCE_LADDER))})")
    p.add_argument("--replicas", type=int, default=CONVERGENCE_REPLICAS,
                   help=f"replicas at the top ladder level (default {CONVERGENCE_REPLICAS})")
    p.add_argument("--no-convergence", action="store_true", help="skip the convergence test")
    p.add_argument("--bounces", choices=("auto", "always", "never"), default="auto",
                   help="per-bounce localisation (needs {max_depth}): on a disagreement (auto), "
                        "always or never")
    p.add_argument("--out", default="out/check", help="folder for the diagnostic pictures")
    add_detect_options(p)
    add_tolerance_options(p)
    add_dask_option(p)
    add_output_options(p)
    return run_check


def run_check(args) -> int:
    """Handler of ``check``."""
    params = parse_defines(args.defines)
    if args.seeds_for is not None:
        return _print_seeds(args, params)
    _check_options(args)
    detect = detect_of(args)
    if detect is not None and args.command is None:
        raise RefsInputError("--detect goes with --command: images rendered elsewhere have "
                             "their sample count (the verdict says what they could see)")
    from ..external.check import check  # the statistics load inside main, where Ctrl-C is caught
    bounces = {"auto": None, "always": True, "never": False}[args.bounces]
    command_mode = args.command is not None
    settings = Settings(
        spp=(args.spp or config.TEST_MAX_SPP) if command_mode else config.TEST_MAX_SPP,
        alpha=args.alpha, convergence=not args.no_convergence, bounces=bounces, out_dir=args.out,
        jobs=args.jobs, timeout=args.timeout, variance_replicas=args.variance_replicas,
        reference=args.reference_integrator, same_estimator=args.same_estimator,
        splatting=args.splatting, resolution=args.resolution, ladder=args.ladder,
        replicas=args.replicas, detect=detect, name=args.name,
        options={"max_depth": int(args.max_depth)} if args.max_depth is not None else None,
        **tolerance_of(args))
    with on_cluster_of(args):   # --dask: the references rendered on the cluster
        result = check(args.scene, command=args.command, images=args.images, params=params,
                       settings=settings, renderer_scene=args.renderer_scene,
                       output_suffix=args.output_suffix,
                       images_spp=None if command_mode else args.spp,
                       log=lambda message: print(message, file=sys.stderr))
    print(result.report())
    for line in write_outputs(args, [result], alpha=args.alpha):
        print(line)
    return exit_status(result)


def _print_seeds(args, params) -> int:
    """``--seeds-for N``: the seeds of N images, one line of explanation, then one per line."""
    from ..external.check import film_seeds
    if args.seeds_for < 1:
        raise RefsInputError(f"--seeds-for must be >= 1, got {args.seeds_for}")
    if args.spp is not None:
        check_spp(args.spp)
    rule = film_seeds(args.scene, args.seeds_for, args.spp or SEEDS_FOR_SPP, params,
                      args.resolution)
    print(f"# seeds for {args.seeds_for} images of a {rule.width}x{rule.height} film up to "
          f"{rule.max_spp} spp: multiples of {rule.stride}")
    for seed in rule.seeds(args.seeds_for):
        print(seed)
    return 0


def _check_options(args) -> None:
    """Refuse out-of-range options in one line saying what to change."""
    if args.spp is not None:
        check_spp(args.spp)
    check_alpha(args.alpha)
    if args.command is not None and not args.no_convergence:
        check_ladder(args.ladder)
    for name in ("jobs", "variance_replicas", "replicas"):
        value = getattr(args, name)
        if value is not None and value < 1:
            raise RefsInputError(f"--{name.replace('_', '-')} must be >= 1, got {value}")
    if not args.timeout > 0:
        raise RefsInputError(f"--timeout must be > 0 seconds, got {args.timeout}")
    if args.renderer_scene is not None and args.command is None:
        raise RefsInputError("--renderer-scene goes with --command (it is the renderer's {scene})")
    if args.command is not None:
        CommandTemplate.parse(args.command)
    check_output_folder(args.out)
    check_output_options(args)
