"""Judge the C++ smallpt against the project's tracer and Mitsuba 3, with the project's statistics.

Builds ``smallpt.cpp`` with the system C++ compiler, renders the built-in ``smallpt``
scene with it at 64 x 48 and compares each image with

* our ``smallpt`` integrator on the same scene (same estimator: the test side's
  variance is bounded by ``VARIANCE_BOUND`` times ours), and
* the committed Mitsuba 3 references of the scene (``path_bsdf``, the reference the
  README's ``mitsuba-refs check`` uses, and ``path`` at max_depth 1, 2 and 3),

for the correct renderer, its two injected bugs (``--bug roulette``, ``--bug
fresnel-split``) and ``--max-depth`` 1, 2, 3. It also checks that the image does not
depend on the thread count and measures the speed (paths per second, one thread, 64 x 64
at 64 spp)::

    python examples/smallpt-cpp/verify.py              # about a minute of CPU time
    python examples/smallpt-cpp/verify.py --spp 256 --ours-spp 256

``tests/test_example_smallpt_cpp.py`` runs a smaller version of the same comparisons in
the test suite, with these functions.
"""
from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import pathtracer
from mitsuba_refs.reference.cache import get_reference
from mitsuba_refs.stats import compare_means
from mitsuba_refs.stats.mean import VARIANCE_BOUND

HERE = Path(__file__).resolve().parent
SOURCE = HERE / "smallpt.cpp"
#: The film of the committed references of the smallpt scene.
WIDTH, HEIGHT = 64, 48
#: Level of the comparisons printed here (the test suite uses its own, tests/budget.py).
ALPHA = 1e-3


def compiler() -> str | None:
    """The system C++ compiler (``$CXX``, else ``c++``), or None without one."""
    return shutil.which(os.environ.get("CXX", "c++"))


def build(directory: Path) -> Path:
    """Compile ``smallpt.cpp`` into ``directory`` as the README says; return the binary."""
    cxx = compiler()
    if cxx is None:
        raise RuntimeError("no C++ compiler found (set CXX or install c++)")
    binary = Path(directory) / "smallpt"
    subprocess.run([cxx, "-O2", "-std=c++17", "-pthread", "-o", str(binary), str(SOURCE)],
                   check=True, capture_output=True, text=True)
    return binary


def read_pfm(path: Path) -> np.ndarray:
    """A colour PFM as an (H, W, 3) float64 array, row 0 at the top of the image.

    PFM stores rows from the bottom up; a negative scale means little-endian floats.
    """
    data = Path(path).read_bytes()
    kind, size, scale, pixels = data.split(b"\n", 3)
    if kind != b"PF":
        raise ValueError(f"{path}: not a colour PFM (header {kind!r})")
    width, height = (int(v) for v in size.split())
    dtype = "<f4" if float(scale) < 0 else ">f4"
    image = np.frombuffer(pixels, dtype=dtype, count=width * height * 3).reshape(height, width, 3)
    return image[::-1].astype(np.float64)


def render_cpp(binary: Path, directory: Path, spp: int, seed: int, *, max_depth: int = -1,
               bug: str | None = None, threads: int = 1, width: int = WIDTH,
               height: int = HEIGHT) -> tuple[np.ndarray, np.ndarray]:
    """Mean and per-sample variance images of one render of the C++ smallpt."""
    directory = Path(directory)
    tag = f"{bug or 'correct'}-d{max_depth}-s{seed}-n{spp}-t{threads}"
    mean_path, variance_path = directory / f"{tag}-mean.pfm", directory / f"{tag}-var.pfm"
    command = [str(binary), "--width", str(width), "--height", str(height), "--spp", str(spp),
               "--seed", str(seed), "--max-depth", str(max_depth), "--threads", str(threads),
               "--out", str(mean_path), "--variance", str(variance_path)]
    if bug:
        command += ["--bug", bug]
    subprocess.run(command, check=True)
    return read_pfm(mean_path), read_pfm(variance_path)


def render_ours(spp: int, seed: int, *, max_depth: int = -1,
                processes: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Mean and per-sample variance images of our ``smallpt`` integrator on the same scene."""
    scene = pathtracer.load_scene("smallpt", width=WIDTH, height=HEIGHT)
    result = pathtracer.render(scene, "smallpt", spp=spp, seed=seed, max_depth=max_depth,
                               processes=processes, progress=False)
    return result.mean, result.variance


def mitsuba_reference(integrator: str = "path_bsdf", max_depth: int = -1):
    """The committed Mitsuba 3 reference of the smallpt scene at 64 x 48 (never rendered here).

    max_depth is a parameter of the scene file (``-D max_depth=2``), as the references
    at depths 1, 2 and 3 were built.
    """
    params = {"width": str(WIDTH), "height": str(HEIGHT)}
    if max_depth != -1:
        params["max_depth"] = str(max_depth)
    return get_reference("smallpt", params, integrator, render=False)


def against_ours(test, spp: int, ours, ours_spp: int, alpha: float):
    """``compare_means`` of a C++ render (mean, variance) with ours: the same estimator."""
    return compare_means(test[0], test[1], spp, ours[0], ours[1], ours_spp, alpha=alpha,
                         max_var_ratio=VARIANCE_BOUND)


def against_mitsuba(test, spp: int, reference, alpha: float):
    """``compare_means`` of a C++ render with a Mitsuba reference (another estimator)."""
    return compare_means(test[0], test[1], spp, reference.mean, reference.var, reference.n,
                         alpha=alpha)


def paths_per_second(binary: Path, directory: Path, size: int = 64, spp: int = 64,
                     repeats: int = 3) -> float:
    """Camera paths per second of CPU time, one thread, ``size`` x ``size`` at ``spp``
    (the best of ``repeats``: other processes only slow a run down)."""
    best = float("inf")
    for _ in range(repeats):
        before = os.times()
        subprocess.run([str(binary), "--width", str(size), "--height", str(size), "--spp", str(spp),
                        "--seed", "1", "--out", str(Path(directory) / "speed.pfm")], check=True)
        after = os.times()
        best = min(best, after.children_user - before.children_user
                   + after.children_system - before.children_system)
    return size * size * spp / best


def cpu_name() -> str:
    """The CPU's model name from /proc/cpuinfo (or the platform's)."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    import platform
    return platform.processor() or "unknown CPU"


def _row(label: str, result) -> str:
    low, high = result.rel_bias_ci
    verdict = "agrees" if result.agree else "DISAGREES"
    return (f"  {label:<34} p = {result.p_value:9.3g}   rel. bias {result.rel_bias:+7.2%} "
            f"[{low:+.2%}, {high:+.2%}]   {verdict}")


def main(argv=None) -> int:
    """Run every comparison and print one line each; exit 1 if any verdict is wrong."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--spp", type=int, default=1024, help="samples per pixel of the C++ renders")
    parser.add_argument("--ours-spp", type=int, default=1024, help="samples per pixel of our renders")
    parser.add_argument("--depth-spp", type=int, default=256, help="both sides' spp at max_depth 1-3")
    parser.add_argument("--processes", type=int, default=1, help="worker processes of our renders")
    args = parser.parse_args(argv)

    wrong = []

    def report(label, result, expect_agree):
        print(_row(label, result), flush=True)
        if bool(result.agree) != expect_agree:
            wrong.append(label)

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        binary = build(tmp)
        spp, ours_spp, depth_spp = args.spp, args.ours_spp, args.depth_spp

        print(f"C++ {spp} spp against our smallpt at {ours_spp} spp ({WIDTH} x {HEIGHT}, alpha {ALPHA}):")
        ours = render_ours(ours_spp, seed=11, processes=args.processes)
        reference = mitsuba_reference("path_bsdf")
        renders = {bug: render_cpp(binary, tmp, spp, seed=5, bug=bug)
                   for bug in (None, "roulette", "fresnel-split")}
        for bug, image in renders.items():
            report(f"--bug {bug}" if bug else "correct", against_ours(image, spp, ours, ours_spp, ALPHA),
                   expect_agree=bug is None)
        print(f"C++ {spp} spp against Mitsuba's path_bsdf reference ({reference.n} spp):")
        for bug, image in renders.items():
            report(f"--bug {bug}" if bug else "correct", against_mitsuba(image, spp, reference, ALPHA),
                   expect_agree=bug is None)
        report(f"our smallpt at {ours_spp} spp", against_mitsuba(ours, ours_spp, reference, ALPHA), True)

        print(f"--max-depth at {depth_spp} spp, against our smallpt and Mitsuba's path at the same depth:")
        for depth in (1, 2, 3):
            cpp = render_cpp(binary, tmp, depth_spp, seed=20 + depth, max_depth=depth)
            ours_d = render_ours(depth_spp, seed=30 + depth, max_depth=depth, processes=args.processes)
            report(f"max_depth {depth} vs ours", against_ours(cpp, depth_spp, ours_d, depth_spp, ALPHA), True)
            report(f"max_depth {depth} vs Mitsuba path",
                   against_mitsuba(cpp, depth_spp, mitsuba_reference("path", depth), ALPHA), True)

        one = render_cpp(binary, tmp, 16, seed=3, threads=1)
        three = render_cpp(binary, tmp, 16, seed=3, threads=3)
        other = render_cpp(binary, tmp, 16, seed=4, threads=1)
        same = all(np.array_equal(a, b) for a, b in zip(one, three))
        # The noise of two seeds' images about Mitsuba's (4096 spp) should be uncorrelated.
        correlation = np.corrcoef((one[0] - reference.mean).ravel(), (other[0] - reference.mean).ravel())[0, 1]
        print(f"1 and 3 threads give the same image: {same}; seeds 3 and 4 differ "
              f"(noise correlation {correlation:+.3f})")
        if not same:
            wrong.append("thread count")

        start = time.perf_counter()
        rate = paths_per_second(binary, tmp)
        print(f"speed: {rate / 1e6:.3f} M paths/s, one thread, 64 x 64 at 64 spp, on {cpu_name()} "
              f"({time.perf_counter() - start:.1f} s for three runs)")
    if wrong:
        print("WRONG VERDICTS: " + ", ".join(wrong))
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
