"""``mitsuba-refs``: command-line front end of the reference side.

Subcommands are registered in :data:`SUBCOMMANDS` (name -> function adding
an argparse subparser and returning the handler), so others can add
``compare`` etc. without touching ``build``.

``mitsuba-refs build [SCENES...] [--integrators ...] [--spp N]
[-D name=value ...] [--variant V] [--force]`` renders missing, stale or
corrupt references and prints the chosen variant (and why) and the time
per reference.

Exit status of every subcommand (:data:`EXIT_CODES`): 0 success (and, for
``compare``, agreement), 1 ``compare`` disagrees, 2 bad input or usage (one
line on stderr, no traceback), 130 interrupted (Ctrl-C).
"""

import argparse
import sys
import time

from pathtracer import __version__
from pathtracer.core import interrupts
from pathtracer.core.cli_help import HelpFormatter, add_version, with_choice_hint
from pathtracer.scene.defines import parse_defines

from ..errors import RefsInputError, one_line
from ..preflight import check_scene, check_spp, scene_path
from ..reference import config
from ..reference.cache import (
    ReferenceUnavailable,
    build_reference,
    cache_dir,
    lookup_dirs,
    mitsuba_available,
    parse_xml,
    reference_stem,
    validate,
)
from ..reference.render import INTEGRATOR_MAP, xml_defaults
from ..reference.variant import choose_variant
from .check import add_check
from .compare import add_compare
from .examples import EXAMPLES, TOP
from .options import add_dask_option, on_cluster_of, resolution
from .report import add_report

#: Exit status -> meaning, for every subcommand.
EXIT_CODES = {0: "success / agrees", 1: "compare: disagrees with Mitsuba",
              2: "bad input or usage", 3: "compare, check: inconclusive (--tolerance: the budget "
              "ran out before the mean was decided)", 130: "interrupted"}


def default_jobs(scenes=None, integrators=None, extra_params=None,
                 per_bounce=True, resolution=None):
    """The references ``build`` makes by default: every scene x integrator at
    the test resolution, plus ``path`` with ``max_depth`` 1, 2, 3 (feature scenes:
    only their own estimators, no per-bounce references).

    Returns a list of ``(scene, params, integrator)``.
    """
    scenes = list(scenes or (*config.BUILTIN_SCENES, *config.FEATURE_SCENES))
    jobs = []
    for scene in scenes:
        base = {}
        if resolution is None and (scene in config.BUILTIN_SCENES or scene in config.GRADING_SCENES):
            width, height = config.test_resolution(scene)
            base = {"width": str(width), "height": str(height)}
        base.update(extra_params or {})
        scene_integrators = list(integrators or _default_integrators(scene))
        for integ in scene_integrators:
            jobs.append((scene, dict(base), integ))
        if (per_bounce and "path" in scene_integrators and "max_depth" not in base
                and scene not in config.FEATURE_SCENES and _declares_max_depth(scene)):
            for depth in config.PER_BOUNCE_DEPTHS:
                jobs.append((scene, dict(base, max_depth=str(depth)), "path"))
    return jobs


def _declares_max_depth(scene):
    """Per-bounce references set ``max_depth`` as a parameter: only where the file declares it."""
    path = scene_path(scene)
    parse_xml(path)  # a malformed file: one line naming file, line and column
    return "max_depth" in xml_defaults(path)


def _default_integrators(scene):
    """The estimators a scene gets references for unless ``--integrators`` says otherwise."""
    if scene in config.FEATURE_SCENES:
        return config.FEATURE_SCENES[scene][0]
    if scene in config.LIGHT_SCENES:
        return config.REF_INTEGRATORS + ("light",)
    return config.REF_INTEGRATORS


def _add_build(subparsers):
    p = subparsers.add_parser(
        "build", help="render missing/stale references",
        description="Render the Mitsuba references that are missing, stale "
                    "or corrupt (all of them with --force). Exit code: 0 done, "
                    "2 bad input (one line on stderr), 130 interrupted.")
    p.add_argument("scenes", nargs="*", metavar="SCENES",
                   help="built-in scene names or XML files (default: all built-in)")
    p.add_argument("--integrators", nargs="+", default=None, choices=sorted(INTEGRATOR_MAP),
                   metavar="NAME",
                   help=f"our integrator names, of {', '.join(sorted(INTEGRATOR_MAP))} "
                        f"(default: {' '.join(config.REF_INTEGRATORS)})")
    p.add_argument("--spp", type=int, default=config.REF_SPP,
                   help=f"samples per pixel (default {config.REF_SPP})")
    p.add_argument("--seed", type=int, default=config.REF_SEED,
                   help=f"base seed (default {config.REF_SEED})")
    p.add_argument("-D", dest="defines", action="append", metavar="name=value",
                   help="scene <default> or integrator parameter (repeatable)")
    p.add_argument("--variant", default=None,
                   help="Mitsuba variant (default: llvm_ad_rgb if it works, "
                        "else scalar_rgb; env MITSUBA_REFS_VARIANT)")
    p.add_argument("--resolution", type=resolution, default=None, metavar="WxH",
                   help="film size replacing the file's (default: the built-in scenes' test size, "
                        "a file's own)")
    p.add_argument("--force", action="store_true", help="re-render valid references too")
    p.add_argument("--no-per-bounce", action="store_true",
                   help="skip the max_depth = 1, 2, 3 path references")
    p.add_argument("--cache-dir", default=None,
                   help="cache folder (default: env MITSUBA_REFS_CACHE, else the user's cache "
                        "folder; the package's committed references are read first)")
    add_dask_option(p)
    return cmd_build


def cmd_build(args):
    """Handler of ``build``."""
    check_spp(args.spp)
    if args.seed < 0:
        raise RefsInputError(f"--seed must be >= 0, got {args.seed}")
    extra = parse_defines(args.defines)
    jobs = default_jobs(args.scenes or None, args.integrators, extra,
                        per_bounce=not args.no_per_bounce, resolution=args.resolution)
    where = {"resolution": args.resolution}
    for scene, params in {(s, tuple(sorted(p.items()))) for s, p, _ in jobs}:
        check_scene(scene, dict(params))
    directory = args.cache_dir or cache_dir()
    if args.dask and args.variant is None:
        args.variant = "scalar_rgb"   # reproducible bit for bit, split per render call
    if not mitsuba_available():
        raise RefsInputError("build renders with Mitsuba 3, which is not installed: "
                             "pip install mitsuba==3.9.1")
    variant, reason = _usable_variant(args.variant)
    print(f"variant: {variant} ({reason})")
    print(f"cache: {directory}; {len(jobs)} references at {args.spp} spp")
    built = 0
    t_all = time.time()
    with on_cluster_of(args, variant):
        for scene, params, integ in jobs:
            built += _build_one(args, (scene, params, integ), directory, variant, where)
    kept = len(jobs) - built
    print(f"done: {built} built, {kept} up to date, {time.time() - t_all:.1f} s")
    return 0


def _build_one(args, job, directory, variant, where):
    """Build one reference unless a valid one is found (and no --force); 1 when built."""
    import mitsuba as mi  # Mitsuba: optional and heavy, imported where it renders
    scene, params, integ = job
    stem = reference_stem(scene, params, integ, args.spp, args.seed, **where)
    for folder in lookup_dirs(args.cache_dir):
        status, detail, ref = validate(scene, params, integ, args.spp,
                                       args.seed, folder, **where)
        if status == "ok" and ref.metadata.get("mitsuba_version") != mi.__version__:
            status, detail = "stale", (f"made by Mitsuba "
                                       f"{ref.metadata.get('mitsuba_version')}")
        if status == "ok":
            break
    if status == "ok" and not args.force:
        print(f"  ok       {stem}")
        return 0
    t0 = time.time()
    build_reference(scene, params, integ, args.spp, args.seed,
                    directory=directory, variant=variant,
                    log=lambda line: print(line, file=sys.stderr), **where)
    print(f"  built    {stem}  [{status}: {detail}]  {time.time() - t0:.1f} s", flush=True)
    return 1


def _usable_variant(requested):
    """``choose_variant``'s choice, refused in one line if this Mitsuba lacks it."""
    import mitsuba as mi  # Mitsuba: optional and heavy, imported where it renders

    variant, reason = choose_variant(requested)
    if variant not in mi.variants():
        raise RefsInputError(f"Mitsuba variant {variant!r} ({reason}) is not available; "
                             f"this Mitsuba has {', '.join(mi.variants())}")
    return variant, reason


#: name -> function(subparsers) returning the handler; extend to add commands.
SUBCOMMANDS = {"build": _add_build, "compare": add_compare, "check": add_check,
               "report": add_report}


class OneLineParser(argparse.ArgumentParser):
    """An ``ArgumentParser`` whose usage errors are one line (and exit status 2)."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {with_choice_hint(message)} (see {self.prog} --help)\n")


#: Errors a user can fix: printed in one line with exit status 2. ``SceneError`` and
#: ``RefsInputError`` are ``ValueError``s; ``ReferenceUnavailable`` is a ``RuntimeError``.
def _user_errors():
    return (ValueError, OSError, ReferenceUnavailable)


def make_parser():
    """The argparse parser with one subparser per :data:`SUBCOMMANDS` entry."""
    parser = OneLineParser(
        prog="mitsuba-refs", formatter_class=HelpFormatter, epilog=TOP,
        description="Mitsuba 3 references for validating the NumPy path tracer.")
    add_version(parser, __version__)
    subparsers = parser.add_subparsers(dest="command", required=True)
    for name, add in SUBCOMMANDS.items():
        handler = add(subparsers)
        command = subparsers.choices[name]
        command.formatter_class = HelpFormatter
        command.epilog = "\n\n".join(filter(None, (EXAMPLES.get(name), command.epilog)))
        # "subcommand" too: check's option --command replaces args.command with its template.
        subparsers.choices[name].set_defaults(handler=handler, subcommand=name)
    return parser


def main(argv=None):
    """Run one subcommand; return its exit status (:data:`EXIT_CODES`).

    Bad input ends in one line on stderr and status 2, Ctrl-C in one line
    and status 130; only a bug shows a traceback.
    """
    interrupts.install()        # a Ctrl-C inside a reader stays an interrupt
    try:
        args = make_parser().parse_args(argv)
        prog = f"mitsuba-refs {args.subcommand}"
        try:
            return args.handler(args)
        except _user_errors() as error:
            print(f"{prog}: error: {one_line(error)}", file=sys.stderr)
            return 2
    except KeyboardInterrupt:
        print("mitsuba-refs: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
