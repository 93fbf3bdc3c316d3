"""The golden set of a refactoring: every verdict line, JSON record, report and image of a fixed
list of runs, recorded before a change and compared after it.

A change that must leave the harness's behaviour as it was (a move of modules, a new settings
object, statistics that return numbers instead of words) is recorded on the commit before it and
on the working tree after it; ``diff`` then lists every difference that is not a clock reading::

    python tools/golden/record.py record OUT_BEFORE --root /path/to/checkout-before
    python tools/golden/record.py record OUT_AFTER
    python tools/golden/record.py diff OUT_BEFORE OUT_AFTER

Each run executes with ``ROOT/.venv/bin`` first on ``PATH`` and ``ROOT`` as its working
folder. What is compared: standard output and error, JSON (numbers exact), JUnit, HTML, and
EXR and PNG images by their pixels. Seconds, the folders of the two recordings and the
checkout's path are replaced by placeholders first; nothing else is.
"""
from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
from pathlib import Path

PATHTRACER = "pathtracer render {scene} --resolution {width}x{height} --spp {spp} --seed {seed} -o {out}"
SMALLPT = ("./examples/smallpt-cpp/smallpt --width {width} --height {height} --spp {spp} --seed {seed} "
           "--max-depth {max_depth} --out {out}")
MUTANT = ("python tools/golden/mutant_render.py extra_inv_pi {scene} --integrator path_nee "
          "--resolution {width}x{height} --spp {spp} --seed {seed} --max-depth {max_depth} -o {out}")
REPORTS = "--json {o}/results.json --junit {o}/junit.xml --html {o}/html"


def runs() -> dict[str, list[str]]:
    """Name -> shell commands; ``{o}`` is the run's own output folder."""
    return {
        "compare-readme": [
            "mitsuba-refs compare cornell-box --integrator path --out {o}/pictures " + REPORTS],
        "check-pathtracer": [
            "mitsuba-refs check cornell-box --same-estimator --no-convergence --out {o}/pictures "
            "--command '" + PATHTRACER + "' " + REPORTS],
        "check-smallpt": [
            "make -s -C examples/smallpt-cpp",
            "mitsuba-refs check smallpt --reference-integrator path_bsdf --output-suffix .pfm "
            "--out {o}/pictures --command '" + SMALLPT + "' " + REPORTS],
        "check-images": [
            "pathtracer render cornell-box --resolution 64x64 --spp 64 --seed 5 -o {o}/renders/a.exr "
            "--no-progress",
            "pathtracer render cornell-box --resolution 64x64 --spp 64 --seed 6 -o {o}/renders/b.exr "
            "--no-progress",
            "mitsuba-refs check cornell-box --images '{o}/renders/*.exr' --same-estimator "
            "--out {o}/pictures " + REPORTS],
        "check-failing": [
            "mitsuba-refs check cornell-box --reference-integrator path_nee --same-estimator "
            "--no-convergence --out {o}/pictures --command '" + MUTANT + "' " + REPORTS],
        "grade-solution": [
            "pytest -q -p no:cacheprovider autograder/tests_for_students "
            "--gradescope {o}/results.json"],
        "grade-extra-inv-pi": [
            "pytest -q -p no:cacheprovider autograder/tests_for_students --impl tests/bugzoo/extra_inv_pi.py "
            "--solution-runtime "
            "--gradescope {o}/results.json"],
        "grade-mis-weights": [
            "pytest -q -p no:cacheprovider autograder/tests_for_students --impl tests/bugzoo/mis_weights.py "
            "--solution-runtime "
            "--gradescope {o}/results.json"],
    }


def record(out: Path, root: Path, only: list[str]) -> None:
    """Run every command of ``runs()`` (or those named in ``only``) into ``out/NAME/``."""
    env = dict(os.environ, PATH=f"{root / '.venv' / 'bin'}{os.pathsep}{os.environ['PATH']}",
               PYTHONHASHSEED="0", COLUMNS="100")
    env.pop("VIRTUAL_ENV", None)
    for name, commands in runs().items():
        if only and name not in only:
            continue
        folder = out / name
        folder.mkdir(parents=True, exist_ok=True)
        log = []
        for command in commands:
            command = command.replace("{o}", str(folder))
            done = subprocess.run(command, shell=True, cwd=root, env=env, capture_output=True, text=True)
            log.append(f"$ {command}\n[exit {done.returncode}]\n--- stdout\n{done.stdout}--- stderr\n"
                       f"{done.stderr}")
        (folder / "log.txt").write_text("\n".join(log))
        print(f"{name}: recorded", flush=True)


def _normalise(text: str, folder: Path) -> str:
    """``text`` with its clocks, addresses and the two recordings' folders as placeholders."""
    text = text.replace(str(folder), "<OUT>")
    text = re.sub(r"/\S*?/(main|base|wt-[\w-]+)(?=/|\b)", "<ROOT>", text)
    text = re.sub(r"/tmp/mitsuba-refs-check-[^/\s]+/run-[^/\s]+/", "<TMP>/", text)
    text = re.sub(r"\(\d+k paths/s\)", "(<PACE>)", text)
    text = re.sub(r"object at 0x[0-9a-f]+", "object at <ADDR>", text)
    text = re.sub(r"seconds=[\d.e+-]+", "seconds=<T>", text)
    text = re.sub(r"per run [\d.]+", "per run <T>", text)
    text = re.sub(r"\d+(\.\d+)?(e[-+]?\d+)?\s?(s|ms|CPU-seconds|CPU-s|seconds)\b", "<T>", text)
    text = re.sub(r'time="[^"]*"', 'time="<T>"', text)
    text = re.sub(r'timestamp="[^"]*"', 'timestamp="<T>"', text)
    text = re.sub(r"in \d+(\.\d+)?s", "in <T>", text)
    text = re.sub(r" ?\(\d+:\d\d:\d\d\)", "", text)     # pytest adds h:mm:ss past a minute
    # pytest shortens a failed check's repr around its seconds: the Gradescope JSON says the rest.
    text = re.sub(r"CheckResult\(.*$", "CheckResult(<REPR>", text, flags=re.M)
    # The HTML runs table: its last two cells are seconds.
    return "\n".join(re.sub(r"<td>\d+(\.\d+)?</td><td>\d+(\.\d+)?</td></tr>", "<td><T></td><td><T></td></tr>", line)
                     if line.startswith("<h3>Runs</h3>") else line for line in text.split("\n"))


CLOCK_KEYS = {"seconds", "cpu_seconds", "wall_seconds", "render_seconds", "execution_time", "elapsed",
              "timestamp"}


def _strip_clock(value, folder):
    if isinstance(value, dict):
        return {k: _strip_clock(v, folder) for k, v in value.items() if k not in CLOCK_KEYS}
    if isinstance(value, list):
        return [_strip_clock(v, folder) for v in value]
    if isinstance(value, str):
        return _normalise(value, folder)
    return value


def _pixels(path: Path):
    import numpy as np
    if path.suffix == ".png":
        from PIL import Image
        return np.asarray(Image.open(path))
    from pathtracer.io.exr import read_channels
    channels, header = read_channels(path)
    return {k: np.asarray(v) for k, v in channels.items()}


def _same_pixels(a, b) -> bool:
    import numpy as np
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(np.array_equal(a[k], b[k], equal_nan=True) for k in a)
    return a.shape == b.shape and np.array_equal(a, b)


def diff(before: Path, after: Path) -> int:
    """Print every difference between two recordings, clocks aside; 1 if there is one."""
    problems = []
    files_a = {p.relative_to(before) for p in before.rglob("*") if p.is_file()}
    files_b = {p.relative_to(after) for p in after.rglob("*") if p.is_file()}
    for missing in sorted(files_a ^ files_b):
        problems.append(f"only in {'before' if missing in files_a else 'after'}: {missing}")
    for rel in sorted(files_a & files_b):
        a, b = before / rel, after / rel
        run_a, run_b = before / rel.parts[0], after / rel.parts[0]
        if rel.suffix in (".png", ".exr"):
            same = _same_pixels(_pixels(a), _pixels(b))
        elif rel.suffix == ".json":
            same = _strip_clock(json.loads(a.read_text()), run_a) == _strip_clock(json.loads(b.read_text()), run_b)
        else:
            text_a, text_b = _normalise(a.read_text(), run_a), _normalise(b.read_text(), run_b)
            same = text_a == text_b
            if not same:
                import difflib
                lines = list(difflib.unified_diff(text_a.splitlines(), text_b.splitlines(), str(rel), str(rel),
                                                  lineterm="", n=1))
                problems.append("\n".join(lines[:40]))
                continue
        if not same:
            problems.append(f"differs: {rel}")
    for line in problems:
        print(line)
    print(f"{len(files_a & files_b)} files compared, {len(problems)} differences")
    return 1 if problems else 0


def main(argv=None) -> int:
    """``record`` or ``diff``, as the module's docstring shows."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="action", required=True)
    rec = sub.add_parser("record")
    rec.add_argument("out", type=Path)
    rec.add_argument("--root", type=Path, default=Path(__file__).resolve().parents[2])
    rec.add_argument("--only", nargs="*", default=[])
    dif = sub.add_parser("diff")
    dif.add_argument("before", type=Path)
    dif.add_argument("after", type=Path)
    args = parser.parse_args(argv)
    if args.action == "record":
        record(args.out.resolve(), args.root.resolve(), args.only)
        return 0
    return diff(args.before.resolve(), args.after.resolve())


if __name__ == "__main__":
    sys.exit(main())
