"""``pathtracer`` command line: render Mitsuba 3 scene files with the lecture's integrators."""
from __future__ import annotations

import argparse
import math
import os
import signal
import sys
import threading
import warnings
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path

from . import __version__
from .core import interrupts
from .core.cli_help import HelpFormatter, add_version, with_choice_hint
from .core.rng import SEED_MAX
from .integrators import INTEGRATORS, make_integrator
from .integrators.base import HEMISPHERE_RULES, ROULETTE_RULES
from .integrators.class_selection import ClassSelection
from .integrators.pathclass import PathClassIntegrator
from .io.output import output_paths, write_exr, write_png
from .render import resources, sizes
from .render.driver import integrator_for, render
from .render.resources import SPP_MAX
from .scene.defines import parse_defines
from .scene.errors import SceneError
from .scene.load import builtin_scene_names, load_scene, parse_resolution
from .shapes import intersect

EPILOG = """\
examples:
  pathtracer render cornell-box --spp 64 -o out/cbox.exr
  pathtracer render scene.xml -D width=128 -D height=128 --integrator path_nee -o nee.exr
  pathtracer render users_scene.xml --resolution 64x48 --spp 16 -o small.exr
  pathtracer render cornell-caustics --integrator recursive --branches 4 --max-depth 4 -o rec.exr
  pathtracer scenes

SCENE is a Mitsuba 3 XML file or the name of a built-in scene (see `pathtracer scenes`).
The EXR holds R, G, B (pixel mean) and var.R, var.G, var.B (per-sample variance);
a tonemapped PNG preview is written beside it. Both are written to a temporary name
and renamed when complete: an interrupted render leaves no partial file.

exit codes: 0 done, 1 failed while running (a worker died, the disk is full),
2 bad input or usage (nothing rendered), 130 interrupted (Ctrl-C), 143 terminated (SIGTERM).
"""

#: The first line of ``pathtracer --help`` (plain text: the module docstring is reStructuredText).
DESCRIPTION = "pathtracer: render Mitsuba 3 scene files with the lecture's integrators."

#: The integrators that splat into the film (their variance comes from replicas).
SPLATTING = tuple(name for name, cls in INTEGRATORS.items() if cls.splats)
#: The integrators with a ``paths`` option of their own (the path tracer's is PathClassIntegrator).
SELECTING_PATHS = tuple(name for name, cls in INTEGRATORS.items() if issubclass(cls, ClassSelection))

#: Exit codes (docs/rendering.md, "Exit codes").
EXIT_OK, EXIT_FAILED, EXIT_USAGE = 0, 1, 2
EXIT_INTERRUPTED, EXIT_TERMINATED = 128 + signal.SIGINT, 128 + signal.SIGTERM


class _Parser(argparse.ArgumentParser):
    """argparse that reports errors as one line and exit code 2."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {with_choice_hint(message)}\n")


def _integer(text: str, low: int, high: int | None, what: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}") from None
    if value < low or (high is not None and value > high):
        raise argparse.ArgumentTypeError(f"expected {what}, got {value}")
    return value


def _positive(text: str) -> int:
    return _integer(text, 1, None, "a whole number >= 1")


def _natural(text: str) -> int:
    return _integer(text, 0, None, "a whole number >= 0")


def _spp(text: str) -> int:
    return _integer(text, 1, SPP_MAX, f"a whole number from 1 to {SPP_MAX}")


def _seed(text: str) -> int:
    return _integer(text, 0, SEED_MAX, f"a whole number from 0 to {SEED_MAX} (32 bits, as Mitsuba's seed)")


def _depth(text: str) -> int:
    return _integer(text, -1, None, "-1 (unlimited) or a whole number >= 0")


def _finite(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return value


def _resolution(text: str) -> tuple[int, int]:
    try:
        return parse_resolution(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def build_parser() -> argparse.ArgumentParser:
    """The ``pathtracer`` command line (subcommands ``render`` and ``scenes``)."""
    parser = _Parser(prog="pathtracer", description=DESCRIPTION,
                     formatter_class=HelpFormatter, epilog=EPILOG)
    add_version(parser, __version__)
    commands = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    render = commands.add_parser(
        "render", help="render a scene to EXR (+ PNG preview)", epilog=EPILOG,
        formatter_class=HelpFormatter,
        description="Render SCENE with one of the lecture's integrators and write the "
                    "per-pixel mean and per-sample variance to an EXR file.")
    render.add_argument("scene", help="Mitsuba 3 XML file or built-in scene name")
    render.add_argument("-o", "--output", required=True, type=Path,
                        help="output EXR path, ending in .exr (a PNG preview is written beside it)")
    render.add_argument("-D", dest="defines", action="append", default=[],
                        metavar="NAME=VALUE", help="set a scene parameter (<default> override); repeatable")
    render.add_argument("--integrator", choices=sorted(INTEGRATORS),
                        help="integrator (default: the file's <integrator>, else path)")
    render.add_argument("--resolution", type=_resolution, metavar="WxH",
                        help="film size replacing the file's, literal or $param (e.g. 64x48)")
    render.add_argument("--spp", type=_spp,
                        help="samples per pixel replacing the file's sampler count")
    render.add_argument("--seed", type=_seed, help="random seed (default: the file's sampler seed)")
    render.add_argument("--max-depth", type=_depth,
                        help="longest path in segments: 1 = visible emitters, 2 = direct light, -1 = unlimited")
    render.add_argument("--rr-depth", type=int, help="segments before Russian roulette starts (default 5)")
    render.add_argument("--roulette", choices=ROULETTE_RULES,
                        help="roulette rule: Mitsuba's, the lecture's constant q, or off")
    render.add_argument("--rr-q", type=_finite, help="termination probability of --roulette constant")
    render.add_argument("--hemisphere", choices=HEMISPHERE_RULES,
                        help="diffuse sampling: cosine-weighted (default) or uniform")
    render.add_argument("--branches", type=_positive, help="recursive: indirect rays per hit")
    render.add_argument("--branch-depth", type=_natural, help="recursive: depth down to which hits branch")
    render.add_argument("--replicas", type=_positive,
                        help=f"{', '.join(SPLATTING)}: independent renders whose spread gives the variance "
                             "(default 8)")
    render.add_argument("--mis", choices=("power", "balance"),
                        help="bdpt: heuristic combining the strategies (default power)")
    render.add_argument("--paths", metavar="REGEX",
                        help="render only the paths of a Heckbert class, light first, e.g. 'LS+DE' "
                             f"(caustics), 'LDE', 'L.*E' (with path, {' or '.join(SELECTING_PATHS)}; "
                             "see docs/experiments.md)")
    render.add_argument("--glossy", default="G",
                        help="--paths: letter of rough conductors, G, D, S or an alpha threshold")
    render.add_argument("--processes", type=_positive, help="worker processes (default: all cores)")
    render.add_argument("--exposure", type=_finite, default=0.0, help="PNG preview exposure in stops")
    render.add_argument("--no-progress", action="store_true", help="never show a progress bar")
    render.add_argument("-v", "--verbose", action="store_true",
                        help="say the machine and the sizes chosen for it (batch, all-pairs chunk)")

    commands.add_parser("scenes", help="list the built-in scenes", formatter_class=HelpFormatter,
                        description="Print the names of the built-in scenes, one a line; any of them "
                                    "is a SCENE of pathtracer render (and of mitsuba-refs).",
                        epilog="example:\n  pathtracer scenes")
    return parser


def main(argv=None) -> int:
    """Run one ``pathtracer`` command; its exit code (docs/rendering.md, "Exit codes")."""
    interrupts.install()        # a Ctrl-C inside a reader stays an interrupt
    args = build_parser().parse_args(argv)
    if args.command == "scenes":
        for name in builtin_scene_names():
            print(name)
        return 0
    return _render(args)


class Terminated(BaseException):
    """SIGTERM, raised in the main thread so that the render cleans up as for Ctrl-C."""


def _raise_terminated(signum, frame):
    raise Terminated


def _render(args) -> int:
    """Run a render with one-line errors and exit codes; the same cleanup for every stop."""
    in_main_thread = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGTERM, _raise_terminated) if in_main_thread else None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("default")
            warnings.showwarning = _show_warning
            return _render_checked(args)
    except KeyboardInterrupt:
        print("pathtracer: interrupted; no output written", file=sys.stderr)
        return EXIT_INTERRUPTED
    except Terminated:
        print("pathtracer: terminated; no output written", file=sys.stderr)
        return EXIT_TERMINATED
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


def _show_warning(message, category, filename, lineno, file=None, line=None):
    """Warnings as one line each, without Python's source line."""
    print(f"pathtracer: warning: {message}", file=sys.stderr)


def _integrator_choice(args, options: dict):
    """The ``integrator`` argument of :func:`render`: a name, None, or the --paths integrator
    (the class-splitting path tracer, or one of :data:`SELECTING_PATHS` with its ``paths`` option)."""
    if not args.paths:
        return args.integrator
    if args.integrator in SELECTING_PATHS:
        return make_integrator(args.integrator, paths=args.paths, glossy=args.glossy)
    if args.integrator not in (None, "path"):
        raise ValueError(f"--paths works with the path, {' and '.join(SELECTING_PATHS)} integrators only")
    return PathClassIntegrator(args.paths, glossy=args.glossy,
                               **{k: v for k, v in options.items()
                                  if v is not None and k not in ("branches", "branch_depth",
                                                                 "replicas", "mis")})


def _check_file_spp(spp: int, scene: str) -> None:
    """Refuse the file's sample count when out of range, saying where it came from."""
    try:
        resources.check_spp(spp)
    except ValueError as error:
        raise ValueError(f"{scene}: the file's <sampler> sample_count: {error}; --spp N replaces "
                         "it") from None


def _render_checked(args) -> int:
    """Check everything (scene, options, memory, output), render, write; exit code."""
    options = dict(max_depth=args.max_depth, rr_depth=args.rr_depth, roulette=args.roulette,
                   rr_q=args.rr_q, hemisphere=args.hemisphere, branches=args.branches,
                   branch_depth=args.branch_depth, replicas=args.replicas, mis=args.mis)
    try:
        scene = load_scene(args.scene, resolution=args.resolution, sample_count=args.spp,
                           **parse_defines(args.defines))
        if args.spp is None:    # --spp was checked by its parser: this count is the file's
            _check_file_spp(scene.spp, args.scene)
        processes = args.processes or os.cpu_count() or 1
        integrator = _integrator_choice(args, options)
        chosen = integrator_for(scene, integrator, **options)   # bad options: before any output
        batch = sizes.render_batch(processes, chosen.splats)
        resources.check_memory(scene.camera.width, scene.camera.height, processes, batch.paths)
        if args.verbose:
            accel = intersect.prepare(scene)   # built once: render() finds it ready
            for line in sizes.describe(batch, accel):
                print(f"pathtracer: {line}", file=sys.stderr)
        exr, png = output_paths(args.output)    # creates missing folders: after the checks
        result = render(scene, integrator=integrator, spp=args.spp, seed=args.seed,
                        processes=args.processes, batch_size=batch.paths,
                        progress=False if args.no_progress else None,
                        **{k: v for k, v in options.items() if v is not None})
    except (SceneError, ValueError, FileNotFoundError) as error:
        print(f"pathtracer: error: {error}", file=sys.stderr)
        return EXIT_USAGE
    except BrokenProcessPool:
        print("pathtracer: error: a worker process died during the render (killed, or out of "
              "memory?); nothing was written", file=sys.stderr)
        return EXIT_FAILED
    except MemoryError:
        print("pathtracer: error: out of memory during the render; render fewer pixels or use "
              "fewer --processes; nothing was written", file=sys.stderr)
        return EXIT_FAILED
    try:
        write_exr(exr, result)
        write_png(png, result.mean, args.exposure)
    except OSError as error:
        print(f"pathtracer: error: cannot write {exr}: {error.strerror or error}", file=sys.stderr)
        return EXIT_FAILED
    height, width = result.mean.shape[:2]
    paths_per_second = width * height * result.spp / max(result.seconds, 1e-9)
    print(f"{result.integrator}: {width}x{height} at {result.spp} spp in {result.seconds:.2f} s "
          f"({paths_per_second / 1e3:.0f}k paths/s); wrote {exr} and {png}")
    return EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
