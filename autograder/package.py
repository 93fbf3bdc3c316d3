"""Build the Gradescope autograder zip: ``python -m autograder.package OUT.zip``.

The zip holds what Gradescope's Ubuntu image needs (https://gradescope-autograders.readthedocs.io):

``setup.sh``        installs Python packages and this project (pathtracer, mitsuba_refs with
                    its committed references, autograder) and creates the unprivileged user
                    ``student`` the student's code runs as; Mitsuba is *not* installed;
``run_autograder``  copies the submission, runs the graded tests with ``--impl`` and
                    ``--gradescope /autograder/results/results.json``, and always leaves a
                    valid results file (the plugin writes it after every test; a final
                    fallback covers a grader that could not even start);
``source/``         the project (pyproject.toml, pathtracer/, mitsuba_refs/, autograder/).

The references are made readable by root only, and the results folder writable by root
only, so the student's process (running as ``student``) can read neither.
"""
from __future__ import annotations

import argparse
import sys
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
INCLUDE = ("pyproject.toml", "README.md", "pathtracer", "mitsuba_refs", "autograder")
SKIP_SUFFIXES = (".pyc",)
SKIP_PARTS = ("__pycache__", ".pytest_cache")

SETUP_SH = """#!/usr/bin/env bash
# Gradescope setup: runs once when the autograder image is built.
set -euo pipefail
apt-get update
apt-get install -y python3 python3-pip python3-venv
python3 -m venv /autograder/venv
/autograder/venv/bin/pip install --upgrade pip
/autograder/venv/bin/pip install /autograder/source pytest
useradd --no-create-home --shell /usr/sbin/nologin student || true
# References: readable by the grader (root) only.
REFS=$(/autograder/venv/bin/python -c "import mitsuba_refs.cache as c; print(c.cache_dir())")
chmod -R go-rwx "$REFS"
"""

RUN_AUTOGRADER = """#!/usr/bin/env bash
# Gradescope run script: grades /autograder/submission, writes /autograder/results/results.json.
set -u
RESULTS=/autograder/results/results.json
mkdir -p /autograder/results
chmod 700 /autograder/results
rm -rf /autograder/student && mkdir -p /autograder/student
cp -r /autograder/submission/. /autograder/student/
chmod -R a+rX /autograder/student
# A submission is the package folder 'student' (the skeleton's layout) or its files directly.
IMPL=/autograder/student/student
[ -d "$IMPL" ] || IMPL=/autograder/student
export AUTOGRADER_STUDENT_USER=student
export OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 MKL_NUM_THREADS=1
cd /autograder/source
/autograder/venv/bin/python -m pytest --pyargs autograder.tests_for_students \\
    --impl "$IMPL" --gradescope "$RESULTS" -q -p no:cacheprovider || true
# The plugin writes results after every test; if the grader could not even start, say so.
/autograder/venv/bin/python - "$RESULTS" <<'PY'
import json, sys
path = sys.argv[1]
try:
    json.load(open(path))
except Exception:
    json.dump({"score": 0, "output": "The autograder could not run; please contact the course staff.",
               "tests": []}, open(path, "w"))
PY
"""


def _files():
    for name in INCLUDE:
        path = ROOT / name
        if path.is_file():
            yield path
            continue
        for file in sorted(path.rglob("*")):
            if file.is_file() and not file.suffix in SKIP_SUFFIXES and \
                    not any(part in SKIP_PARTS for part in file.parts):
                yield file


def build(out_zip) -> Path:
    """Write the Gradescope zip; return its path."""
    out_zip = Path(out_zip)
    out_zip.parent.mkdir(parents=True, exist_ok=True)
    with zipfile.ZipFile(out_zip, "w", zipfile.ZIP_DEFLATED) as z:
        for name, text in (("setup.sh", SETUP_SH), ("run_autograder", RUN_AUTOGRADER)):
            info = zipfile.ZipInfo(name)
            info.external_attr = 0o755 << 16
            z.writestr(info, text)
        for file in _files():
            z.write(file, "source/" + str(file.relative_to(ROOT)))
    return out_zip


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out_zip")
    args = parser.parse_args(argv)
    path = build(args.out_zip)
    print(f"wrote {path} ({path.stat().st_size / 1e6:.1f} MB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
