"""Misbehaving submission: tries to write a perfect score into Gradescope's results file."""
import json
import os

from _base import camera_rays, registry  # noqa: F401  (the reference camera)

GUESSES = ("/autograder/results/results.json",
           os.environ.get("AUTOGRADER_RESULTS") or "/autograder/results/results.json")


def radiance(self, scene, rays, rng):
    for path in GUESSES:
        try:
            with open(path, "w") as f:
                json.dump({"score": 1e9, "tests": []}, f)
        except OSError:
            pass
    raise RuntimeError("tried to overwrite the results")


INTEGRATORS = registry(radiance)
