"""Option readers that several ``mitsuba-refs`` commands share: argparse types for sample-count
lists and film sizes, ``--detect`` / ``--max-time``, and ``--alpha``'s range."""
from __future__ import annotations

import argparse

from pathtracer.scene.load import parse_resolution

from ..errors import RefsInputError
from ..settings import DEFAULT_MAX_TIME, Detect

__all__ = ["positive_ints", "resolution", "add_detect_options", "detect_of", "check_alpha",
           "add_tolerance_options", "tolerance_of", "exit_status", "EXIT_INCONCLUSIVE",
           "add_dask_option", "on_cluster_of"]

#: Exit status of compare and check when the mean verdict is INCONCLUSIVE (``--tolerance``):
#: 0 agrees, 1 disagrees, 2 bad input and 130 interrupted keep their meanings.
EXIT_INCONCLUSIVE = 3
#: ``--tolerance``'s percentage when given without one (docs/statistics.md, section 9: above the
#: committed references' own noise floor, below the 3 % a renderer must not be let off with).
DEFAULT_TOLERANCE = 2.0


def positive_ints(text: str) -> tuple[int, ...]:
    """argparse type: comma-separated sample counts, each at least 1 (``--ladder``)."""
    try:
        values = tuple(int(v) for v in text.split(","))
    except ValueError:
        values = ()
    if not values or min(values) < 1:
        raise argparse.ArgumentTypeError(
            f"expected comma-separated sample counts >= 1 (e.g. 1,4,16,64), got {text!r}")
    return values


def resolution(text: str) -> tuple[int, int]:
    """argparse type: a film size ``WxH`` (``--resolution``)."""
    try:
        return parse_resolution(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def add_detect_options(parser) -> None:
    """``--detect BIAS`` and ``--max-time SECONDS`` (compare and check)."""
    parser.add_argument("--detect", default=None, metavar="BIAS",
                        help="choose the spp (instead of --spp) from a short pilot render so that the "
                             "mean test detects a global bias of BIAS (e.g. 2%%) with probability 0.95, "
                             "or say why it cannot (the reference's own noise)")
    parser.add_argument("--max-time", type=float, default=None, metavar="SECONDS",
                        help="with --detect: the most seconds the mean-and-variance render may take, "
                             "at the pilot's pace (default 300)")


def detect_of(args):
    """The :class:`mitsuba_refs.settings.Detect` of ``--detect`` / ``--max-time`` (None without
    --detect); one-line errors for a bad value or a conflicting option."""
    if args.detect is None:
        if args.max_time is not None:
            raise RefsInputError("--max-time goes with --detect (it caps the spp --detect chooses)")
        return None
    # The verdicts load SciPy's statistics: inside the command, where Ctrl-C is one line.
    from ..verdicts.detect import parse_bias
    target = parse_bias(args.detect)
    if args.spp is not None:
        raise RefsInputError("--spp and --detect both set the sample count: give one of them")
    max_time = DEFAULT_MAX_TIME if args.max_time is None else args.max_time
    if not (max_time > 0 and max_time < float("inf")):
        raise RefsInputError(f"--max-time must be a number of seconds > 0, got {args.max_time}")
    return Detect(target, max_time)


def check_alpha(alpha: float) -> None:
    """Refuse a significance level outside (0, 1) in one line."""
    if not 0 < alpha < 1:
        raise RefsInputError(f"--alpha must be between 0 and 1 (e.g. 1e-3), got {alpha}")


def percentage(text: str) -> float:
    """``--tolerance``'s value. Its percentage is optional, so a bare ``--tolerance`` before the
    scene takes the scene's name for it: say so, instead of argparse's "invalid float value"."""
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"a percentage, e.g. 2; got {text!r} (a bare --tolerance goes after the scene, or "
            f"write --tolerance {DEFAULT_TOLERANCE:g} {text})") from None


def add_tolerance_options(parser) -> None:
    """``--tolerance PCT``, ``--max-spp N`` and ``--max-seconds S`` (compare and check)."""
    parser.add_argument("--tolerance", type=percentage, default=None, nargs="?",
                        const=DEFAULT_TOLERANCE, metavar="PCT",
                        help="three outcomes for the mean: AGREES within +-PCT%% (relative bias, "
                             "per image and per region), DISAGREES, or INCONCLUSIVE (exit 3) when "
                             "the budget runs out first; renders in doubling rounds until decided "
                             f"(PCT default {DEFAULT_TOLERANCE:g}; without --tolerance: the "
                             "fixed-budget test of equal means)")
    parser.add_argument("--max-spp", type=int, default=None, metavar="N",
                        help="with --tolerance: the most samples per pixel the rounds render "
                             "(default --spp's)")
    parser.add_argument("--max-seconds", type=float, default=None, metavar="S",
                        help="with --tolerance: start no round that would end past S seconds")


def tolerance_of(args) -> dict:
    """``tolerance``, ``max_spp`` and ``max_seconds`` of the Settings, checked (one line each)."""
    if args.tolerance is None:
        if args.max_spp is not None or args.max_seconds is not None:
            raise RefsInputError("--max-spp and --max-seconds go with --tolerance (the budget of "
                                 "the rounds)")
        return {}
    if not 0 < args.tolerance < 100:
        raise RefsInputError(f"--tolerance is a percentage in (0, 100), e.g. 2, got {args.tolerance}")
    if args.max_spp is not None and args.max_spp < 1:
        raise RefsInputError(f"--max-spp must be >= 1, got {args.max_spp}")
    if args.max_seconds is not None and not args.max_seconds > 0:
        raise RefsInputError(f"--max-seconds must be > 0, got {args.max_seconds}")
    if getattr(args, "detect", None) is not None:
        raise RefsInputError("--detect and --tolerance both choose the sample count: give one")
    return {"tolerance": float(args.tolerance), "max_spp": args.max_spp,
            "max_seconds": args.max_seconds}


def exit_status(result) -> int:
    """0 agrees, 1 disagrees, :data:`EXIT_INCONCLUSIVE` when the mean is undecided."""
    outcome = getattr(result, "outcome", "AGREES" if result.agree else "DISAGREES")
    return {"AGREES": 0, "DISAGREES": 1}.get(outcome, EXIT_INCONCLUSIVE)


def add_dask_option(parser) -> None:
    """``--dask ADDRESS``: render the references on a Dask cluster (build, compare, check)."""
    parser.add_argument("--dask", metavar="ADDRESS", default=None,
                        help="render the Mitsuba references on a Dask cluster: a scheduler "
                             "address (tcp://host:8786) or 'local' for a LocalCluster; the "
                             "workers must see the scene files and MITSUBA_REFS_CACHE at the "
                             "same paths (docs/cluster.md)")


def on_cluster_of(args, variant=None):
    """The context of ``--dask`` (:func:`mitsuba_refs.cluster.site.on_cluster`; a no-op
    without it, and Dask is imported only with it)."""
    if not getattr(args, "dask", None):
        import contextlib
        return contextlib.nullcontext()
    from ..cluster.site import on_cluster
    return on_cluster(args.dask, variant)
