"""``mitsuba-refs``: command-line front end of the reference side.

Subcommands are registered in :data:`SUBCOMMANDS` (name -> function adding
an argparse subparser and returning the handler), so others can add
``compare`` etc. without touching ``build``.

``mitsuba-refs build [SCENES...] [--integrators ...] [--spp N]
[-D name=value ...] [--variant V] [--force]`` renders missing, stale or
corrupt references and prints the chosen variant (and why) and the time
per reference.
"""

import argparse
import sys
import time

from . import config


def default_jobs(scenes=None, integrators=None, extra_params=None,
                 per_bounce=True):
    """The references ``build`` makes by default: every scene x integrator at
    the test resolution, plus ``path`` with ``max_depth`` 1, 2, 3 (feature scenes:
    only their own estimators, no per-bounce references).

    Returns a list of ``(scene, params, integrator)``.
    """
    scenes = list(scenes or (*config.BUILTIN_SCENES, *config.FEATURE_SCENES))
    jobs = []
    for scene in scenes:
        width, height = config.test_resolution(scene)
        base = {"width": str(width), "height": str(height)}
        base.update(extra_params or {})
        scene_integrators = list(integrators or _default_integrators(scene))
        for integ in scene_integrators:
            jobs.append((scene, dict(base), integ))
        if (per_bounce and "path" in scene_integrators and "max_depth" not in base
                and scene not in config.FEATURE_SCENES):
            for depth in config.PER_BOUNCE_DEPTHS:
                jobs.append((scene, dict(base, max_depth=str(depth)), "path"))
    return jobs


def _default_integrators(scene):
    """The estimators a scene gets references for unless ``--integrators`` says otherwise."""
    if scene in config.FEATURE_SCENES:
        return config.FEATURE_SCENES[scene][0]
    return config.REF_INTEGRATORS


def _parse_defines(defines):
    params = {}
    for item in defines or []:
        if "=" not in item:
            raise SystemExit(f"-D expects name=value, got {item!r}")
        name, value = item.split("=", 1)
        params[name.strip()] = value.strip()
    return params


def _add_build(subparsers):
    p = subparsers.add_parser(
        "build", help="render missing/stale references",
        description="Render the Mitsuba references that are missing, stale "
                    "or corrupt (all of them with --force).")
    p.add_argument("scenes", nargs="*", metavar="SCENES",
                   help="built-in scene names or XML files (default: all built-in)")
    p.add_argument("--integrators", nargs="+", default=None,
                   help=f"our integrator names (default: {' '.join(config.REF_INTEGRATORS)})")
    p.add_argument("--spp", type=int, default=config.REF_SPP,
                   help=f"samples per pixel (default {config.REF_SPP})")
    p.add_argument("--seed", type=int, default=config.REF_SEED,
                   help=f"base seed (default {config.REF_SEED})")
    p.add_argument("-D", dest="defines", action="append", metavar="name=value",
                   help="scene <default> or integrator parameter (repeatable)")
    p.add_argument("--variant", default=None,
                   help="Mitsuba variant (default: llvm_ad_rgb if it works, "
                        "else scalar_rgb; env MITSUBA_REFS_VARIANT)")
    p.add_argument("--force", action="store_true", help="re-render valid references too")
    p.add_argument("--no-per-bounce", action="store_true",
                   help="skip the max_depth = 1, 2, 3 path references")
    p.add_argument("--cache-dir", default=None,
                   help="cache folder (default: env MITSUBA_REFS_CACHE or the package's)")
    return cmd_build


def cmd_build(args):
    """Handler of ``build``."""
    from .cache import (cache_dir, get_reference, reference_stem, validate)
    from .variant import choose_variant

    extra = _parse_defines(args.defines)
    jobs = default_jobs(args.scenes or None, args.integrators, extra,
                        per_bounce=not args.no_per_bounce)
    directory = args.cache_dir or cache_dir()
    variant, reason = choose_variant(args.variant)
    print(f"variant: {variant} ({reason})")
    print(f"cache: {directory}; {len(jobs)} references at {args.spp} spp")
    import mitsuba as mi
    built = kept = 0
    t_all = time.time()
    for scene, params, integ in jobs:
        stem = reference_stem(scene, params, integ, args.spp, args.seed)
        status, detail, ref = validate(scene, params, integ, args.spp,
                                       args.seed, directory)
        if status == "ok" and ref.metadata.get("mitsuba_version") != mi.__version__:
            status, detail = "stale", (f"made by Mitsuba "
                                       f"{ref.metadata.get('mitsuba_version')}")
        if status == "ok" and not args.force:
            print(f"  ok       {stem}")
            kept += 1
            continue
        t0 = time.time()
        get_reference(scene, params, integ, args.spp, args.seed,
                      directory=directory, variant=variant, force=True)
        built += 1
        print(f"  built    {stem}  [{status}: {detail}]  {time.time() - t0:.1f} s",
              flush=True)
    print(f"done: {built} built, {kept} up to date, {time.time() - t_all:.1f} s")
    return 0


#: name -> function(subparsers) returning the handler; extend to add commands.
def _add_compare(subparsers):
    from .cli_compare import add_compare
    return add_compare(subparsers)


SUBCOMMANDS = {"build": _add_build, "compare": _add_compare}


def make_parser():
    """The argparse parser with one subparser per :data:`SUBCOMMANDS` entry."""
    parser = argparse.ArgumentParser(
        prog="mitsuba-refs",
        description="Mitsuba 3 references for validating the NumPy path tracer.")
    subparsers = parser.add_subparsers(dest="command", required=True)
    for name, add in SUBCOMMANDS.items():
        handler = add(subparsers)
        subparsers.choices[name].set_defaults(handler=handler)
    return parser


def main(argv=None):
    args = make_parser().parse_args(argv)
    return args.handler(args)


if __name__ == "__main__":
    sys.exit(main())
