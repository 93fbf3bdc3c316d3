"""Build the Gradescope autograder zip: ``python -m autograder.package OUT.zip [--assignment NAME]``.

One zip grades one assignment (:data:`autograder.grading.ASSIGNMENTS`, default ``path-tracing``):
its name is written into ``run_autograder``.

The zip holds what Gradescope's Ubuntu image needs (https://gradescope-autograders.readthedocs.io):

``setup.sh``        creates a venv with the *dependencies* only (the project is not installed
                    into it, so a submission, which runs with that interpreter, cannot import
                    the grader or the solution from it), creates the unprivileged user
                    ``student``, and makes ``source/`` (grader, solution, references) readable
                    by root only;
``run_autograder``  copies the submission, runs the graded tests as root with
                    ``AUTOGRADER_STUDENT_USER=student`` (each test's student process runs as
                    that user, from the student runtime without the solution, under seccomp;
                    see :mod:`autograder.isolation.process`) and always leaves a valid
                    results file;
``source/``         the project (pyproject.toml, requirements.txt, pathtracer/, mitsuba_refs/,
                    autograder/), used through ``PYTHONPATH``.

Both scripts take ``AUTOGRADER_ROOT`` (default ``/autograder``), so that the package can be
tested end to end in a temporary folder; ``setup.sh`` also takes ``AUTOGRADER_PYTHON`` (an
interpreter that already has the dependencies: no apt, no venv) and
``AUTOGRADER_STUDENT_USER`` / ``AUTOGRADER_STUDENT_PYTHON`` / ``AUTOGRADER_STUDENT_SITE``
(see :class:`autograder.isolation.environment.Environment`), which it records in
``ROOT/env.sh`` for ``run_autograder``. ``AUTOGRADER_PYTEST_K`` grades only the checks a pytest
``-k`` expression selects.
"""
from __future__ import annotations

import argparse
import importlib.metadata
import re
import sys
import zipfile
from pathlib import Path

from .grading import ASSIGNMENTS, checks_of

ROOT = Path(__file__).resolve().parent.parent
INCLUDE = ("pyproject.toml", "README.md", "pathtracer", "mitsuba_refs", "autograder")
SKIP_SUFFIXES = (".pyc",)
SKIP_PARTS = ("__pycache__", ".pytest_cache")

SETUP_SH = """#!/usr/bin/env bash
# Gradescope setup: runs once when the autograder image is built (see autograder/package.py).
set -euo pipefail
ROOT=${AUTOGRADER_ROOT:-/autograder}
STUDENT=${AUTOGRADER_STUDENT_USER:-student}
if [ -z "${AUTOGRADER_PYTHON:-}" ]; then
    apt-get update
    apt-get install -y python3 python3-pip python3-venv
    python3 -m venv "$ROOT/venv"
    "$ROOT/venv/bin/pip" install --upgrade pip
    # The dependencies only: the project stays in source/, readable by root alone.
    "$ROOT/venv/bin/pip" install -r "$ROOT/source/requirements.txt" pytest
    GRADER_PYTHON="$ROOT/venv/bin/python"
else
    GRADER_PYTHON="$AUTOGRADER_PYTHON"
fi
id -u "$STUDENT" >/dev/null 2>&1 || useradd --system --no-create-home --shell /usr/sbin/nologin "$STUDENT"
chmod 755 "$ROOT"
chown -R root:root "$ROOT/source"
chmod -R go-rwx "$ROOT/source"
{
    echo "GRADER_PYTHON='$GRADER_PYTHON'"
    echo "export AUTOGRADER_STUDENT_USER='$STUDENT'"
    [ -n "${AUTOGRADER_STUDENT_PYTHON:-}" ] && echo "export AUTOGRADER_STUDENT_PYTHON='$AUTOGRADER_STUDENT_PYTHON'"
    [ -n "${AUTOGRADER_STUDENT_SITE:-}" ] && echo "export AUTOGRADER_STUDENT_SITE='$AUTOGRADER_STUDENT_SITE'"
    true
} > "$ROOT/env.sh"
chmod 600 "$ROOT/env.sh"
"""

RUN_AUTOGRADER = """#!/usr/bin/env bash
# Gradescope run script: grades ROOT/submission, writes ROOT/results/results.json.
set -u
ROOT=${AUTOGRADER_ROOT:-/autograder}
. "$ROOT/env.sh"
RESULTS=$ROOT/results/results.json
ASSIGNMENT=@ASSIGNMENT@
mkdir -p "$ROOT/results"
chmod 700 "$ROOT/results"
rm -rf "$ROOT/student" && mkdir -p "$ROOT/student"
cp -r "$ROOT/submission/." "$ROOT/student/"
# Readable by the student user (it imports it), writable by nobody but root.
chown -R root:root "$ROOT/student"
chmod -R a+rX,go-w "$ROOT/student"
# A submission is the package folder 'student' (the skeleton's layout) or its files directly.
IMPL=$ROOT/student/student
[ -d "$IMPL" ] || IMPL=$ROOT/student
export OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
export PYTHONPATH="$ROOT/source"
cd "$ROOT/source"
# The plugin is a pytest11 entry point only where the project is pip-installed.
PLUGIN=$("$GRADER_PYTHON" -c 'import importlib.metadata as m
print("" if any(e.name == "autograder" for e in m.entry_points(group="pytest11")) else "-p autograder.plugin")')
"$GRADER_PYTHON" -m pytest $PLUGIN autograder/tests_for_students --impl "$IMPL" --assignment "$ASSIGNMENT" \\
    --gradescope "$RESULTS" -q -p no:cacheprovider ${AUTOGRADER_PYTEST_K:+-k "$AUTOGRADER_PYTEST_K"} || true
# The plugin writes results after every test; if the grader could not even start, say so.
"$GRADER_PYTHON" - "$RESULTS" <<'PY'
import json, sys
path = sys.argv[1]
try:
    json.load(open(path))
except Exception:
    try:
        with open(path, "w") as f:
            json.dump({"score": 0, "output": "The autograder could not run; please contact the "
                       "course staff.", "tests": []}, f)
    except OSError as error:
        sys.exit(f"autograder: cannot write the results file {path}: {error.strerror}")
PY
"""


def requirements() -> str:
    """The project's runtime dependencies, one per line (for setup.sh's venv)."""
    text = (ROOT / "pyproject.toml").read_text()
    block = re.search(r"^dependencies = \[(.*?)^\]", text, re.S | re.M)
    if block is None:
        return "\n".join(importlib.metadata.requires("pathtracer-validation") or []) + "\n"
    return "\n".join(re.findall(r'"([^"]+)"', block.group(1))) + "\n"


def _files():
    for name in INCLUDE:
        path = ROOT / name
        if path.is_file():
            yield path
            continue
        for file in sorted(path.rglob("*")):
            if file.is_file() and file.suffix not in SKIP_SUFFIXES and \
                    not any(part in SKIP_PARTS for part in file.parts):
                yield file


def build(out_zip, assignment: str = "path-tracing") -> Path:
    """Write the Gradescope zip that grades ``assignment``; return its path."""
    checks_of(assignment)                       # an unknown name fails here, not on Gradescope
    out_zip = Path(out_zip)
    out_zip.parent.mkdir(parents=True, exist_ok=True)
    with zipfile.ZipFile(out_zip, "w", zipfile.ZIP_DEFLATED) as z:
        run = RUN_AUTOGRADER.replace("@ASSIGNMENT@", assignment)
        for name, text in (("setup.sh", SETUP_SH), ("run_autograder", run)):
            info = zipfile.ZipInfo(name)
            info.external_attr = 0o755 << 16
            z.writestr(info, text)
        z.writestr("source/requirements.txt", requirements())
        for file in _files():
            z.write(file, "source/" + str(file.relative_to(ROOT)))
    return out_zip


def main(argv=None) -> int:
    """Build the Gradescope upload (command line); exit code."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out_zip")
    parser.add_argument("--assignment", choices=list(ASSIGNMENTS), default="path-tracing",
                        help="the assignment the zip grades (default: %(default)s)")
    args = parser.parse_args(argv)
    path = build(args.out_zip, args.assignment)
    print(f"wrote {path} ({path.stat().st_size / 1e6:.1f} MB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
