"""Hostile: lowers the grader's own limits with ``prlimit64`` on its pid, so that the grader
dies of SIGXCPU (its CPU limit set to one second it has already used) or cannot open its
results file (no file descriptors left), and every later test stays "not run".

EXPECT: prlimit64 is allowed only on the calling process itself (seccomp), and its real uid
is not the grader's (as root, a uid of its own; no CAP_SYS_RESOURCE); the grader lives on,
the submission returns black: zero points.
"""
import resource

from _hostile import Escaped, black, grader_pids, registry

EXPECT = dict(kind="black", words="")


def radiance(self, scene, rays, rng):
    for pid in grader_pids():
        for limit, value in ((resource.RLIMIT_CPU, (1, 1)), (resource.RLIMIT_NOFILE, (3, 3)),
                             (resource.RLIMIT_FSIZE, (0, 0))):
            try:
                resource.prlimit(pid, limit, value)
            except OSError:
                continue
            raise Escaped(f"ESCAPED: set limit {limit} of the grader {pid} to {value}")
        try:
            resource.prlimit(pid, resource.RLIMIT_CPU)
            raise Escaped(f"ESCAPED: read the CPU limit of the grader {pid}")
        except OSError:
            pass
    return black(rays)


INTEGRATORS = registry(radiance)
