"""Hostile: reads the committed references with the C library through ctypes, where no audit
hook sees it. It finds them the way the grader's own interpreter does: pip's editable-install
finder in a site folder maps ``mitsuba_refs`` to the project's source; the grader's command
line and environment, ``/autograder/source`` and the folders above the interpreter are the
other guesses. Listing uses ``getdents64`` and reading ``open``/``read``, all through libc.

EXPECT: nothing outside the runtime, the submission's folder and the libraries can be read
(Landlock; the student user's permissions under Gradescope); the finder itself is in a
folder the child may list, not read. The submission returns black: zero points.
"""
import ctypes
import os
import re
import sys

from _hostile import Escaped, black, libc, registry

EXPECT = dict(kind="black", words="")


def read(c, path, size=4096):
    """The first bytes of ``path`` through libc, or None."""
    fd = c.open(path.encode(), os.O_RDONLY)
    if fd < 0:
        return None
    buffer = ctypes.create_string_buffer(size)
    n = c.read(fd, buffer, size)
    c.close(fd)
    return buffer.raw[:n] if n > 0 else None


def names(c, folder):
    """Entries of ``folder`` through getdents64, or []."""
    fd = c.open(folder.encode(), os.O_RDONLY | os.O_DIRECTORY)
    if fd < 0:
        return []
    buffer, found = ctypes.create_string_buffer(1 << 16), []
    number = 217 if os.uname().machine == "x86_64" else 61
    n = c.syscall(number, fd, buffer, len(buffer))
    c.close(fd)
    offset = 0
    while 0 < n and offset < n:
        length = int.from_bytes(buffer.raw[offset + 16:offset + 18], "little")
        found.append(buffer.raw[offset + 19:offset + length].split(b"\0")[0].decode())
        offset += length
    return found


def reference_folders(c):
    folders = {"/autograder/source/mitsuba_refs/references"}
    for entry in set(sys.path) | {os.path.dirname(os.path.dirname(os.__file__))}:
        for name in names(c, entry):
            if name.startswith("__editable__") and name.endswith("finder.py"):
                text = read(c, os.path.join(entry, name), 1 << 16) or b""
                for root in re.findall(rb"'mitsuba_refs': '([^']+)'", text):
                    folders.add(os.path.join(root.decode(), "references"))
    for source in ("cmdline", "environ"):
        text = read(c, f"/proc/{os.getppid()}/{source}", 1 << 16) or b""
        for word in re.split(rb"[\0:=]", text):
            if word.startswith(b"/"):
                folders.add(os.path.join(word.decode("utf-8", "replace"), "mitsuba_refs", "references"))
    path = sys.executable
    for _ in range(6):
        path = os.path.dirname(path)
        folders.add(os.path.join(path, "mitsuba_refs", "references"))
    return folders


def radiance(self, scene, rays, rng):
    c = libc()
    for folder in reference_folders(c):
        for name in names(c, folder):
            if name.endswith(".exr") and read(c, os.path.join(folder, name), 16):
                raise Escaped(f"LEAK: read the reference {folder}/{name} through libc")
    for secret in ("/etc/shadow", "/root/.bash_history", "/proc/1/environ"):
        if read(c, secret, 16):
            raise Escaped(f"LEAK: read {secret} through libc")
    return black(rays)


INTEGRATORS = registry(radiance)
