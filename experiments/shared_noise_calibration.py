"""Calibration of the shared-noise check (``mitsuba_refs.stats.replicas.offset_shared_noise``).

False refusals: the largest ``z`` over every pair and pixel offset of independent replicas,
simulated (Gaussian, sparse 1-spp-like, grey sparse, 3 x 3 blurred, lognormal; K = 3, 8, 16;
16 x 16 to 128 x 96) and rendered (Mitsuba's command line at seeds of the harness's rule;
``pathtracer render``). Detection: Mitsuba's command line at consecutive seeds and at seeds
1..8, whose streams are shifted copies. Each stack is compared with the limit the check uses
(:func:`mitsuba_refs.external.renders.shared_noise_limit`).

    python -m experiments.shared_noise_calibration --simulated 200 --rendered 10

Results go to ``--json`` (default docs/data/shared_noise_calibration.json).
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.ndimage import uniform_filter

from mitsuba_refs.external.images import read_image
from mitsuba_refs.external.renders import shares_noise
from mitsuba_refs.external.seeding import seed_rule
from mitsuba_refs.stats.replicas import offset_shared_noise
from pathtracer.scene.load import scene_file

from .bench import cpu_name

ROOT = Path(__file__).resolve().parent.parent
KINDS = ("gaussian", "sparse", "sparse_grey", "blurred", "lognormal")
SHAPES = ((8, 64, 64), (3, 64, 64), (16, 40, 48), (8, 16, 16), (8, 96, 128))


def simulated(rng, kind, count, height, width):
    """``count`` independent replicas (count, height, width, 3) of one kind of noise."""
    shape = (count, height, width, 3)
    if kind == "gaussian":
        return rng.normal(size=shape)
    if kind == "sparse":         # one sample per pixel: rare bright values, brighter to the right
        ramp = np.linspace(0.1, 3, width)[None, None, :, None]
        return (rng.random(shape) < 0.05) * rng.exponential(size=shape) * ramp
    if kind == "sparse_grey":    # the same, one path for the three channels
        grey = (rng.random(shape[:3] + (1,)) < 0.05) * rng.exponential(size=shape[:3] + (1,))
        return np.repeat(grey, 3, axis=-1)
    if kind == "blurred":        # neighbours correlated, as in a tent or gaussian film
        wide = uniform_filter(rng.normal(size=(count, height + 4, width + 4, 3)), size=(1, 3, 3, 1))
        return wide[:, 2:2 + height, 2:2 + width]
    if kind == "lognormal":
        return rng.lognormal(0, 1.5, size=shape)
    raise ValueError(kind)


def summary(found) -> dict:
    """The numbers of an :func:`offset_shared_noise` result, and whether the check refuses it."""
    return {"pair": [found.first, found.second], "offset": [found.dx, found.dy],
            "correlation": found.correlation, "z": found.z, "pixels": found.pixels,
            "tests": found.tests, "refused": shares_noise(found)}


def run_simulated(trials: int) -> list:
    """Largest z and correlation of ``trials`` independent stacks per kind and shape."""
    rows = []
    for kind in KINDS:
        for count, height, width in SHAPES:
            rng = np.random.default_rng([KINDS.index(kind), count, height, width])
            found = [offset_shared_noise(simulated(rng, kind, count, height, width))
                     for _ in range(trials)]
            rows.append({"kind": kind, "replicas": count, "size": [width, height], "trials": trials,
                         "max_z": max(f.z for f in found),
                         "max_correlation": max(f.correlation for f in found),
                         "refused": sum(shares_noise(f) for f in found)})
            print(json.dumps(rows[-1]), flush=True)
    return rows


def render_stack(program, folder: Path, seeds, spp: int, size) -> np.ndarray:
    """Replicas of cornell-box rendered by ``program`` ("mitsuba" or "pathtracer")."""
    width, height = size
    scene = scene_file("cornell-box")
    images = []
    for seed in seeds:
        out = folder / f"{program}-{seed}-{spp}-{width}x{height}.exr"
        if program == "mitsuba":
            command = [str(Path(sys.executable).parent / "mitsuba"), "-m", "scalar_rgb", "-o",
                       str(out), "-D", f"width={width}", "-D", f"height={height}", "-D",
                       f"spp={spp}", "-D", f"seed={seed}", "-D", "max_depth=-1", scene]
        else:
            command = [sys.executable, "-m", "pathtracer.cli", "render", scene, "--resolution",
                       f"{width}x{height}", "--spp", str(spp), "--seed", str(seed), "-o", str(out)]
        subprocess.run(command, check=True, capture_output=True)
        images.append(read_image(out).mean)
    return np.stack(images)


def run_rendered(groups: int) -> list:
    """One record per rendered stack: consecutive seeds, seeds 1..8, seeds of the rule."""
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)

        def record(kind, program, seeds, spp, size):
            found = offset_shared_noise(render_stack(program, folder, seeds, spp, size))
            rows.append({"kind": kind, "seeds": [int(s) for s in seeds], "spp": spp,
                         "size": list(size), **summary(found)})
            print(json.dumps(rows[-1]), flush=True)

        for size in ((64, 64), (48, 40)):
            rule = seed_rule(*size, 4096, 4096)
            for spp in (8, 1):
                record("mitsuba seeds 1..8", "mitsuba", range(1, 9), spp, size)
                for g in range(groups):
                    record("mitsuba consecutive", "mitsuba", range(100 * g + 5, 100 * g + 13),
                           spp, size)
                    record("mitsuba seed rule", "mitsuba", rule.seeds(8, g + 1), spp, size)
        for g in range(max(1, groups // 2)):
            record("pathtracer", "pathtracer", range(1000 * g + 1, 1000 * g + 9), 8, (64, 64))
    return rows


def main(argv=None):
    """Run both parts and write the JSON."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--simulated", type=int, default=200, help="stacks per simulated case")
    parser.add_argument("--rendered", type=int, default=10, help="rendered groups per case")
    parser.add_argument("--json", default=str(ROOT / "docs/data/shared_noise_calibration.json"))
    args = parser.parse_args(argv)
    start = time.perf_counter()
    result = {"machine": cpu_name(), "simulated": run_simulated(args.simulated),
              "rendered": run_rendered(args.rendered)}
    result["seconds"] = round(time.perf_counter() - start, 1)
    Path(args.json).parent.mkdir(parents=True, exist_ok=True)
    Path(args.json).write_text(json.dumps(result, indent=1) + "\n")
    print(f"{args.json} ({result['seconds']} s)")


if __name__ == "__main__":
    main()
