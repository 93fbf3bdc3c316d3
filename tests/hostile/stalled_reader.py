"""Hostile: asks the grader for camera rays and never reads the answer, so that the grader's
write blocks forever (a pipe holds 64 KB; the answer is megabytes).

EXPECT: the grader's writes wait on the test's deadline, not forever: a time-limit failure.
"""
import json
import sys
import time

import numpy as np
from _hostile import registry

EXPECT = dict(kind="timeout", words="time limit")


def radiance(self, scene, rays, rng):
    from grading_child import wire
    n = 1 << 18
    wire.write_frame(json.loads(sys.argv[2])["reply_fd"], {"status": "camera"},
                     {"pixel": np.zeros(n, dtype=np.int64), "u_film": np.full((n, 2), 0.5)})
    time.sleep(3600)


INTEGRATORS = registry(radiance)
