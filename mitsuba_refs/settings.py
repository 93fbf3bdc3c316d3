"""What a comparison renders and how it is judged: one frozen :class:`Settings` value.

:func:`mitsuba_refs.verdicts.compare.compare`, :func:`mitsuba_refs.external.check.check`,
:func:`mitsuba_refs.testing.assert_agrees` (and the pytest fixture) and the autograder take the
same value; a variant is ``dataclasses.replace(settings, alpha=1e-4)``::

    from mitsuba_refs.settings import Settings
    from mitsuba_refs.verdicts.compare import compare

    quick = Settings(spp=64, convergence=False)
    result = compare("cornell-box", "path", settings=quick)

The functions also take the fields as keywords (``compare("cornell-box", spp=64)``), which
replace those of ``settings`` (default ``Settings()``): :func:`settings_of`. The defaults are
the command line's. This module imports only :mod:`mitsuba_refs.reference.config`, so that the
command line's parsers can read the defaults without the statistics.
"""
from __future__ import annotations

import dataclasses
import os
from collections.abc import Mapping
from dataclasses import dataclass

from .reference import config

__all__ = ["Settings", "Detect", "settings_of", "DEFAULT_MAX_TIME", "PILOT_SPP"]

#: ``--max-time``'s default: seconds the mean-and-variance render may take.
DEFAULT_MAX_TIME = 300.0
#: The pilot render of ``--detect``: its sample count (its seed: ``verdicts.detect.PILOT_SEED``).
PILOT_SPP = 16


@dataclass(frozen=True)
class Detect:
    """What ``--detect`` asks: a ``target`` bias seen with probability
    :data:`mitsuba_refs.verdicts.detect.POWER`, the mean-and-variance render within
    ``max_time`` seconds (:func:`mitsuba_refs.verdicts.detect.choose_spp`)."""

    target: float
    max_time: float = DEFAULT_MAX_TIME
    pilot_spp: int = PILOT_SPP


@dataclass(frozen=True)
class Settings:
    """What a comparison renders and how it is judged.

    Fields marked *compare* or *check* apply only to that side; the others to both.

    Attributes
    ----------
    spp : int
        Samples per pixel of the test side's mean-and-variance render (at most
        ``TEST_MAX_SPP`` for the committed references to be 64x as precise).
    alpha : float
        Significance level of each verdict.
    convergence : bool
        Run the convergence-law verdict.
    ladder : tuple of int
        spp levels (4x steps) of the convergence test.
    replicas : int
        The convergence test's independent replicas at the top level of ``ladder`` (equal
        work per level: :func:`mitsuba_refs.verdicts.convergence.level_replicas`).
    max_growth : int
        The most the convergence renders may grow while rare paths dominate
        (:func:`mitsuba_refs.verdicts.convergence.convergence_test`).
    bounces : bool or None
        Localise the first diverging bounce: always (True), never (False) or when the mean
        disagrees (None; check: only when the command template passes ``{max_depth}``).
    detect : Detect or None
        Choose ``spp`` from a pilot render so that the mean test sees ``detect.target``
        (:func:`mitsuba_refs.verdicts.detect.choose_spp`); replaces ``spp``. check: with a
        command only.
    reference : str or None
        The reference estimator. compare: our name for it (e.g. ``light`` for Mitsuba's
        ``ptracer``), default from the integrator; check: a Mitsuba type or one of our names,
        default the scene file's ``<integrator>``.
    same_estimator : bool or None
        The test side runs the reference's estimator: the variance verdict applies.
        compare: default from the integrator; check: None is False (it needs the user's word).
    splatting : bool or None
        The test side's paths splat into many pixels (the mean test leaves out its whole-image
        components); default from the integrator (compare) or the reference (check).
    heavy_tail_guard : bool or None
        The mean test's ``same_estimator`` guard (:mod:`mitsuba_refs.stats.mean`): on for the
        same estimator unless False (the grader's: its power was measured without it).
    options : mapping or None
        Options of every test-side render (compare: integrator options such as ``branches``;
        check: ``max_depth`` only); those that set the light transport (``max_depth``,
        ``rr_depth``, ``hide_emitters``) go to the reference too.
    resolution : (int, int) or None
        Film size replacing the file's, on both sides.
    out_dir : path or None
        Where diagnostic pictures go (written for every failed verdict); None: none.
    name : str or None
        check: the renderer's name in the verdicts, records and picture names (``--name``);
        None: the short form of its command (:func:`mitsuba_refs.external.naming.short_name`),
        or ``images``.
    processes : int or None
        compare: worker processes of our renders (default: all cores).
    jobs : int or None
        check: renderer runs at once (default: the cores).
    timeout : float
        check: seconds each renderer run may take.
    variance_replicas : int or None
        check: ``K``, the replicas that give mean and variance when the renderer's images
        carry no variance (None: 8).
    seed_offset : int
        check: which range of the renderer's seeds the runs take
        (:mod:`mitsuba_refs.external.seeding`), for independent repetitions of one check.
    tolerance : float or None
        Relative tolerance of the mean verdict, in percent (``--tolerance``): the mean
        AGREES within +-tolerance %, DISAGREES or is INCONCLUSIVE, rendered in doubling
        rounds until decided (:mod:`mitsuba_refs.verdicts.rounds`). None: the fixed-budget
        test of equal means at ``spp`` (docs/statistics.md, section 9).
    max_spp : int or None
        With ``tolerance``: the most samples per pixel the rounds render (None: ``spp``).
    max_seconds : float or None
        With ``tolerance``: no round starts that would end past this many seconds of rounds.
    judge_independence : bool
        Judge from the data whether the test side's samples are independent within a pixel
        (check: True; our integrators' are by construction, and the grader scores their
        variance): when the convergence verdict finds the error falling significantly faster
        than N^-1/2 (stratified or low-discrepancy samples), the variance verdict is not
        applicable (docs/statistics.md, section 3).
    """

    spp: int = config.TEST_MAX_SPP
    alpha: float = 1e-3
    convergence: bool = True
    ladder: tuple[int, ...] = config.CONVERGENCE_LADDER
    replicas: int = config.CONVERGENCE_REPLICAS
    max_growth: int = config.CONVERGENCE_MAX_GROWTH
    bounces: bool | None = None
    detect: Detect | None = None
    reference: str | None = None
    same_estimator: bool | None = None
    splatting: bool | None = None
    heavy_tail_guard: bool | None = None
    options: Mapping[str, int | float | bool | str] | None = None
    resolution: tuple[int, int] | None = None
    out_dir: str | os.PathLike | None = None
    name: str | None = None
    processes: int | None = None
    jobs: int | None = None
    timeout: float = config.DEFAULT_TIMEOUT
    variance_replicas: int | None = None
    seed_offset: int = 0
    judge_independence: bool = False
    tolerance: float | None = None
    max_spp: int | None = None
    max_seconds: float | None = None


FIELDS = frozenset(field.name for field in dataclasses.fields(Settings))


def settings_of(settings: Settings | None, keywords: Mapping, where: str,
                aliases: Mapping[str, str] | None = None) -> Settings:
    """``settings`` (default ``Settings()``) with ``keywords`` replacing its fields.

    ``aliases`` maps a function's older keyword names to fields; any other keyword that is
    not a field is a ``TypeError`` naming ``where`` (the function), as Python's own.
    """
    aliases = aliases or {}
    chosen = {aliases.get(name, name): value for name, value in keywords.items()}
    unknown = sorted(set(chosen) - FIELDS)
    if unknown:
        raise TypeError(f"{where}() got an unexpected keyword argument {unknown[0]!r}")
    base = Settings() if settings is None else settings
    return dataclasses.replace(base, **chosen) if chosen else base
