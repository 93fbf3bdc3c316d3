"""The course autograder (autograder/): reference -> full marks, skeleton -> zero, every
bug-zoo mutant loses points with the expected hint, misbehaving submissions fail cleanly
while results.json stays valid.

Runtime: the reference's checks (every assignment's) and the mutants' checks run concurrently
in one pool (each check is its own student process), ~4 min on 2 cores, of which the media
assignment's 2 reference checks and 4 mutants are ~2.5 min of CPU; everything else is seconds.
Time limits are scaled by ``CI_TIME_SCALE`` because CI machines are shared.
"""
from __future__ import annotations

import ast
import glob
import importlib.metadata
import json
import os
import re
import signal
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from autograder import grading, results
from autograder.contract import refusal
from autograder.isolation.process import Limits, StudentProcess
from mitsuba_refs.report.wording import variance_policy_verdict, verdict_line

ROOT = Path(__file__).resolve().parent.parent
ZOO = ROOT / "tests" / "bugzoo"
MISBEHAVING = ZOO / "misbehaving"
HOSTILE = ROOT / "tests" / "hostile"
CI_TIME_SCALE = float(os.environ.get("AUTOGRADER_CI_TIME_SCALE", "6"))
MUTANTS = sorted(p for p in glob.glob(str(ZOO / "*.py")) if not Path(p).name.startswith("_"))
ATTACKS = sorted(p for p in glob.glob(str(HOSTILE / "*.py")) if not Path(p).name.startswith("_"))
#: Words a hostile submission's message contains when its attack worked (tests/hostile).
ESCAPES = ("LEAK", "WROTE", "ESCAPED")


def constants(path) -> SimpleNamespace:
    """A submission's module-level constants, read without running its code."""
    found = {}
    for node in ast.parse(Path(path).read_text()).body:
        if isinstance(node, ast.Assign) and len(node.targets) == 1 and \
                isinstance(node.targets[0], ast.Name) and node.targets[0].id.isupper():
            try:
                found[node.targets[0].id] = ast.literal_eval(node.value)
            except ValueError:
                if isinstance(node.value, ast.Call) and getattr(node.value.func, "id", "") == "dict":
                    found[node.targets[0].id] = {k.arg: ast.literal_eval(k.value)
                                                 for k in node.value.keywords}
    return SimpleNamespace(**found)


#: Correct implementations written differently from the reference (tests/alternatives/): each
#: must get full marks on every check. Listed here so that a calibration sweep can grade them.
ALTERNATIVES_DIR = ROOT / "tests" / "alternatives"
ALTERNATIVES = ("balance_heuristic", "constant_roulette", "other_random_order",
                "light_choice_by_power")

def _limits(check):
    return Limits(check.seconds * CI_TIME_SCALE, grading.MEMORY_MB, grading.OUTPUT_BYTES)


@pytest.fixture(scope="session")
def graded():
    """CheckResults of the reference (every check of every assignment) and of every mutant
    (its target check)."""
    jobs = {("reference", c.id): (c, "autograder.solution") for c in grading.ALL_CHECKS}
    for path in MUTANTS:
        module = constants(path)
        jobs[(Path(path).stem, module.CHECK)] = (grading.CHECKS_BY_ID[module.CHECK], path)
    for name in ALTERNATIVES:
        path = ALTERNATIVES_DIR / f"{name}.py"
        for c in alternative_checks(path):
            jobs[(f"alternative:{name}", c.id)] = (c, str(path))
    workers = max(2, os.cpu_count() or 1)
    with ThreadPoolExecutor(workers) as pool:
        futures = {key: pool.submit(grading.run_check, check, impl, limits=_limits(check),
                                    trusted=True)
                   for key, (check, impl) in jobs.items()}
        return {key: f.result() for key, f in futures.items()}


@pytest.mark.parametrize("assignment", list(grading.ASSIGNMENTS))
def test_budget_is_within_one_in_a_thousand(assignment):
    """Each assignment is a submission of its own: its parts share 1e-3."""
    checks = grading.checks_of(assignment)
    b = grading.budget(assignment)
    assert b.n_tests == sum(len(c.parts) for c in checks)
    assert b.worst_case_suite_alpha() <= grading.SUBMISSION_ALPHA * (1 + 1e-9)
    for check in checks:
        assert check.assignment == assignment
        assert grading.alpha_of(check) == pytest.approx(grading.SUBMISSION_ALPHA / b.n_tests)
    assert grading.ALPHA == grading.alpha_of(grading.CHECKS[0])
    # An ad-hoc check (not registered) is graded at one part's level, not a KeyError.
    adhoc = grading.Check("adhoc", "path", "quad-light", (("mean", 1),), 10, assignment=assignment)
    assert grading.alpha_of(adhoc) == pytest.approx(grading.SUBMISSION_ALPHA / b.n_tests)


def test_check_ids_are_unique_across_assignments():
    assert len(grading.CHECKS_BY_ID) == len(grading.ALL_CHECKS)


@pytest.mark.parametrize("assignment", list(grading.ASSIGNMENTS))
def test_time_limits_fit_gradescope(assignment):
    """Even a submission whose every test hangs to its limit is graded before Gradescope's
    default autograder timeout of 10 minutes ("It took longer than 600 seconds to run"),
    with 60 s left for the grader itself (start-up, references, statistics, results.json).
    The bound was 270 s (5 minutes) while checks rendered 64 spp; the spp that give every
    check its power (docs/autograder.md, "Power") need limits of 445 s."""
    assert sum(c.seconds for c in grading.checks_of(assignment)) <= 600 - 60


def test_reference_solution_gets_full_marks(graded):
    for check in grading.ALL_CHECKS:
        result = graded[("reference", check.id)]
        assert result.passed and result.score == check.points, result.report()


def test_mutant_count():
    assert len(MUTANTS) >= 15


@pytest.mark.parametrize("path", MUTANTS, ids=[Path(p).stem for p in MUTANTS])
def test_mutant_loses_points_with_the_expected_hint(graded, path):
    module = constants(path)
    name = Path(path).stem
    result = graded[(name, module.CHECK)]
    assert result.score < result.max_score, result.report()
    assert not result.failure, result.report()          # a wrong image, not a crash
    text = " ".join(result.hints).lower()
    assert any(k.lower() in text for k in module.EXPECTED), result.report()
    # Numbers a student can read: a band with no light in the reference is said in words.
    assert not re.search(r"\bx?(nan|inf)\b", text), result.report()
    if getattr(module, "PARTIAL", False):
        assert 0 < result.score < result.max_score, result.report()
        assert result.parts[0].name == "mean" and result.parts[0].passed


def alternative_checks(path) -> list:
    """The checks an alternative is graded on: those of the integrators it changes (the others
    run the reference's own classes: test_alternatives_are_listed checks that), less the scenes
    where its images are the reference's bit for bit (``SAME_AS_REFERENCE``, proved by
    test_alternatives_equal_the_reference_where_not_graded) or outside ``GRADED_SCENES``."""
    module = constants(path)
    skipped = set(getattr(module, "SAME_AS_REFERENCE", ()))
    graded = set(getattr(module, "GRADED_SCENES", [c.scene for c in grading.CHECKS]))
    return [c for c in grading.CHECKS if c.integrator in module.CHANGES and not c.camera
            and c.scene in graded - skipped]


def _load_alternative(name, monkeypatch):
    import importlib.util
    monkeypatch.syspath_prepend(str(ALTERNATIVES_DIR))
    spec = importlib.util.spec_from_file_location(f"alternative_{name}",
                                                  ALTERNATIVES_DIR / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("name", [n for n in ALTERNATIVES if getattr(
    constants(ALTERNATIVES_DIR / f"{n}.py"), "SAME_AS_REFERENCE", ())])
def test_alternatives_equal_the_reference_where_not_graded(name, monkeypatch):
    """Where an alternative is not graded because its estimator is the reference's there, its
    renders (at each such check's settings, small) equal the reference's bit for bit."""
    from pathtracer import load_scene, render
    from pathtracer.integrators import INTEGRATORS as REFERENCE
    module = _load_alternative(name, monkeypatch)
    checks = [c for c in grading.CHECKS if c.integrator in module.CHANGES and not c.camera
              and c.scene in module.SAME_AS_REFERENCE]
    assert {c.scene for c in checks} == set(module.SAME_AS_REFERENCE)
    for check in checks:
        params = dict(grading.check_params(check), width=16, height=12)
        options = {} if check.max_depth is None else {"max_depth": check.max_depth}
        images = [render(load_scene(check.scene, **params), cls(), spp=8, seed=3, processes=1,
                         **options)
                  for cls in (module.INTEGRATORS[check.integrator], REFERENCE[check.integrator])]
        np.testing.assert_array_equal(images[0].mean, images[1].mean, err_msg=check.id)
        np.testing.assert_array_equal(images[0].variance, images[1].variance, err_msg=check.id)


def test_alternatives_are_listed(monkeypatch):
    from pathtracer.integrators import INTEGRATORS as REFERENCE
    found = {Path(p).stem for p in glob.glob(str(ALTERNATIVES_DIR / "*.py"))
             if not Path(p).name.startswith("_")}
    assert found == set(ALTERNATIVES)
    for name in ALTERNATIVES:
        module = _load_alternative(name, monkeypatch)
        differ = {k for k, cls in module.INTEGRATORS.items() if cls is not REFERENCE.get(k)}
        assert differ == set(module.CHANGES), name


@pytest.mark.parametrize("name", ALTERNATIVES)
def test_correct_alternative_gets_full_marks(graded, name):
    """A right answer written differently (another MIS heuristic, roulette rule, order of
    random numbers, light choice) keeps every point of every part of every check."""
    lost = [graded[(f"alternative:{name}", c.id)]
            for c in alternative_checks(ALTERNATIVES_DIR / f"{name}.py")]
    lost = [r for r in lost if not (r.passed and r.score == r.max_score)]
    assert not lost, "\n\n".join(r.report() for r in lost)


# -- isolation ---------------------------------------------------------------------------

QUICK = grading.Check("quick", "path", "quad-light", (("mean", 1),), 10)


@pytest.mark.parametrize("name, kind, words", [
    ("hang", "timeout", "time limit"),
    ("crash_exit", "crash", "exit code 3"),
    ("sys_exit", "exception", "SystemExit"),
    ("segfault", "crash", "SIGSEGV"),
    ("raises", "exception", "index out of range"),
    ("nan", "output", "NaN"),
    ("wrong_shape", "output", "shape"),
    ("int_dtype", "output", "dtype"),
    ("chatty", "output", "printed more than"),
    ("memory_hog", "memory", "out of memory"),
])
def test_misbehaving_submission_fails_cleanly(name, kind, words):
    seconds = 4 if name == "hang" else QUICK.seconds * CI_TIME_SCALE
    result = grading.run_check(QUICK, str(MISBEHAVING / f"{name}.py"),
                               limits=Limits(seconds, grading.MEMORY_MB, 64 * 1024), trusted=True)
    assert result.score == 0 and not result.passed
    assert result.failure_kind == kind, result.failure
    assert words in result.failure, result.failure


def _runtime_processes() -> list:
    """Processes still alive that run from one of this test session's student runtimes
    (a fork keeps its parent's command line, so escaped children count too)."""
    from autograder.isolation import runtime
    folders = [str(path).encode() for path in runtime._BUILT.values()]
    alive = []
    for entry in os.listdir("/proc"):
        try:
            cmdline = Path(f"/proc/{entry}/cmdline").read_bytes()
        except OSError:
            continue
        if entry.isdigit() and any(folder in cmdline for folder in folders):
            alive.append(int(entry))
    return alive


@pytest.mark.parametrize("path", ATTACKS, ids=[Path(p).stem for p in ATTACKS])
def test_hostile_submission_scores_nothing_and_leaves_nothing(path, tmp_path):
    """Each attack of tests/hostile: zero points, the expected failure, the grader alive,
    no process left, no file written, no payload run."""
    expect = constants(path).EXPECT
    markers = [Path("/tmp/autograder-hostile-pickle-ran"), Path("/tmp/autograder-hostile-daemon-ran")]
    for marker in markers:
        marker.unlink(missing_ok=True)
    seconds = 5 if expect["kind"] == "timeout" else QUICK.seconds * CI_TIME_SCALE
    result = grading.run_check(QUICK, path, limits=Limits(seconds, grading.MEMORY_MB, 64 * 1024))
    assert result.score == 0 and not result.passed, result.report()
    if expect["kind"] == "black":           # the attack ran to its end and returned black
        assert not result.failure, result.report()
    elif expect["kind"]:
        assert result.failure_kind == expect["kind"], result.report()
        assert expect["words"] in result.failure, result.report()
    assert not any(word in result.report() for word in ESCAPES), result.report()
    assert not _runtime_processes()
    import time
    time.sleep(3.5 if "daemon" in path else 0)         # the daemon would write after 3 s
    assert not any(marker.exists() for marker in markers)
    assert not (HOSTILE / "pathtracer").exists() and Path(path).exists()


MISSTATED = sorted(p for p in (HOSTILE / "misstated").glob("*.py") if not p.name.startswith("_"))


@pytest.mark.parametrize("path", MISSTATED, ids=[p.stem for p in MISSTATED])
def test_misstated_variance_scores_zero_on_the_part_it_attacks(path):
    """A submission that reports 100x or 0.1x its variance (tests/hostile/misstated): zero on the
    part the lie attacks, the parts it does not attack as they would be, and a finding that
    names the ratio; with the reported variance believed, the attack would have worked."""
    from mitsuba_refs.reference.cache import get_reference
    from mitsuba_refs.stats import compare_means, compare_variances
    from mitsuba_refs.verdicts.estimators import reference_integrator
    expect = constants(path).EXPECT
    check, trusted = grading.CHECKS_BY_ID[expect["check"]], expect.get("trusted", False)
    result = grading.run_check(check, str(path), limits=_limits(check), trusted=trusted)
    assert not result.failure, result.report()
    for part in result.parts:
        assert part.passed == (part.name not in expect["zero"]), result.report()
    ratios = [float(m.group(1)) for f in result.findings
              for m in [re.search(r"variance your renders reported is ([0-9.]+)x", f)] if m]
    assert len(ratios) == 1 and 1 / 1.5 < ratios[0] / expect["misstated"] < 1.5, result.report()
    # The control: one render at the check's spp, its reported variance believed by the
    # components it scales (the mean part's own-variance tiles and image; the variance part).
    reference = get_reference(check.scene, grading.check_params(check),
                              reference_integrator(check.integrator))
    with StudentProcess(str(path), _limits(check), trusted=trusted) as student:
        mean, variance = student.render(check.scene, check.integrator, grading.check_params(check),
                                        check.spp, 1000)
    alpha = grading.alpha_of(check)
    believed_mean = compare_means(mean, variance, check.spp, reference.mean, reference.var,
                                  reference.n, alpha=alpha)
    believed_variance = compare_variances(variance, check.spp, reference.var, reference.n,
                                          alpha=alpha)
    believed = {"mean": bool(believed_mean.agree), "variance": bool(believed_variance.policy_agree)}
    assert believed[expect["zero"][0]], (verdict_line(believed_mean), variance_policy_verdict(believed_variance))


def test_student_runtime_has_no_solution(tmp_path):
    """The runtime a submission imports from: integrators and camera are the skeleton's stubs,
    no path-class integrator, no references, no grader."""
    from autograder.isolation import runtime
    from autograder.skeleton import STUBS, stub_names
    folder = runtime.build(tmp_path / "rt")
    stubs = [(relative, name) for relative, (names, _) in STUBS.items()
             for name in ((names,) if isinstance(names, str) else names)]
    for relative, name in stubs:
        tree = ast.parse((folder / "pathtracer" / relative).read_text())
        bodies = [node.body for node in ast.walk(tree)
                  if isinstance(node, ast.FunctionDef) and node.name in stub_names(name)]
        assert len(bodies) >= len(stub_names(name)), relative
        for body in bodies:
            code = [stmt for stmt in body if not (isinstance(stmt, ast.Expr)
                                                  and isinstance(stmt.value, ast.Constant))]
            assert len(code) == 1 and isinstance(code[0], ast.Raise), relative
    assert not (folder / "pathtracer" / "integrators" / "pathclass.py").exists()
    # The volumetric algorithm is in no integrator module of the runtime: media.py's building
    # blocks are called only from the stubbed methods (volume.py keeps the bookkeeping).
    steps = {"sample_free_flight", "shadow_transmittance", "next_medium", "phase_sample",
             "null_event", "sample_bsdf"}
    for module in (folder / "pathtracer" / "integrators").glob("vol*.py"):
        calls = {getattr(node.func, "id", getattr(node.func, "attr", None))
                 for node in ast.walk(ast.parse(module.read_text())) if isinstance(node, ast.Call)}
        assert not calls & steps, (module.name, calls & steps)
    # Ungraded integrators keep their class and name, not their algorithm.
    from autograder.isolation.runtime import UNGRADED_MODULES
    from pathtracer import INTEGRATORS
    for relative in UNGRADED_MODULES:
        stub = (folder / "pathtracer" / relative).read_text()
        assert "connect" not in stub and "sample_bsdf" not in stub, relative
    probe = ("import sys; sys.path.insert(0, sys.argv[1]); "
             "from pathtracer.integrators import INTEGRATORS; print(sorted(INTEGRATORS))")
    listed = subprocess.run([sys.executable, "-c", probe, str(folder)], capture_output=True,
                            text=True, check=True, cwd=tmp_path).stdout
    assert listed.strip() == str(sorted(INTEGRATORS))
    names = {p.name for p in folder.rglob("*")}
    references = {p.name for p in (ROOT / "mitsuba_refs" / "references").iterdir()}
    assert not names & references
    # The only images are built-in scenes' inputs (an environment map, a texture).
    assert {p.parent for p in folder.rglob("*.exr")} <= {folder / "pathtracer" / "data" / "scenes"}
    assert "mitsuba_refs" not in names and "autograder" not in names
    assert {p.name for p in (folder / "grading_child").iterdir()} >= {"child.py", "wire.py"}


def test_refusal_reads_the_source(tmp_path):
    from autograder.skeleton import generate
    assert refusal(str(generate(tmp_path / "skeleton"))) == ""
    assert refusal(str(generate(tmp_path / "copy", stubs=False))) == ""
    assert refusal(str(generate(tmp_path / "light", stubs=False, assignment="light-tracing"))) == ""
    assert "imports the reference solution" in refusal(str(HOSTILE / "solution_import.py"))
    bad = tmp_path / "bad.py"
    for line in ("from pathtracer.integrators.path import PathIntegrator",
                 "import mitsuba_refs.reference.cache", "from pathtracer.camera import camera_rays",
                 "from pathtracer.camera_connection import connect_to_camera",
                 "from pathtracer import INTEGRATORS", "__import__('autograder.solution')"):
        bad.write_text(line + "\n")
        assert refusal(str(bad)), line
    bad.write_text("from pathtracer.integrators.base import Integrator\n"
                   "from pathtracer.camera import Rays\n")
    assert refusal(str(bad)) == ""
    bad.write_text("def f(:\n")
    assert "not valid Python" in refusal(str(bad))


def test_wire_rejects_what_is_not_plain_data():
    """Frames carry JSON and raw arrays; anything else is an error, never an object."""
    import pickle

    import numpy as np

    from autograder.sandbox import wire
    r, w = os.pipe()
    try:
        wire.write_frame(w, {"status": "ok"}, {"mean": np.ones((2, 3))})
        header, arrays = wire.read_frame(r, expect={"mean": ("f8", (2, 3))})
        assert header == {"status": "ok"} and arrays["mean"].sum() == 6
        wire.write_frame(w, {"status": "ok"}, {"mean": np.ones((2, 2))})
        with pytest.raises(wire.WireError, match="expected"):
            wire.read_frame(r, expect={"mean": ("f8", (2, 3))})
        os.read(r, 32)                                            # drop the unread payload
        data = pickle.dumps(("ok", object()))
        os.write(w, len(data).to_bytes(4, "big") + data)
        with pytest.raises(wire.WireError, match="not JSON"):
            wire.read_frame(r)
        os.write(w, (1 << 30).to_bytes(4, "big"))
        with pytest.raises(wire.WireError, match="header of"):
            wire.read_frame(r)
        text = b'{"arrays": [["x", "O", [1]]]}'
        os.write(w, len(text).to_bytes(4, "big") + text)
        with pytest.raises(wire.WireError, match="malformed array"):
            wire.read_frame(r)
        with pytest.raises(wire.WireTimeout):
            wire.read_frame(r, deadline=0)
    finally:
        os.close(r)
        os.close(w)


def test_media_skeleton_builds_on_its_own_volpath_phase(tmp_path):
    """The media skeleton's volpath imports the student's own volpath_phase (relatively, not
    the runtime's stub), and the reference written in the skeleton's layout renders in the
    student runtime exactly what the reference renders."""
    from autograder.skeleton import generate
    from pathtracer import load_scene, render
    skeleton = generate(tmp_path / "skeleton", assignment="media")
    assert "from .volpath_phase import VolPathPhaseIntegrator" in (skeleton / "volpath.py").read_text()
    assert refusal(str(skeleton)) == ""
    copy = generate(tmp_path / "copy", stubs=False, assignment="media")
    assert refusal(str(copy)) == ""
    params = {"width": 8, "height": 6}
    with StudentProcess(str(copy), Limits(60 * CI_TIME_SCALE)) as student:
        for name in ("volpath_phase", "volpath"):
            mean, variance = student.render("media-box", name, params, 2, 5)
            direct = render(load_scene("media-box", **params), name, spp=2, seed=5, processes=1)
            assert np.array_equal(mean, direct.mean) and np.array_equal(variance, direct.variance)


def test_skeleton_starts_in_the_student_runtime(tmp_path):
    from autograder.skeleton import generate
    package = generate(tmp_path)
    with StudentProcess(str(package), Limits(60 * CI_TIME_SCALE)) as student:
        assert "seccomp" in student.sandbox
    source = (package / "path_nee.py").read_text()
    assert "NotImplementedError" in source and "Path Tracing with Shadow Rays" in source


# -- end to end through the pytest plugin ------------------------------------------------

def _plugin_args():
    names = {ep.name for ep in importlib.metadata.entry_points(group="pytest11")}
    return [] if "autograder" in names else ["-p", "autograder.plugin"]


def _run_grader(impl, out, *extra, timeout=900, env_extra=None):
    env = dict(os.environ, AUTOGRADER_TIME_SCALE=str(CI_TIME_SCALE),
               PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    env.update(env_extra or {})
    cmd = [sys.executable, "-m", "pytest", *_plugin_args(), str(ROOT / "autograder" / "tests_for_students"),
           "--impl", str(impl), "--gradescope", str(out), "-q", "-p", "no:cacheprovider",
           "--rootdir", str(ROOT / "autograder"), *extra]
    proc = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True, timeout=timeout)
    document = json.loads(Path(out).read_text())
    results.validate(document)
    return proc, document


def test_an_interrupt_while_reading_the_reply_is_an_interrupt(monkeypatch):
    """SIGINT while the grader reads the student's reply: KeyboardInterrupt, the child gone;
    never a verdict on the submission (a crash, a malformed reply, zero points)."""
    from autograder.sandbox import wire
    honest = wire._read_exact
    reads = []

    def interrupted_read(fd, size, deadline):
        reads.append(size)
        if len(reads) == 3:                 # inside the render's reply, after the "ready" frame
            signal.raise_signal(signal.SIGINT)
        return honest(fd, size, deadline)
    monkeypatch.setattr(wire, "_read_exact", interrupted_read)
    with pytest.raises(KeyboardInterrupt):
        grading.run_check(QUICK, "autograder.solution", limits=_limits(QUICK))
    assert len(reads) >= 3 and not _runtime_processes()


def test_interrupted_grading_writes_no_grade(tmp_path):
    """Ctrl-C between two tests (tests/interrupting.py, deterministic): the finished test keeps
    its score, the rest say they were interrupted, the file says it is no grade, exit 2."""
    proc, document = _run_grader("autograder.solution", tmp_path / "results.json", "-k",
                                 "direct-cornell-box or camera", "-p", "tests.interrupting")
    assert proc.returncode == pytest.ExitCode.INTERRUPTED, proc.stdout[-2000:]
    assert document["output"] == results.INTERRUPTED
    first, second = document["tests"]
    assert first["score"] == first["max_score"] == 10, first
    assert second["score"] == 0 and second["output"] == results.NOT_RUN_INTERRUPTED, second


@pytest.mark.parametrize("assignment", list(grading.ASSIGNMENTS))
def test_skeleton_grades_zero_without_crashing(tmp_path, assignment):
    from autograder.skeleton import generate
    package = generate(tmp_path / "skeleton", assignment=assignment)
    proc, document = _run_grader(package, tmp_path / "results.json", "--assignment", assignment)
    assert document["score"] == 0
    assert len(document["tests"]) == len(grading.checks_of(assignment)), proc.stdout[-2000:]
    for test in document["tests"]:
        assert test["status"] == "failed" and "not implemented" in test["output"], test


def test_package_grades_the_assignment_it_was_built_for(tmp_path):
    import zipfile

    from autograder import package
    for name in grading.ASSIGNMENTS:
        with zipfile.ZipFile(package.build(tmp_path / f"{name}.zip", name)) as z:
            run = z.read("run_autograder").decode()
        assert f"ASSIGNMENT={name}\n" in run and '--assignment "$ASSIGNMENT"' in run, run
    with pytest.raises(ValueError, match="unknown assignment"):
        package.build(tmp_path / "other.zip", "raytracing")


def test_unknown_assignment_is_a_usage_error(tmp_path):
    cmd = [sys.executable, "-m", "pytest", *_plugin_args(), str(ROOT / "autograder" / "tests_for_students"),
           "--assignment", "raytracing", "-q", "-p", "no:cacheprovider", "--rootdir", str(ROOT / "autograder")]
    proc = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 4, proc.stdout + proc.stderr
    assert "unknown; the assignments are path-tracing" in proc.stderr, proc.stderr


def test_plugin_writes_points_visibility_and_partial_credit(tmp_path):
    zoo = ZOO / "uniform_hemisphere.py"
    proc, document = _run_grader(zoo, tmp_path / "results.json", "-k",
                                 "path_nee-cornell or camera or direct-glass", "--solution-runtime")
    tests = {t["name"].split("[")[-1].rstrip("]"): t for t in document["tests"]}
    nee = tests["path_nee-cornell-box"]
    assert nee["max_score"] == 10 and nee["score"] == 8 and nee["status"] == "failed", nee
    assert "cosine" in nee["output"]
    assert tests["camera"]["score"] == 5 and tests["camera"]["status"] == "passed"
    assert tests["direct-glass"]["visibility"] == "after_due_date"
    assert document["score"] == pytest.approx(sum(t["score"] for t in document["tests"]))


@pytest.mark.parametrize("name, scale", [("hang", "0.2"), ("crash_exit", None),
                                         ("steal_results", None)])
def test_hang_and_crash_leave_valid_results(tmp_path, name, scale):
    """A submission whose path integrator hangs, exits or attacks the results file: that test
    fails, the others are graded, results.json is valid at the end."""
    out = tmp_path / "results.json"
    extra = {"AUTOGRADER_TIME_SCALE": scale} if scale else {}
    proc, document = _run_grader(MISBEHAVING / f"{name}.py", out, "-k", "path-cornell or camera",
                                 "--solution-runtime", env_extra=extra)
    tests = {t["name"].split("[")[-1].rstrip("]"): t for t in document["tests"]}
    assert tests["path-cornell-box"]["status"] == "failed"
    assert tests["path-cornell-box"]["score"] == 0
    if scale is None:       # the camera check uses the reference integrator: it still passes
        assert tests["camera"]["score"] == 5, tests["camera"]
    assert document["score"] == sum(t["score"] for t in document["tests"]) <= 5


def test_results_file_is_replaced_atomically(tmp_path):
    r = results.Results(tmp_path / "results.json")
    r.add_pending("a", "A", 2)
    r.add_pending("b", "B", 3)
    r.write()
    results.validate(json.loads((tmp_path / "results.json").read_text()))
    r.record("a", "A", 1.5, 2, False, "x" * 20000, "hidden")
    document = json.loads((tmp_path / "results.json").read_text())
    results.validate(document)
    assert document["score"] == 1.5 and len(document["tests"][0]["output"]) < 9000
    assert not list(tmp_path.glob(".results-*"))


def test_calibration_script_reports_rates_and_p_values(tmp_path, capsys):
    from autograder import calibrate
    out = tmp_path / "cal.json"
    assert calibrate.main(["--seeds", "2", "--checks", "camera", "direct-glass", "--workers", "2",
                           "--time-scale", str(CI_TIME_SCALE), "--out", str(out)]) == 0
    report = json.loads(out.read_text())
    assert report["submissions"] == 2 and report["checks"] == ["camera", "direct-glass"]
    assert report["part_p_values"] == 2 * 2          # camera mean; glass mean
    assert 0 <= report["min_p"] <= 1 and 0 <= report["ks_uniform_p"] <= 1
    low, high = report["false_failure_ci95"]
    assert 0 <= low <= report["false_failure_rate"] <= high <= 1
    assert "correct submissions lost points" in capsys.readouterr().out


def test_light_tracer_written_as_a_student_renders_in_the_student_runtime(tmp_path):
    """The light-tracing contract end to end: the skeleton filled with the reference's code
    (its light.py calls the package's own camera_connection.py; the runtime's are stubs)
    renders in the student runtime, its splats carried back as the two images, bit for bit
    what pathtracer.render gives; the skeleton itself is 'not implemented'."""
    from autograder.isolation.process import StudentFailure
    from autograder.skeleton import generate
    from pathtracer import load_scene, render
    filled = generate(tmp_path / "filled", stubs=False, assignment="light-tracing")
    assert "from .camera_connection import connect_to_camera" in (filled / "light.py").read_text()
    with StudentProcess(str(filled), Limits(60 * CI_TIME_SCALE)) as student:
        mean, variance = student.render("glass-lamp", "light", {}, 4, 5)
    direct = render(load_scene("glass-lamp"), "light", spp=4, seed=5, processes=1)
    assert np.array_equal(mean, direct.mean) and np.array_equal(variance, direct.variance)
    assert mean.sum() > 0 and variance.sum() > 0
    stubbed = generate(tmp_path / "stubbed", assignment="light-tracing")
    assert "NotImplementedError" in (stubbed / "camera_connection.py").read_text()
    with StudentProcess(str(stubbed), Limits(60 * CI_TIME_SCALE)) as student:
        with pytest.raises(StudentFailure, match="splat: implement the lecture's slide 'Light Tracing'"):
            student.render("glass-lamp", "light", {}, 4, 5)


def test_splats_are_checked_before_they_reach_the_film():
    """A splat outside the film would wrap into another pixel: refused, as NaN and negatives."""
    from autograder.sandbox.child import ContractError, check_splats
    pixel, value = np.array([0, 5]), np.ones((2, 3))
    assert check_splats((pixel, value), 6, "light")[0].dtype == np.int64
    for bad, words in [((np.array([0, 6]), value), "outside the film"),
                       ((np.array([-1, 0]), value), "outside the film"),
                       ((pixel, value * np.nan), "NaN"), ((pixel, -value), "negative"),
                       ((pixel, value[:1]), "shape"), ((pixel * 1.0, value), "integer"),
                       ([pixel, value], "tuple")]:
        with pytest.raises(ContractError, match=words):
            check_splats(bad, 6, "light")


def test_calibration_pools_sweeps_of_different_checks(tmp_path, capsys):
    """Two sweeps over parts of the checks at the same repetitions make whole submissions; a
    later log supersedes an earlier one for a check both graded; incomplete repetitions drop."""
    from autograder import calibrate

    def record(seed, checks, lost=None):
        return json.dumps({"seed": seed, "lost_points": bool(lost), "lost": lost or {},
                           "p_values": {f"{c}/mean": 0.5 + 0.01 * seed for c in checks},
                           "seconds": 1.0, "impl": "autograder.solution", "checks": checks})
    first, second = tmp_path / "a.jsonl", tmp_path / "b.jsonl"
    first.write_text("\n".join([record(1, ["camera", "direct-glass"], {"direct-glass": 5.0}),
                                record(2, ["camera", "direct-glass"]), record(3, ["camera"])]))
    second.write_text("\n".join([record(1, ["direct-glass"]), record(2, ["direct-glass"])]))
    out = tmp_path / "pooled.json"
    assert calibrate.main(["--pool", str(first), str(second), "--checks", "camera", "direct-glass",
                           "--out", str(out)]) == 0
    report = json.loads(out.read_text())
    assert report["submissions"] == 2 and report["lost_points"] == 0       # seed 1 re-graded
    assert report["part_p_values"] == 4
    assert calibrate.main(["--pool", str(first), "--checks", "camera", "direct-glass",
                           "--out", str(out)]) == 0
    assert json.loads(out.read_text())["lost_points"] == 1
    assert "correct submissions lost points" in capsys.readouterr().out
    with pytest.raises(SystemExit) as exit_info:        # a missing log: a usage error naming it
        calibrate.main(["--pool", str(first), str(tmp_path / "nope.jsonl"), "--out", str(out)])
    assert exit_info.value.code == 2 and "nope.jsonl" in capsys.readouterr().err


def test_sandboxed_render_is_the_direct_render():
    """The student process renders exactly what pathtracer.render gives: same camera rays
    (sent by the grader), same random numbers, and the scene file's options (glass-cube sets
    max_depth 8) applied to the submission's integrator."""
    import numpy as np

    from pathtracer import load_scene, render
    params = {"width": 64, "height": 64}
    with StudentProcess("autograder.solution", Limits(60 * CI_TIME_SCALE)) as student:
        mean, variance = student.render("glass-cube", "path_bsdf", params, 2, 5)
    direct = render(load_scene("glass-cube", **params), "path_bsdf", spp=2, seed=5, processes=1)
    assert np.array_equal(mean, direct.mean) and np.array_equal(variance, direct.variance)
    shallow = render(load_scene("glass-cube", **params), "path_bsdf", spp=2, seed=5, processes=1,
                     max_depth=2)
    assert not np.array_equal(mean, shallow.mean)
    with StudentProcess("autograder.solution", Limits(60 * CI_TIME_SCALE)) as student:
        mean, _ = student.render("glass-cube", "path_bsdf", params, 2, 5, max_depth=2)
    assert np.array_equal(mean, shallow.mean)          # an explicit depth beats the file's


@pytest.mark.parametrize("integrator, fog, clear, fog_later, first_words", [
    ("volpath", 1.19, 1.15, 1.19, "transmittance along shadow rays"),
    ("volpath_phase", 1.40, 1.10, 1.40, "null boundaries"),
    ("volpath_phase", 0.60, 0.97, 0.0, "pdf cancels"),
    ("volpath", 0.79, 0.99, 0.79, "free-flight"),
    ("volpath", 1.00, 0.80, 1.00, "surface steps"),
])
def test_media_hints_read_the_fog_and_clear_regions(integrator, fog, clear, fog_later, first_words):
    """The media rules (autograder/hints/media.py) on sweeps made from the committed per-bounce
    references, what each depth adds scaled by one factor in the fog's pixels and another in
    the rest: each pattern names its cause first, with the factors it read."""
    from autograder.hints.explain import Evidence
    from autograder.hints.media import explain_media, fog_pixels
    from mitsuba_refs.reference.cache import get_reference
    check = grading.CHECKS_BY_ID[f"{integrator}-media"]
    refs = {d: get_reference("media-box", {"max_depth": d}, "volpath", render=False).mean
            for d in (1, 2, 3)}
    in_fog, _ = fog_pixels("media-box", {})
    sweep, test = {}, {0: np.zeros_like(refs[1])}
    for depth, (f, c) in {1: (1, 1), 2: (fog, clear), 3: (fog_later, clear)}.items():
        scale = np.where(in_fog[..., None], f, c)
        base = refs[depth - 1] if depth > 1 else 0
        test[depth] = base + (refs[depth] - base) * scale
        rel = float(test[depth].sum() / refs[depth].sum() - 1)
        sweep[depth] = (SimpleNamespace(agree=abs(rel) < 1e-3, rel_bias=rel), test[depth], refs[depth])
    comparison = SimpleNamespace(mean=SimpleNamespace(agree=False, rel_bias=0.05))
    found = explain_media(Evidence(check=check, comparison=comparison, sweep=sweep))
    text = " ".join(found)
    assert found and first_words in found[0].split("; or ")[0], found
    assert f"x{fog:.2f}" in text and not re.search(r"\bx?(nan|inf)\b", text.lower()), text
