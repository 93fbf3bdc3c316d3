"""End to end: the Gradescope zip, unpacked into a stand-in for /autograder, set up and run as
root with an unprivileged student user, on a correct, a wrong and a hostile submission.

Asserts the scores, that results.json is valid and final (nothing changes it after the
grader ends), that no process of the student user survives, and, listing as the student
user, that nothing under the autograder root that is private (grader, solution,
references, results) is readable.

Needs root (it creates the user, as Gradescope's setup does) and a system interpreter of
this Python version that the student user can run: the one fixture below decides.
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
import zipfile
from pathlib import Path

import pytest

from autograder import package, results
from autograder.isolation.environment import kill_user_processes, user_processes
from autograder.skeleton import generate

ROOT = Path(__file__).resolve().parent.parent
HOSTILE = ROOT / "tests" / "hostile"
USER = "autograder-e2e"
SYSTEM_PYTHON = Path(f"/usr/bin/python3.{sys.version_info.minor}")
#: What the student needs from the grader's environment (copied: the grader's may sit in a
#: folder the student user cannot enter).
DEPENDENCIES = ("numpy", "numpy.libs", "scipy", "scipy.libs", "threadpoolctl.py")



@pytest.fixture(scope="module")
def autograder_root():
    """(root, environment) of a set-up Gradescope autograder in a temporary folder."""
    if os.geteuid() != 0:
        pytest.skip("needs root: creates the unprivileged grading user as Gradescope's setup does")
    if not SYSTEM_PYTHON.exists():
        pytest.skip(f"needs {SYSTEM_PYTHON} (a Python {sys.version_info.major}."
                    f"{sys.version_info.minor} the student user can run)")
    root = Path(tempfile.mkdtemp(prefix="autograder-e2e-", dir="/tmp"))
    os.chmod(root, 0o755)
    try:
        with tempfile.TemporaryDirectory() as private:       # the zip is not in the image
            with zipfile.ZipFile(package.build(Path(private) / "autograder.zip")) as z:
                z.extractall(root)
        site = Path(__import__("numpy").__file__).resolve().parent.parent
        deps = root / "deps"
        deps.mkdir()
        for name in DEPENDENCIES:
            (shutil.copytree if (site / name).is_dir() else shutil.copy)(site / name, deps / name)
        subprocess.run(["chmod", "-R", "a+rX", str(deps)], check=True)
        env = dict(os.environ, AUTOGRADER_ROOT=str(root), AUTOGRADER_PYTHON=sys.executable,
                   AUTOGRADER_STUDENT_USER=USER, AUTOGRADER_STUDENT_PYTHON=str(SYSTEM_PYTHON),
                   AUTOGRADER_STUDENT_SITE=str(deps))
        # Gradescope's environment has none of these; the caller's (a pytest plugin given in
        # PYTEST_ADDOPTS, say) must not reach the grader's own pytest run.
        for key in ("PYTHONPATH", "MITSUBA_REFS_CACHE", "PYTEST_ADDOPTS", "PYTEST_PLUGINS"):
            env.pop(key, None)
        setup = subprocess.run(["bash", str(root / "setup.sh")], env=env, capture_output=True,
                               text=True, timeout=300)
        assert setup.returncode == 0, setup.stderr[-3000:]
        yield root, env
    finally:
        shutil.rmtree(root, ignore_errors=True)


def grade(root: Path, env: dict, submission: Path, checks: str) -> dict:
    """Run run_autograder on ``submission`` (a folder of files) and return results.json."""
    target = root / "submission"
    shutil.rmtree(target, ignore_errors=True)
    shutil.copytree(submission, target)
    run = subprocess.run(["bash", str(root / "run_autograder")], capture_output=True, text=True,
                         env=dict(env, AUTOGRADER_PYTEST_K=checks,
                                  AUTOGRADER_TIME_SCALE=os.environ.get(
                                      "AUTOGRADER_CI_TIME_SCALE", "6")), timeout=900)
    path = root / "results" / "results.json"
    assert path.exists(), run.stdout[-3000:] + run.stderr[-3000:]
    document = json.loads(path.read_text())
    results.validate(document)
    return document


def scores(document) -> dict:
    return {t["name"].split("[")[-1].rstrip("]"): t["score"] for t in document["tests"]}


def readable_as_student(root: Path) -> list:
    """Files and folders under ``root`` the student user can read, listed as that user."""
    code = ("import os, sys\n"
            "for folder, dirs, files in os.walk(sys.argv[1]):\n"
            "    for name in files + dirs:\n"
            "        path = os.path.join(folder, name)\n"
            "        if os.access(path, os.R_OK): print(path)\n")
    import pwd
    entry = pwd.getpwnam(USER)
    done = subprocess.run([str(SYSTEM_PYTHON), "-S", "-c", code, str(root)], capture_output=True,
                          text=True, user=entry.pw_uid, group=entry.pw_gid, extra_groups=[],
                          cwd="/", timeout=60)
    return done.stdout.split()


def test_correct_submission_gets_full_marks(autograder_root, tmp_path):
    root, env = autograder_root
    generate(tmp_path, stubs=False)                 # the solution, written as a student would
    document = grade(root, env, tmp_path, "direct")
    assert scores(document) == {"direct-cornell-box": 10, "direct-glass": 5,
                                "direct-lights": 5}, document


def test_wrong_submission_loses_points(autograder_root, tmp_path):
    root, env = autograder_root
    package_dir = generate(tmp_path, stubs=False)
    with open(package_dir / "direct.py", "a") as f:   # MIS weights that sum to two
        f.write("\n\ndef power_heuristic(a, b):\n    return np.ones_like(a)\n")
    document = grade(root, env, tmp_path, "direct-cornell")
    test = document["tests"][0]
    assert test["score"] == 0 and "MIS weights" in test["output"], test


def test_hostile_submission_gets_nothing_and_changes_nothing(autograder_root, tmp_path):
    root, env = autograder_root
    for file in HOSTILE.glob("*.py"):
        shutil.copy(file, tmp_path / file.name)
    (tmp_path / "student").mkdir()
    shutil.copy(HOSTILE / "_everything.py", tmp_path / "student" / "__init__.py")
    marker = Path("/tmp/autograder-hostile-daemon-ran")
    marker.unlink(missing_ok=True)
    document = grade(root, env, tmp_path, "cornell-box or camera")
    assert document["score"] == 0 and len(document["tests"]) == 5, document
    import pwd
    assert not user_processes(pwd.getpwnam(USER).pw_uid)
    final = (root / "results" / "results.json").read_text()
    time.sleep(4)                                    # the daemon would have written by now
    assert (root / "results" / "results.json").read_text() == final
    assert not marker.exists() and not Path("/tmp/autograder-hostile-pickle-ran").exists()
    output = " ".join(t["output"] for t in document["tests"])
    assert not any(word in output for word in ("LEAK", "WROTE", "ESCAPED")), output
    assert not any(t["output"].startswith("not run") for t in document["tests"]), document


def test_student_user_reads_nothing_private(autograder_root):
    root, _ = autograder_root
    readable = readable_as_student(root)
    private = [p for p in readable if p.startswith((str(root / "source"), str(root / "results"),
                                                    str(root / "env.sh")))]
    assert not private, private[:20]
    assert any(p.startswith(str(root / "deps")) for p in readable)   # the probe itself works


def test_grader_refuses_an_unsafe_setup(autograder_root):
    """References readable by the student user: the grader stops before grading."""
    root, env = autograder_root
    references = root / "source" / "mitsuba_refs" / "references"
    os.chmod(root / "source", 0o755)
    subprocess.run(["chmod", "-R", "a+rX", str(root / "source")], check=True)
    try:
        document = grade(root, env, ROOT / "tests" / "hostile", "camera")
        assert document["score"] == 0 and "not set up safely" in document["output"], document
        assert str(references) in document["output"] or "private file" in document["output"]
    finally:
        subprocess.run(["chmod", "-R", "go-rwx", str(root / "source")], check=True)
        kill_user_processes(__import__("pwd").getpwnam(USER).pw_uid)
