"""Where the tracer's time goes: a per-stage profile of one render per benchmark scene.

Run ``python -m experiments.profile [--scenes cornell-box,smallpt,mesh] [--spp 16]``. Each
scene of :data:`experiments.bench.CASES` is rendered once in this process (one core, after a
warm-up render) under ``cProfile``; the table gives each stage's share of the render:

* closest hits (``geometry.intersect``: accelerator, analytic shapes, hit records);
* shadow rays (``geometry.occluded``);
* light sampling (``emitters.sample_emitter``; next-event estimation traces its shadow rays
  apart, in ``geometry.occluded``);
* BSDF sampling and evaluation (``shading.sample_bsdf``, ``shading.eval_bsdf``);
* emission and the light pdf of BSDF-sampled hits (``emitters.emitted_radiance``,
  ``emitters.pdf_emitter_direction``);
* camera rays and random numbers;
* the integrator's own array work (compaction, throughput, MIS weights: ``radiance``'s
  self time);
* everything else (driver, per-pixel statistics, ray spawning).

cProfile adds a few per cent to each Python call, so shares, not absolute times, are the
result. Used by docs/performance.md.
"""
from __future__ import annotations

import argparse
import cProfile
import pstats
import time

from pathtracer import render

from .bench import CASES, warmed_scene

#: (stage, [(module path suffix, function name), ...], counted as cumulative or self time).
STAGES = [
    ("closest hits (geometry.intersect)", [("pathtracer/shapes/intersect.py", "intersect")], "cum"),
    ("shadow rays (geometry.occluded)", [("pathtracer/shapes/intersect.py", "occluded")], "cum"),
    ("light sampling", [("pathtracer/emitters/scene_emitters.py", "sample_emitter")],
     "cum"),
    ("BSDF sampling and evaluation", [("pathtracer/bsdfs/shading.py", "sample_bsdf"),
                                      ("pathtracer/bsdfs/shading.py", "eval_bsdf")], "cum"),
    ("emission and light pdf of BSDF hits", [("pathtracer/emitters/scene_emitters.py", "emitted_radiance"),
                                             ("pathtracer/emitters/scene_emitters.py", "pdf_emitter_direction")],
     "cum"),
    ("camera rays and random numbers", [("pathtracer/sensors/perspective.py", "camera_rays"),
                                        ("pathtracer/core/rng.py", "sample_keys"),
                                        ("pathtracer/core/rng.py", "next_1d"),
                                        ("pathtracer/core/rng.py", "next_2d"),
                                        ("pathtracer/core/rng.py", "subset")], "cum"),
    ("integrator's own array work", [("pathtracer/integrators/", "radiance")], "self"),
]


def stage_seconds(stats: pstats.Stats) -> dict:
    """{stage: seconds} from a profile, plus 'total' and 'everything else'."""
    table = stats.stats   # {(file, line, name): (calls, prim calls, self, cumulative, callers)}

    def seconds(suffix, name, kind):
        return sum((entry[2] if kind == "self" else entry[3])
                   for (path, _, func), entry in table.items()
                   if func == name and suffix in path.replace("\\", "/"))

    found = {stage: sum(seconds(suffix, name, kind) for suffix, name in functions)
             for stage, functions, kind in STAGES}
    total = max(entry[3] for (path, _, func), entry in table.items() if func == "render")
    found["everything else"] = total - sum(found.values())
    found["total"] = total
    return found


def profile_scene(stem: str, integrator: str, width: int, height: int, spp: int) -> dict:
    """Stage seconds of one profiled render of the benchmark scene ``stem``."""
    scene = warmed_scene(stem, integrator, width, height)
    profiler = cProfile.Profile()
    start = time.perf_counter()
    profiler.enable()
    render(scene, integrator=integrator, spp=spp, seed=1, processes=1, progress=False)
    profiler.disable()
    found = stage_seconds(pstats.Stats(profiler))
    found["paths_per_second"] = width * height * spp / (time.perf_counter() - start)
    return found


def table(profiles: dict) -> str:
    """Markdown: one column per scene, stages as rows (share of the render)."""
    labels = list(profiles)
    stages = [stage for stage, _, _ in STAGES] + ["everything else"]
    lines = ["| stage | " + " | ".join(labels) + " |", "|---" * (len(labels) + 1) + "|"]
    for stage in stages:
        shares = [profiles[label][stage] / profiles[label]["total"] for label in labels]
        lines.append(f"| {stage} | " + " | ".join(f"{s:.0%}" for s in shares) + " |")
    rates = [f"{profiles[label]['paths_per_second'] / 1e3:.0f}k" for label in labels]
    lines.append("| paths/s under the profiler | " + " | ".join(rates) + " |")
    return "\n".join(lines)


def main(argv=None) -> int:
    """Profile a render per scene and print where the time goes (command line); exit code."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenes", default=",".join(label for label, *_ in CASES),
                        help="comma-separated benchmark scenes (default: all)")
    parser.add_argument("--resolution", type=int, default=128, help="film width")
    parser.add_argument("--spp", type=int, default=16, help="samples per pixel")
    args = parser.parse_args(argv)
    wanted = [s for s in args.scenes.split(",") if s]
    unknown = set(wanted) - {label for label, *_ in CASES}
    if unknown:
        parser.error(f"unknown scene(s) {', '.join(sorted(unknown))}; "
                     f"choose from {', '.join(label for label, *_ in CASES)}")
    profiles = {}
    for label, stem, integrator, _, aspect in CASES:
        if label in wanted:
            height = max(1, round(args.resolution * aspect))
            profiles[f"{label} ({integrator})"] = profile_scene(stem, integrator, args.resolution,
                                                                height, args.spp)
    print(table(profiles))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
