"""The student process's side of the grader (copied into the student runtime).

:mod:`.child` serves the grader's requests, :mod:`.wire` is the message format both sides
use, :mod:`.seccomp` the kernel filter. Nothing here imports the rest of the grader.
"""
