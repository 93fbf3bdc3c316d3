"""Hostile: sends the grader a pickle whose unpickling would run code in the grader.

The old grader unpickled the student process's replies; this one reads frames of JSON and
raw floats. EXPECT: the reply is malformed, zero points, and the payload's marker file is
never created (the payload would run ``touch MARKER`` inside the grader).
"""
import json
import os
import pickle
import sys

from _hostile import black, registry

MARKER = "/tmp/autograder-hostile-pickle-ran"
EXPECT = dict(kind="protocol", words="malformed")


class Payload:
    def __reduce__(self):
        return (os.system, (f"touch {MARKER}",))


def radiance(self, scene, rays, rng):
    reply_fd = json.loads(sys.argv[2])["reply_fd"]      # the config is on the command line
    data = pickle.dumps(("ok", Payload(), Payload()))
    os.write(reply_fd, len(data).to_bytes(4, "big") + data)
    return black(rays)


INTEGRATORS = registry(radiance)
