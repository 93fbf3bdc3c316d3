"""Hostile: writes a well-formed but forged "ok" frame (a constant image) before the grader
asked for it, then a garbage frame.

EXPECT: the grader reads frames strictly: the forged image is graded like any image (wrong:
zero points), the extra frame is an unexpected reply; the grader never crashes.
"""
import json
import sys

import numpy as np
from _hostile import black, registry

EXPECT = dict(kind=None, words="")


def radiance(self, scene, rays, rng):
    from grading_child import wire
    config = json.loads(sys.argv[2])
    shape = (scene.camera.height, scene.camera.width, 3)
    wire.write_frame(config["reply_fd"], {"status": "ok"},
                     {"mean": np.full(shape, 0.5), "variance": np.full(shape, 0.01)})
    return black(rays)


INTEGRATORS = registry(radiance)
