"""The checks a submission is graded on, their parts, points, limits and statistical budget.

A *check* is one scene x one integrator. It runs :func:`mitsuba_refs.verdicts.compare.compare` with a
``render`` hook that renders in the student's isolated process
(:mod:`autograder.isolation.process`) and scores its parts:

``mean``         the image agrees with Mitsuba's (tile + whole-image z test);
``variance``     the per-sample variance is at most 1.5x that of Mitsuba's run of the *same*
                 estimator (one-sided; the same rule for every check, see score_parts);
``convergence``  the error falls at least as fast as N^-1/2 and shows no bias floor (one-sided:
                 only an error that falls too slowly, as reused random numbers make it, fails).

Variance and convergence points are awarded only when the mean is right: they grade the
quality of a correct estimator. When anything fails, the check also renders the student's
integrator at max_depth = 1, 2, 3 against the per-bounce references to say which bounce
breaks first (evidence for the hints, never scored), and writes the z-map pictures.

Checks are grouped into *assignments* (``ASSIGNMENTS``: path tracing, and the lecture's later
methods), each graded as a submission of its own (``--assignment`` of the pytest plugin).

Error budget
------------
Every scored part is one statistical test. A correct submission to an assignment must lose points with
probability at most ``SUBMISSION_ALPHA`` = 1e-3 in total, so each of the ``N`` scored parts
runs at ``alpha = SUBMISSION_ALPHA / N`` (Bonferroni, valid under any dependence; the mean,
variance and convergence tests each control their own internal families at that level).
"""
from __future__ import annotations

import dataclasses
import os
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mitsuba_refs.reference import config as refs_config
from mitsuba_refs.reference.cache import get_reference
from mitsuba_refs.report.text import closing_lines
from mitsuba_refs.report.wording import convergence_verdict, mean_verdict, variance_policy_verdict
from mitsuba_refs.settings import Settings
from mitsuba_refs.stats import MAX_VARIANCE_RATIO, ErrorBudget, compare_means
from mitsuba_refs.stats.mean import MeanAgreement
from mitsuba_refs.verdicts.compare import TEST_SEED, Comparison, compare, write_pictures
from mitsuba_refs.verdicts.estimators import BOUNCE_REFERENCE, SPLATTING, reference_integrator
from mitsuba_refs.verdicts.scenes import default_params
from pathtracer.core.progress import Progress
from pathtracer.render.splats import replica_count

from .contract import refusal
from .hints.explain import Evidence, camera_evidence, camera_findings, explain, independence
from .isolation.process import SOLUTION, Limits, StudentFailure, StudentProcess
from .replicas import REPLICAS, reported_variance_finding, scored_render

#: Chance that grading a correct submission costs it any point (whole submission).
SUBMISSION_ALPHA = 1e-3
#: Default samples per pixel of a check's mean/variance render (``Check.spp``; the references
#: have 4096). Checks whose estimator is noisier render more, so that every integrator check's
#: mean part detects a global bias of 1.5 % with probability >= 0.95 (``python -m
#: autograder.power``; docs/autograder.md, "Power").
SPP = refs_config.TEST_MAX_SPP
#: Memory limit of the student's process (address space; the reference needs ~330 MB).
MEMORY_MB = 640
#: Most stdout + stderr a submission may print per test.
OUTPUT_BYTES = 1 << 20
#: Multiplies every time limit (``AUTOGRADER_TIME_SCALE``; the project's CI sets it > 1 because
#: its machines are shared, Gradescope runs with 1).
TIME_SCALE = float(os.environ.get("AUTOGRADER_TIME_SCALE", "1"))
#: Depths of the per-bounce sweep (explanations only).
BOUNCE_DEPTHS = refs_config.PER_BOUNCE_DEPTHS
#: Samples per pixel of the per-bounce sweep: explanations only, never scored, so the 64 spp the
#: hint rules were tuned at, not the check's scoring spp (a failing submission must still finish
#: inside its time limit with its explanations).
BOUNCE_SPP = SPP
#: Convergence test of a graded check: ladder, renders at its top level, most growth while
#: rare paths dominate (mitsuba_refs.verdicts.convergence.convergence_test). Equal work per level: 256
#: image-spp (64 renders at 1 spp ... 1 at 64), at most 512, inside the time limits.
CONVERGENCE = dict(ladder=(1, 4, 16, 64), replicas=1, max_growth=2)


@dataclass(frozen=True)
class Check:
    """One graded comparison.

    Attributes
    ----------
    id : str  unique, also the pytest parameter id
    integrator : str  the student's integrator graded (``INTEGRATORS`` key)
    scene : str  built-in scene (the committed references' film size)
    parts : tuple of (part, points)
    seconds : float  wall-clock limit of the student's process for the whole check
    spp : int  samples per pixel of the scored mean/variance render
    camera : bool  grade the student's ``camera_rays`` (with the reference ``direct``)
    glass : bool  a scene with glass (revealed after the due date; glass-specific hints)
    title : str
    max_depth : int, optional  render (and compare) at this max_depth instead of the scene's
        unbounded default: an off-by-one in the depth limit is invisible at max_depth = -1
    rr_depth : int, optional  the depth where Russian roulette starts, instead of the scene's;
        ``rr_depth = max_depth`` turns roulette off, so that every roulette rule gives the
        reference's estimator on that check
    assignment : str  the assignment (``ASSIGNMENTS`` key) the check belongs to
    """

    id: str
    integrator: str
    scene: str
    parts: tuple
    seconds: float
    spp: int = SPP
    camera: bool = False
    glass: bool = False
    title: str = ""
    max_depth: int | None = None
    rr_depth: int | None = None
    assignment: str = "path-tracing"

    @property
    def points(self) -> float:
        return float(sum(p for _, p in self.parts))


#: max_depth (= rr_depth: no roulette) of the glass checks but ``direct-glass``: 8 segments keep
#: 98.6 % of ``cornell-caustics``' unbounded image (``path_nee``) and are ``glass-cube``'s default.
GLASS_DEPTH = 8


def _cornell(integrator, seconds, title, spp=SPP, scene="cornell-box"):
    where = {"cornell-box": "the Cornell box",
             "cornell-box-large-light": "the Cornell box with a large ceiling light"}[scene]
    return Check(f"{integrator}-cornell-box", integrator, scene,
                 (("mean", 6), ("variance", 2), ("convergence", 2)), seconds, spp,
                 title=f"{title} on {where}")


def _glass(integrator, seconds, title, scene="cornell-caustics", spp=SPP):
    # Paths of up to GLASS_DEPTH segments and no Russian roulette (rr_depth = max_depth): along
    # specular chains a roulette rule sets the variance's tail, and the lecture leaves the rule
    # free (the slide's constant q = 0.5 doubles a surviving throughput, and a chain of
    # mirror and glass bounces keeps it, so its renders carry rare outliers that one render
    # cannot tell from a bias). Without roulette every correct rule renders the reference's
    # estimator here; roulette itself is graded on the Cornell box. Mean only: the variance
    # part is the Cornell and lights checks' (docs/autograder.md, "Variance policy").
    what = {"cornell-caustics": "a mirror and a glass sphere",
            "cornell-caustics-large-light": "a mirror and a glass sphere under a large light",
            "glass-cube": "a glass cube (total internal reflection)"}[scene]
    depth = {} if integrator == "direct" else {"max_depth": GLASS_DEPTH, "rr_depth": GLASS_DEPTH}
    return Check(f"{integrator}-glass", integrator, scene, (("mean", 5),),
                 seconds, spp, glass=True, title=f"{title} with {what}", **depth)


def _lights(integrator, seconds, title, max_depth=3, spp=SPP, scene="cornell-lights"):
    # Two lights of different size and power, a glossy sphere, and (for the path tracers) a
    # finite max_depth: what the one-light, all-diffuse, unbounded Cornell box cannot see.
    depth = f" at max_depth={max_depth}" if max_depth is not None else ""
    return Check(f"{integrator}-lights", integrator, scene,
                 (("mean", 4), ("variance", 1)), seconds, spp, max_depth=max_depth,
                 title=f"{title} with two lights and a glossy sphere{depth}")


def check_params(check: Check) -> dict:
    """Scene parameters of a check: the references' film size, and its max_depth and rr_depth
    if set."""
    params = default_params(check.scene)
    if check.max_depth is not None:
        params["max_depth"] = check.max_depth
    if check.rr_depth is not None:
        params["rr_depth"] = check.rr_depth
    return params


#: The graded checks, in order. ``spp``: each integrator check's mean part detects a global bias
#: of 1.5 % with probability >= 0.95 at ALPHA (python -m autograder.power). The ``path_bsdf``
#: checks get there by their scenes, not by samples: on the original scenes BSDF sampling alone
#: would need 1792-1920 spp, more than the 3 minutes a submission may take on one core.
#: Time limits are 2.3-3x the reference solution's time on one core (docs/autograder.md) and add
#: up to less than Gradescope's default 10-minute timeout even if every test of a submission hangs.
CHECKS = (
    # BSDF sampling alone finds a light only by chance: its checks use variants of the scenes
    # with larger, dimmer lights of the same power (mitsuba_refs.reference.config.GRADING_SCENES).
    _cornell("path_bsdf", 60, "Path tracing with BSDF sampling (slide 'Path Tracing')", spp=320,
             scene="cornell-box-large-light"),
    _cornell("path_nee", 75, "Path tracing with shadow rays (slide 'Path Tracing with Shadow Rays')", spp=256),
    _cornell("path", 80, "Path tracing with MIS (slide 'Path Tracing Algorithm')", spp=256),
    _cornell("direct", 35, "Direct illumination (slide 'Direct Illumination')", spp=512),
    _glass("path_bsdf", 40, "Path tracing with BSDF sampling", spp=320,
           scene="cornell-caustics-large-light"),
    _glass("path_nee", 70, "Path tracing with shadow rays", spp=448),
    # The cube, not a sphere: inside a sphere no ray ever meets total internal reflection,
    # so Schlick's approximation (0.5 % on the spheres) would go unnoticed; here it is +7 %.
    _glass("path", 50, "Path tracing with MIS", scene="glass-cube", spp=384),
    _glass("direct", 25, "Direct illumination", spp=512),
    # max_depth = 3 (two segments after the camera ray): an off-by-one depth limit adds or
    # drops a whole bounce; with two lights, forgetting the 1/N light choice halves direct light.
    _lights("path_bsdf", 20, "Path tracing with BSDF sampling", spp=320,
            scene="cornell-lights-large"),
    _lights("path_nee", 25, "Path tracing with shadow rays", spp=640),
    _lights("path", 25, "Path tracing with MIS", spp=640),
    _lights("direct", 25, "Direct illumination", max_depth=None, spp=768),
    # Not left-right symmetric, 4:3, a light whose edges sit mid-pixel: a mirrored image, the
    # field of view on the wrong axis and rays through pixel centres all change the mean.
    Check("camera", "direct", "cornell-lights", (("mean", 5),), 10, camera=True,
          title="Perspective camera (camera_rays)"),
)

#: The ``media`` assignment: volumetric path tracing on ``media-box`` (a fog cube behind an
#: index-matched null boundary, floating above the floor of a box lit from the ceiling; 32 x 32).
#: ``volpath_phase`` (phase and BSDF sampling only) has no Mitsuba estimator of its own: mean
#: and convergence only, against Mitsuba's ``volpath``. ``spp``: a 1.5 % global bias is
#: detected with probability >= 0.95 at the assignment's ALPHA, with volpath_phase's own
#: per-sample variance (3.7-3.8x volpath's, measured; 1216 spp suffice up to 4x) counted. Time limits 2.8x and 2.7x the
#: reference solution's time on one core (21 s, 26 s; docs/autograder.md, "The media assignment").
MEDIA_CHECKS = (
    Check("volpath_phase-media", "volpath_phase", "media-box", (("mean", 6), ("convergence", 2)),
          60, spp=1216, assignment="media",
          title="Volumetric path tracing with phase-function sampling, fog behind an "
                "index-matched boundary"),
    Check("volpath-media", "volpath", "media-box",
          (("mean", 6), ("variance", 2), ("convergence", 2)), 70, spp=384, assignment="media",
          title="Volumetric path tracing with shadow rays through the fog and MIS"),
)

#: The light-tracing assignment (slide 'Light Tracing'): the student writes the light tracer's
#: ``splat`` (paths from the lights, importance transport) and the camera's side of each
#: connection (``connect_to_camera``, ``camera_importance``). One check, mean only: a light
#: tracer's samples belong to no pixel, its variance comes from 8 replicas (7 degrees of
#: freedom per pixel), and a variance part would add a test without adding a mistake it sees.
#: 256 spp (W H 256 light paths): a 1.5 % global bias fails the mean part with probability
#: >= 0.95 (python -m autograder.power --assignment light-tracing; docs/autograder.md).
LIGHT_CHECKS = (
    # A red lamp inside a glass sphere and a cyan ceiling light: the 1/eta^2 radiance scaling
    # applied to importance scales only the red channel (eta^2 = 2.26); the room is not
    # symmetric, so splats in mirrored pixels change the image.
    Check("light-glass-lamp", "light", "glass-lamp", (("mean", 10),), 35, spp=256,
          title="Light tracing (slide 'Light Tracing') with a lamp inside glass",
          assignment="light-tracing"),
)

#: Assignment name -> its checks. Each assignment is graded as a submission of its own (its own
#: Gradescope autograder, ``--assignment``): its own points, time and error budget.
ASSIGNMENTS = {
    "path-tracing": CHECKS,
    "media": MEDIA_CHECKS,
    "light-tracing": LIGHT_CHECKS,
}
#: Every check of every assignment (ids are unique across assignments).
ALL_CHECKS = tuple(check for checks in ASSIGNMENTS.values() for check in checks)
CHECKS_BY_ID = {c.id: c for c in ALL_CHECKS}
DEFAULT_ASSIGNMENT = "path-tracing"


def checks_of(assignment: str = DEFAULT_ASSIGNMENT) -> tuple:
    """The checks of ``assignment``; a ValueError that lists the assignments if it is unknown."""
    if assignment not in ASSIGNMENTS:
        raise ValueError(f"unknown assignment {assignment!r}; the assignments are "
                         f"{', '.join(ASSIGNMENTS)}")
    return ASSIGNMENTS[assignment]


def budget(assignment: str = DEFAULT_ASSIGNMENT) -> ErrorBudget:
    """The error budget of one submission to ``assignment``: one registered test per scored part."""
    b = ErrorBudget(SUBMISSION_ALPHA)
    for check in checks_of(assignment):
        for part, _ in check.parts:
            b.register(f"{check.id}/{part}")
    return b


def alpha_of(check: Check) -> float:
    """Per-test level of every scored part of ``check`` (its assignment's Bonferroni share).

    A check that is not one of its assignment's (an ad-hoc check built by a test or a course)
    is graded at the level of one of the assignment's own parts: adding it to a submission
    does not dilute the others.
    """
    parts = budget(check.assignment)
    name = f"{check.id}/{check.parts[0][0]}"
    return parts.alpha(name) if name in parts.weights else parts.suite_alpha / parts.n_tests


#: Per-test level of every scored part of the path-tracing assignment.
ALPHA = alpha_of(CHECKS[0])


@dataclass
class Part:
    """One scored part of a check (mean, variance or convergence): points won of the most, and why."""

    name: str
    points: float
    max_points: float
    passed: bool
    detail: str


@dataclass
class CheckResult:
    """What a check found: scored parts, hints (with numbers), pictures, the report."""

    check: Check
    parts: list[Part] = field(default_factory=list)
    hints: list[str] = field(default_factory=list)
    pictures: dict[str, str] = field(default_factory=dict)
    failure: str = ""
    failure_kind: str = ""
    comparison: Comparison | None = None
    bounce: dict[int, MeanAgreement] | None = None
    seconds: float = 0.0
    findings: list[str] = field(default_factory=list)    # measured on every run (camera geometry)

    @property
    def score(self) -> float:
        return float(sum(p.points for p in self.parts))

    @property
    def max_score(self) -> float:
        return self.check.points

    @property
    def passed(self) -> bool:
        return not self.failure and all(p.passed for p in self.parts)

    def report(self) -> str:
        """The text the student reads on Gradescope."""
        c = self.check
        lines = [f"{c.title}: {c.integrator} on {c.scene}, {c.spp} spp, compared with Mitsuba 3 "
                 f"({self.score:g}/{self.max_score:g} points)"]
        if self.failure:
            lines.append(f"FAILED: {self.failure}")
        for p in self.parts:
            status = "ok  " if p.passed else "FAIL"
            lines.append(f"  [{status}] {p.name:<11} {p.points:g}/{p.max_points:g}  {p.detail}")
        if self.bounce:
            lines.append("  per bounce: " + "; ".join(
                f"max_depth={d}: {'agrees' if r.agree else 'DISAGREES'} "
                f"(x{1 + r.rel_bias:.3f})" for d, r in sorted(self.bounce.items())))
        for finding in self.findings:
            lines.append(f"  {finding}")
        lines += closing_lines(self.hints, self.pictures, self.seconds)
        return "\n".join(lines)


def run_check(check: Check, impl: str, *, out_dir=None, seed_offset: int = 0,
              limits: Limits | None = None, history: dict | None = None,
              alpha: float | None = None, trusted: bool = False,
              explain=explain) -> CheckResult:
    """Grade one check of implementation ``impl`` (a ``.py`` file, a package folder, or
    ``"autograder.solution"``).

    Parameters
    ----------
    out_dir : path, optional  where z-map pictures go (failed checks only)
    seed_offset : int  added to every render seed (false-failure calibration)
    limits : Limits, optional  default: the check's time limit, MEMORY_MB, OUTPUT_BYTES
    history : dict, optional  ``check id -> CheckResult`` of earlier checks (hints compare them)
    alpha : float, optional  per-part level (default: :func:`alpha_of` the check)
    trusted : bool  grade in the solution runtime without the refusal check (the reference
        solution, the bug zoo and the correct alternatives; never a student's submission)
    explain : callable  the hints of a failed check's :class:`~autograder.hints.explain.Evidence`
        (default :func:`autograder.hints.explain.explain`; :mod:`autograder.hints.accuracy`
        passes one that also keeps the evidence)
    """
    start = time.perf_counter()
    alpha = alpha_of(check) if alpha is None else alpha
    limits = limits or Limits(check.seconds * TIME_SCALE, MEMORY_MB, OUTPUT_BYTES)
    result = CheckResult(check)
    camera = "student" if check.camera else "reference"
    run_as = f"reference:{check.integrator}" if check.camera else check.integrator

    main_render = {}

    trusted = trusted or impl == SOLUTION
    refused = "" if trusted else refusal(impl)
    try:
        if refused:
            raise StudentFailure(f"refused: {refused}", "refused")
        student = StudentProcess(impl, limits, trusted=trusted)
        student.start()
    except StudentFailure as failure:
        return _failed(result, failure, start)
    with student:
        def render(scene, integrator, params, spp, seed, processes=None, max_depth=None, **_):
            if max_depth is None:
                max_depth = check.max_depth     # the check's depth unless the sweep sets one
            return student.render(scene, run_as, params, spp, seed + seed_offset,
                                  max_depth=max_depth, camera=camera)

        def scored(scene, integrator, params, spp, seed, processes=None, max_depth=None, **_):
            # compare()'s hook: its mean-and-variance render is the scored one, from replicas
            # (autograder.replicas) unless the grader renders it itself (the camera check).
            if not (seed == TEST_SEED and max_depth is None and spp == check.spp):
                return render(scene, integrator, params, spp, seed, max_depth=max_depth)
            if not scored_replicas(check):
                main_render["image"] = render(scene, integrator, params, spp, seed)
            else:
                replicas = scored_render(render, scene, integrator, params, spp, seed,
                                         replicas=scored_replicas(check),
                                         reference_noisy=_reference_noisy(check))
                main_render["image"] = replicas.mean, replicas.variance
                main_render["replicas"] = replicas
            return main_render["image"]

        wants_convergence = any(name == "convergence" for name, _ in check.parts)
        try:
            # Without the heavy-tail guard: every check's calibration and power
            # (docs/autograder.md) were measured without it.
            settings = Settings(spp=check.spp, alpha=alpha, convergence=wants_convergence,
                                bounces=False, heavy_tail_guard=False, **CONVERGENCE)
            comparison = compare(check.scene, check.integrator, check_params(check), settings,
                                 render=scored)
        except StudentFailure as failure:
            return _failed(result, failure, start)
        result.comparison = comparison
        result.parts = score_parts(check, comparison)
        if "replicas" in main_render:
            result.findings.extend(filter(None, [reported_variance_finding(main_render["replicas"])]))
        camera_geometry = None
        if check.camera:
            # The camera's geometry is measured on every submission (a few rays, no render):
            # a mirrored or mis-sampled camera is reported even where the image hides it.
            try:
                camera_geometry = camera_evidence(check, student)
                result.findings = camera_findings(
                    camera_geometry, all(p.passed for p in result.parts))
            except StudentFailure as failure:
                result.findings = [f"camera geometry not measured: {str(failure).splitlines()[0]}"]
        if not all(p.passed for p in result.parts):
            evidence = Evidence(check=check, comparison=comparison, history=history or {})
            try:
                if check.camera:
                    evidence.camera = camera_geometry
                elif check.integrator in SPLATTING:
                    # No camera rays to probe and no per-bounce light references: the light
                    # rules read the scored render itself (hints.explain.light_hints).
                    evidence.images = _images(check, main_render)
                else:
                    evidence.sweep = _bounce_sweep(check, render, alpha=alpha)
                    result.bounce = {d: s[0] for d, s in evidence.sweep.items()} or None
                    evidence.probe = student.probe(check.scene, default_params(check.scene),
                                                   check.integrator)
                    if "replicas" in main_render:
                        # Do the reported variances predict how much independent renders
                        # differ? (Samples of a pixel that share random numbers do not.)
                        evidence.independence = independence(*main_render["replicas"].halves())
            except StudentFailure as failure:
                evidence.incomplete = str(failure).splitlines()[0]
            result.hints = explain(evidence)
            if out_dir is not None:
                result.pictures = _pictures(result, comparison, main_render, Path(out_dir))
    result.seconds = time.perf_counter() - start
    return result


def _failed(result: CheckResult, failure: StudentFailure, start: float) -> CheckResult:
    """A check whose student process failed: zero points, the failure as the message."""
    result.failure, result.failure_kind = str(failure), failure.kind
    result.parts = [Part(name, 0.0, float(points), False, "not graded: see above")
                    for name, points in result.check.parts]
    result.seconds = time.perf_counter() - start
    return result


def score_parts(check: Check, comparison) -> list:
    """Points of each part from a comparison (variance/convergence need a right mean).

    The variance part applies one policy to every check: the per-sample variance may be at
    most ``MAX_VARIANCE_RATIO`` (1.5) times the reference's, a one-sided test at the part's
    level (``VarianceAgreement.policy_*``; docs/statistics.md). Another correct estimator
    (balance heuristic, constant-q roulette, another order of random numbers) passes; uniform
    hemisphere sampling (~1.9x) does not. The two-sided equality verdict is not scored.
    """
    mean_ok = bool(comparison.mean.agree)
    parts = []
    for name, points in check.parts:
        if name == "mean":
            ok, detail = mean_ok, mean_verdict(comparison.mean)
        elif name == "variance":
            test = comparison.variance
            ok = mean_ok and test is not None and bool(test.policy_agree)
            if test is not None and test.max_ratio != MAX_VARIANCE_RATIO:
                raise ValueError(f"variance compared against {test.max_ratio}x, the policy is "
                                 f"{MAX_VARIANCE_RATIO}x")
            detail = variance_policy_verdict(test) if test is not None else "not compared"
            if not mean_ok:
                detail = "needs a right mean first; " + detail
        elif name == "convergence":
            test = comparison.convergence
            ok = mean_ok and test is not None and bool(test.passed)
            detail = convergence_verdict(test) if test is not None else "not run"
            if not mean_ok:
                detail = "needs a right mean first; " + detail
        else:
            raise ValueError(f"unknown part {name!r}")
        parts.append(Part(name, float(points) if ok else 0.0, float(points), ok, detail))
    return parts


def scored_replicas(check: Check) -> int | None:
    """Replicas of the check's scored render (:mod:`autograder.replicas`): REPLICAS, or the
    largest divisor of ``spp`` below it; None where the grader renders it itself (the camera
    check: the student sends rays, not images)."""
    return None if check.camera else replica_count(check.spp, REPLICAS)


def _reference_noisy(check: Check) -> bool:
    """Whether the check's reference has any noise (then identical replicas are a failure)."""
    reference = get_reference(check.scene, check_params(check),
                              reference_integrator(check.integrator))
    return bool(np.any(reference.var > 0))


def _images(check: Check, main_render) -> dict | None:
    """The scored render and its reference, for the rules that read images (light tracing)."""
    if "image" not in main_render:
        return None
    reference = get_reference(check.scene, check_params(check),
                              reference_integrator(check.integrator))
    mean, variance = main_render["image"]
    return dict(mean=mean, var=variance, n=check.spp, ref_mean=reference.mean,
                ref_var=reference.var, ref_n=reference.n)


def _bounce_sweep(check: Check, render, alpha: float) -> dict:
    """{max_depth: (MeanAgreement, test mean, reference mean)}: the student's integrator vs
    Mitsuba's per-bounce references, ``path`` (``volpath`` for the volumetric integrators;
    explanations only, never scored)."""
    params = default_params(check.scene)
    estimator = BOUNCE_REFERENCE.get(check.integrator, "path")   # volpath for the media checks
    depths = [d for d in BOUNCE_DEPTHS if not (check.integrator == "direct" and d > 2)
              and not (check.max_depth is not None and d > check.max_depth > 0)]
    out = {}
    for depth in depths:
        reference = get_reference(check.scene, {**params, "max_depth": depth}, estimator)
        mean, variance = render(check.scene, check.integrator, params, BOUNCE_SPP,
                                TEST_SEED + depth, max_depth=depth)
        out[depth] = (compare_means(mean, variance, BOUNCE_SPP, reference.mean, reference.var,
                                    reference.n, alpha=alpha), mean, reference.mean)
    return out


def _pictures(result: CheckResult, comparison, main_render, out_dir: Path) -> dict:
    """The z-map (and variance / convergence) pictures of a failed check."""
    if "image" not in main_render:
        return {}
    check = result.check
    reference = get_reference(check.scene, check_params(check),
                              reference_integrator(check.integrator))
    mean, variance = main_render["image"]
    out_dir.mkdir(parents=True, exist_ok=True)
    try:    # named after the check (a comparison is frozen: a copy with the check's id)
        return write_pictures(dataclasses.replace(comparison, scene=check.id), out_dir, mean,
                              variance, reference)
    except Exception as error:  # pictures are a courtesy: never fail grading on them
        return {"error": f"could not draw pictures: {error}"}


def grade(impl: str, checks=CHECKS, out_dir=None, seed_offset: int = 0, log=None,
          trusted: bool = False, time_scale: float | None = None) -> list:
    """Run every check of ``impl`` in order; returns the CheckResults.

    ``time_scale`` multiplies the checks' time limits (default :data:`TIME_SCALE`).
    """
    history = {}
    scale = TIME_SCALE if time_scale is None else time_scale
    checks = list(checks)
    progress = Progress(len(checks), "grading", "checks") if log else None
    for check in checks:
        result = run_check(check, impl, out_dir=out_dir, seed_offset=seed_offset, history=history,
                           trusted=trusted, limits=Limits(check.seconds * scale, MEMORY_MB, OUTPUT_BYTES))
        history[check.id] = result
        if log:
            log(result.report())
            progress.advance()
    if progress is not None:
        progress.close()
    return list(history.values())
