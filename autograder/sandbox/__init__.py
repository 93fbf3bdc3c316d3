"""The student process's side of the grader (copied into the student runtime).

:mod:`.child` serves the grader's requests, :mod:`.wire` is the message format both sides
use, :mod:`.seccomp` the kernel filter built from :mod:`.syscalls`' allowlist,
:mod:`.landlock` the file-system confinement and :mod:`.privileges` the capabilities given
up. Nothing here imports the rest of the grader.
"""
