"""``pathtracer`` command line: render Mitsuba 3 scene files with the lecture's integrators."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .integrators import INTEGRATORS
from .integrators.base import HEMISPHERE_RULES, ROULETTE_RULES

EPILOG = """\
examples:
  pathtracer render cornell-box --spp 64 -o out/cbox.exr
  pathtracer render scene.xml -D width=128 -D height=128 --integrator path_nee -o nee.exr
  pathtracer render users_scene.xml --resolution 64x48 --spp 16 -o small.exr
  pathtracer render cornell-caustics --integrator recursive --branches 4 --max-depth 4 -o rec.exr
  pathtracer scenes

SCENE is a Mitsuba 3 XML file or the name of a built-in scene (see `pathtracer scenes`).
The EXR holds R, G, B (pixel mean) and var.R, var.G, var.B (per-sample variance);
a tonemapped PNG preview is written beside it.
"""


class _Parser(argparse.ArgumentParser):
    """argparse that reports errors as one line and exit code 2."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message}\n")


def _define(text: str) -> tuple[str, str]:
    name, sep, value = text.partition("=")
    if not sep or not name:
        raise argparse.ArgumentTypeError(f"expected name=value, got {text!r}")
    return name, value


def _positive(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {value}")
    return value


def _resolution(text: str) -> tuple[int, int]:
    from .scene import parse_resolution
    try:
        return parse_resolution(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="pathtracer", description=__doc__,
                     formatter_class=argparse.RawDescriptionHelpFormatter, epilog=EPILOG)
    commands = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    render = commands.add_parser(
        "render", help="render a scene to EXR (+ PNG preview)", epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description="Render SCENE with one of the lecture's integrators and write the "
                    "per-pixel mean and per-sample variance to an EXR file.")
    render.add_argument("scene", help="Mitsuba 3 XML file or built-in scene name")
    render.add_argument("-o", "--output", required=True, type=Path,
                        help="output EXR path (a PNG preview is written beside it)")
    render.add_argument("-D", dest="defines", action="append", type=_define, default=[],
                        metavar="NAME=VALUE", help="set a scene parameter (<default> override); repeatable")
    render.add_argument("--integrator", choices=sorted(INTEGRATORS),
                        help="integrator (default: the file's <integrator>, else path)")
    render.add_argument("--resolution", type=_resolution, metavar="WxH",
                        help="film size replacing the file's, literal or $param (e.g. 64x48)")
    render.add_argument("--spp", type=_positive,
                        help="samples per pixel replacing the file's sampler count")
    render.add_argument("--seed", type=int, help="random seed (default: the file's sampler seed)")
    render.add_argument("--max-depth", type=int,
                        help="longest path in segments: 1 = visible emitters, 2 = direct light, -1 = unlimited")
    render.add_argument("--rr-depth", type=int, help="segments before Russian roulette starts (default 5)")
    render.add_argument("--roulette", choices=ROULETTE_RULES,
                        help="roulette rule: Mitsuba's, the lecture's constant q, or off")
    render.add_argument("--rr-q", type=float, help="termination probability of --roulette constant")
    render.add_argument("--hemisphere", choices=HEMISPHERE_RULES,
                        help="diffuse sampling: cosine-weighted (default) or uniform")
    render.add_argument("--branches", type=_positive, help="recursive: indirect rays per hit")
    render.add_argument("--branch-depth", type=int, help="recursive: depth down to which hits branch")
    render.add_argument("--paths", metavar="REGEX",
                        help="render only the paths of a Heckbert class, light first, e.g. 'LS+DE' "
                             "(caustics), 'LDE', 'L.*E' (MIS path tracer; see docs/experiments.md)")
    render.add_argument("--glossy", default="G",
                        help="--paths: letter of rough conductors, G, D, S or an alpha threshold")
    render.add_argument("--processes", type=_positive, help="worker processes (default: all cores)")
    render.add_argument("--exposure", type=float, default=0.0, help="PNG preview exposure in stops")
    render.add_argument("--no-progress", action="store_true", help="never show a progress bar")

    commands.add_parser("scenes", help="list the built-in scenes")
    return parser


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    if args.command == "scenes":
        import os
        from .scene import BUILTIN_DIR
        for name in sorted(f[:-4] for f in os.listdir(BUILTIN_DIR) if f.endswith(".xml")):
            print(name)
        return 0
    return _render(args)


def _render(args) -> int:
    from . import render
    from .io import write_exr, write_png
    from .scene import SceneError, load_scene

    options = dict(max_depth=args.max_depth, rr_depth=args.rr_depth, roulette=args.roulette,
                   rr_q=args.rr_q, hemisphere=args.hemisphere, branches=args.branches,
                   branch_depth=args.branch_depth)
    try:
        scene = load_scene(args.scene, resolution=args.resolution, spp=args.spp,
                           **dict(args.defines))
        integrator = args.integrator
        if args.paths:
            from .integrators.pathclass import PathClassIntegrator
            if integrator not in (None, "path"):
                raise ValueError("--paths works with the path integrator only")
            integrator = PathClassIntegrator(args.paths, glossy=args.glossy,
                                             **{k: v for k, v in options.items()
                                                if v is not None and k not in ("branches", "branch_depth")})
        result = render(scene, integrator=integrator, spp=args.spp, seed=args.seed,
                        processes=args.processes, progress=False if args.no_progress else None,
                        **{k: v for k, v in options.items() if v is not None})
    except (SceneError, ValueError, FileNotFoundError) as error:
        print(f"pathtracer: error: {error}", file=sys.stderr)
        return 2
    exr = write_exr(args.output, result)
    png = write_png(exr.with_suffix(".png"), result.mean, args.exposure)
    height, width = result.mean.shape[:2]
    paths_per_second = width * height * result.spp / max(result.seconds, 1e-9)
    print(f"{result.integrator}: {width}x{height} at {result.spp} spp in {result.seconds:.2f} s "
          f"({paths_per_second / 1e3:.0f}k paths/s); wrote {exr} and {png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
