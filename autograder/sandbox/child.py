"""The student process: load a submission and answer the grader's requests.

Started by :class:`autograder.isolation.process.StudentProcess` as a fresh interpreter
(``python -S -E -s -B -c BOOT RUNTIME CONFIG``) from the *student runtime*
(:mod:`autograder.isolation.runtime`), already running as the unprivileged student user when
the grader runs as root with one. This file is copied there with :mod:`wire`, :mod:`seccomp`,
:mod:`syscalls`, :mod:`landlock` and :mod:`privileges`; it imports nothing of the grader.
Before the submission is imported it

1. puts the runtime and the dependency folders (NumPy, ...) on ``sys.path``;
2. sets the resource limits (address space, CPU time, output size, no core dumps, open
   files, locked memory, message queues, queued signals, threads of its real uid);
3. closes the sandbox (:func:`_sandbox`): no capabilities and no new privileges
   (:mod:`privileges`), Landlock (:mod:`landlock`: read the runtime, the submission's folder
   and the libraries, write nothing), the seccomp allowlist (:mod:`seccomp`), then an audit
   hook that turns reading files outside those folders into a clear ``PermissionError``. If
   the capabilities or the filter cannot be given up or installed it sends a ``setup`` error
   and never imports the submission (the grader stops grading); without Landlock it says so
   in its list of layers.

With ``probe`` in its configuration it stops there and only reports the layers.

Then it serves requests, one frame each (:mod:`wire`), until the grader closes the pipe:

``render``    the submission's integrator on a built-in scene -> ``mean``, ``variance``;
              camera rays come from the grader (``camera`` callback frames): the reference
              camera is not in the student runtime. A light tracer (``splats``) is rendered
              by the same driver as replicas of splatted images (its ``splat`` output is
              checked: pixels on the film, finite non-negative values), so the reply is the
              same two images;
``radiance``  the submission's integrator on rays the grader sends -> ``radiance``;
``rays``      the submission's ``camera_rays`` -> ``o``, ``d``.

Every error becomes an ``{"status": "error", "kind": ..., "message": ...}`` frame.
"""
from __future__ import annotations

import errno
import json
import os
import resource
import sys
import traceback

RUNTIME = None
CONFIG = None


def main(runtime: str, config_json: str) -> None:
    """Entry point (see the module docstring)."""
    global RUNTIME, CONFIG
    RUNTIME, CONFIG = runtime, json.loads(config_json)
    sys.path[:] = [runtime] + CONFIG["site"] + [p for p in sys.path if p and p.startswith(
        (sys.base_prefix, sys.prefix))]
    _limits(CONFIG["limits"])
    import numpy  # noqa: F401  (loaded before the sandbox closes: it reads its libraries)

    import pathtracer  # noqa: F401  (likewise loaded while files can still be read)
    from pathtracer import render  # noqa: F401  (likewise)
    from pathtracer.accel.blas import single_threaded_blas

    from . import wire
    single_threaded_blas()     # reads /proc/self/maps to find BLAS: done before the hook
    try:
        sandbox = _sandbox()
    except SandboxError as error:
        wire.write_frame(CONFIG["reply_fd"], _error("setup", str(error)))
        return
    _install_audit_hook()
    if CONFIG.get("probe"):      # the grader asks what holds here, before grading anything
        wire.write_frame(CONFIG["reply_fd"], {"status": "ready", "sandbox": sandbox})
        return
    server = Server(CONFIG, wire)
    header = {"status": "ready", "sandbox": sandbox}
    if server.load_error:
        header = {"status": "error", "kind": "import", "message": server.load_error}
    wire.write_frame(CONFIG["reply_fd"], header)
    server.serve()


# ----------------------------------------------------------------------------------------
# Limits and the audit hook


def _limits(limits: dict) -> None:
    from . import privileges
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
    cpu = int(limits["cpu_seconds"])
    resource.setrlimit(resource.RLIMIT_CPU, (cpu, cpu + 5))
    size = int(limits["output_bytes"])
    resource.setrlimit(resource.RLIMIT_FSIZE, (size, size))
    memory = int(limits["memory_mb"]) << 20
    resource.setrlimit(resource.RLIMIT_AS, (memory, memory))
    # Kernel memory outside RLIMIT_AS: open files, locked pages, message queues, queued
    # signals (pipes, sockets, memfd and SysV IPC are refused by the seccomp filter).
    files = int(limits.get("files", 64))
    resource.setrlimit(resource.RLIMIT_NOFILE, (files, files))
    for name, value in (("RLIMIT_MEMLOCK", 0), ("RLIMIT_MSGQUEUE", 0), ("RLIMIT_SIGPENDING", 64)):
        if hasattr(resource, name):         # Linux's; elsewhere the sandbox refuses anyway
            resource.setrlimit(getattr(resource, name), (value, value))
    # Threads (tasks) of the real uid: its own as the student user or as root (whose real
    # uid privileges.drop moves to a uid of its own); the user's others too otherwise.
    count = int(limits["processes"])
    if os.getuid() != 0 and not limits.get("own_user"):
        count += privileges.user_tasks(os.getuid())
    resource.setrlimit(resource.RLIMIT_NPROC, (count, count))


class SandboxError(Exception):
    """The sandbox could not be closed: the child refuses to run the submission."""


#: What the student process may read once the sandbox is closed, besides the runtime, the
#: submission's folder and the libraries (their folders beneath the site folders).
SYSTEM_READABLE = ("/dev/null", "/dev/zero", "/dev/urandom", "/dev/random", "/etc/ld.so.cache",
                   "/etc/localtime", "/sys/devices/system/cpu")
#: The only packages of the site folders it may read (the rest of a site folder, e.g. a
#: virtual environment's editable-install finders naming the grader's source, stays closed).
LIBRARIES = ("numpy", "numpy.libs", "scipy", "scipy.libs", "threadpoolctl", "threadpoolctl.py")


def readable_paths() -> tuple:
    """``(readable, listable)`` paths of the Landlock rules: read beneath the first, only
    list the second (the site folders, so that imports find the libraries in them)."""
    import sysconfig
    readable = [RUNTIME, CONFIG["submission_root"], f"/proc/{os.getpid()}", *SYSTEM_READABLE]
    readable += [sysconfig.get_path(name) for name in ("stdlib", "platstdlib")]
    listable = []
    for site in CONFIG["site"]:
        if os.path.isdir(site) and any(os.path.exists(os.path.join(site, n)) for n in LIBRARIES):
            listable.append(site)
            readable += [os.path.join(site, name) for name in LIBRARIES]
        else:
            readable.append(site)
    with open("/proc/self/maps") as maps:       # folders of the native libraries loaded
        for line in maps:
            fields = line.split(None, 5)      # address perms offset device inode [path]
            path = fields[5].strip() if len(fields) == 6 else ""
            if path.startswith("/") and ".so" in os.path.basename(path):
                readable.append(os.path.dirname(path))
    return readable, listable


def _sandbox() -> list:
    """Drop capabilities, confine the file system, install the seccomp filter; returns the
    layers that hold (SandboxError when one that must hold does not)."""
    from . import landlock, privileges, seccomp
    problem = seccomp.supported()
    if problem:
        raise SandboxError(f"{problem}; refusing to run a submission")
    problem, layers = privileges.drop()
    if problem:
        raise SandboxError(f"the student process keeps privileges ({problem}); refusing to "
                           "run a submission")
    version = landlock.abi()
    readable, listable = readable_paths()
    problem = landlock.restrict(readable, listable, version)
    layers.append(f"landlock ABI {version}" if not problem else
                  f"no file-system confinement ({problem})")
    problem = seccomp.install()
    if problem:
        raise SandboxError(f"{problem}; refusing to run a submission")
    layers.append("seccomp")
    return layers


#: Audit events that start processes, signal others or open sockets.
FORBIDDEN_EVENTS = {
    "os.system": "start programs", "os.exec": "start programs", "os.posix_spawn": "start programs",
    "os.spawn": "start programs", "subprocess.Popen": "start programs",
    "os.fork": "start processes", "os.forkpty": "start processes",
    "socket.__new__": "open sockets", "socket.connect": "open sockets",
}


def _install_audit_hook() -> None:
    """Clear messages for what the sandbox forbids (the kernel's filter is the guarantee)."""
    readable = tuple(os.path.realpath(p) + os.sep for p in
                     [RUNTIME, CONFIG["submission_root"]] + CONFIG["site"]
                     + [sys.base_prefix, sys.prefix] if p)
    pid, group = os.getpid(), os.getpgid(0)
    devices = ("/dev/null", "/dev/urandom", "/proc/self/", f"/proc/{pid}/",
               "/sys/devices/system/cpu/")

    def allowed(path) -> bool:
        if isinstance(path, int):
            return True
        path = os.path.realpath(os.fsdecode(path))
        return (path + os.sep).startswith(readable) or path.startswith(devices)

    def hook(event, args):
        what = FORBIDDEN_EVENTS.get(event)
        if what:
            raise PermissionError(f"the grading sandbox does not let submissions {what} ({event})")
        if event == "os.kill" and args[0] not in (pid, 0) \
                or event == "os.killpg" and args[0] not in (group, 0):
            raise PermissionError("the grading sandbox does not let submissions signal other "
                                  "processes")
        if event == "open" and not allowed(args[0]):
            raise PermissionError(f"the grading sandbox does not let submissions read {args[0]!r}")
        if event in ("os.listdir", "os.scandir", "glob.glob") and args and args[0] is not None \
                and not allowed(args[0]):
            raise PermissionError(f"the grading sandbox does not let submissions list {args[0]!r}")

    sys.addaudithook(hook)


# ----------------------------------------------------------------------------------------
# The submission


class ContractError(Exception):
    """The submission's output or shape breaks the contract (message for the student)."""


#: Added to the message of an error that the sandbox's refusal of a system call explains.
REFUSED_NOTE = ("\n(the grading sandbox refused a system call: a submission may compute, read its "
                "own folder, the tracer and NumPy/SciPy, and print; it may not start processes, "
                "write files, open pipes or sockets, or signal, trace or limit other processes)")


def _refused(error: BaseException) -> bool:
    """Whether ``error`` (or what caused it) is an EPERM or EACCES from the kernel."""
    seen = set()
    while error is not None and id(error) not in seen:
        seen.add(id(error))
        if isinstance(error, OSError) and error.errno in (errno.EPERM, errno.EACCES):
            return True
        error = error.__cause__ or error.__context__
    return False


def _traceback(error: BaseException, limit: int = 3000) -> str:
    text = "".join(traceback.format_exception(type(error), error, error.__traceback__))
    text = text if len(text) <= limit else "...\n" + text[-limit:]
    return text + (REFUSED_NOTE if _refused(error) else "")


def load_submission(path: str):
    """Import a ``.py`` file or package folder; returns ``(integrators, camera_rays)``."""
    import importlib.util
    import inspect
    import pkgutil

    from pathtracer.integrators.base import Integrator
    path = os.path.realpath(path)
    if os.path.isdir(path):
        init = os.path.join(path, "__init__.py")
        if not os.path.exists(init):
            raise ContractError(f"{os.path.basename(path)} is a folder without __init__.py "
                                "(not a Python package)")
        name, location, search = os.path.basename(path), init, [path]
    else:
        name, location, search = os.path.splitext(os.path.basename(path))[0], path, None
    module_name = f"student_impl_{name}".replace("-", "_")
    # Absolute imports of sibling modules keep working, as in the student's own checkout.
    sys.path.insert(1, os.path.dirname(path))
    spec = importlib.util.spec_from_file_location(module_name, location,
                                                  submodule_search_locations=search)
    module = importlib.util.module_from_spec(spec)
    sys.modules[module_name] = module
    spec.loader.exec_module(module)
    integrators = getattr(module, "INTEGRATORS", None)
    if integrators is None:
        integrators, modules = {}, [module]
        if search:
            modules += [importlib.import_module(f"{module_name}.{info.name}")
                        for info in pkgutil.iter_modules(search)]
        for mod in modules:
            for _, obj in inspect.getmembers(mod, inspect.isclass):
                if issubclass(obj, Integrator) and obj is not Integrator and obj.name != "base":
                    integrators.setdefault(obj.name, obj)
    if not isinstance(integrators, dict):
        raise ContractError("INTEGRATORS must be a dict name -> class")
    for key, cls in integrators.items():
        if not (inspect.isclass(cls) and issubclass(cls, Integrator)):
            raise ContractError(f"INTEGRATORS[{key!r}] is not a subclass of pathtracer.Integrator")
    return integrators, getattr(module, "camera_rays", None)


def own_code(function, root: str) -> bool:
    """Whether ``function`` was written in a file under ``root`` (the submission)."""
    code = getattr(function, "__code__", None)
    return code is not None and os.path.realpath(code.co_filename).startswith(root + os.sep)


def check_radiance(out, n: int, name: str):
    """``out`` if it is a valid radiance batch for ``n`` rays, else ContractError."""
    import numpy as np
    if not isinstance(out, np.ndarray):
        raise ContractError(f"{name}.radiance returned {type(out).__name__}, expected a NumPy "
                            f"array of shape ({n}, 3)")
    if out.shape != (n, 3):
        raise ContractError(f"{name}.radiance returned shape {out.shape} for {n} rays, expected "
                            f"({n}, 3): one RGB radiance per ray")
    if out.dtype.kind != "f":
        raise ContractError(f"{name}.radiance returned dtype {out.dtype}, expected floats")
    bad = ~np.isfinite(out)
    if bad.any():
        row = int(np.argwhere(bad)[0][0])
        raise ContractError(
            f"{name}.radiance returned {int(bad.any(axis=1).sum())} rays with NaN or Inf (first: "
            f"ray {row}, value {out[row].tolist()}; a division by a zero pdf or cosine?)")
    negative = out < 0
    if negative.any():
        row = int(np.argwhere(negative)[0][0])
        raise ContractError(f"{name}.radiance returned negative radiance for "
                            f"{int(negative.any(axis=1).sum())} rays (first: ray {row}, value "
                            f"{out[row].tolist()})")
    return out


def check_splats(out, n_pixels: int, name: str):
    """``out`` if it is a valid ``(pixel, value)`` pair of splats on a film of ``n_pixels``
    pixels, else ContractError (a pixel outside the film would land in another one)."""
    import numpy as np
    if not (isinstance(out, tuple) and len(out) == 2 and all(isinstance(x, np.ndarray) for x in out)):
        raise ContractError(f"{name}.splat returned {type(out).__name__}, expected a tuple "
                            "(pixel, value) of NumPy arrays")
    pixel, value = out
    if pixel.ndim != 1 or pixel.dtype.kind not in "iu":
        raise ContractError(f"{name}.splat: pixel must be a 1-D integer array, got shape "
                            f"{pixel.shape} dtype {pixel.dtype}")
    if value.shape != (len(pixel), 3) or value.dtype.kind != "f":
        raise ContractError(f"{name}.splat: value must be a float array of shape ({len(pixel)}, 3), "
                            f"got shape {value.shape} dtype {value.dtype}")
    outside = (pixel < 0) | (pixel >= n_pixels)
    if outside.any():
        raise ContractError(f"{name}.splat returned {int(outside.sum())} splats outside the film "
                            f"(first: pixel {int(pixel[outside][0])}; the film has {n_pixels} "
                            "pixels, flat index row * width + column): drop what the camera does not see")
    bad = ~np.isfinite(value)
    if bad.any():
        raise ContractError(f"{name}.splat returned {int(bad.any(axis=1).sum())} splats with NaN "
                            "or Inf (a division by a zero pdf, cosine or distance?)")
    if (value < 0).any():
        raise ContractError(f"{name}.splat returned {int((value < 0).any(axis=1).sum())} "
                            "negative splats")
    return pixel.astype(np.int64), value


def graded_method(cls) -> str:
    """The method a student writes: ``splat`` for an integrator that splats, else ``radiance``."""
    return "splat" if cls.splats else "radiance"


def checked_class(cls, name: str):
    """A subclass of ``cls`` whose radiance (or splat) checks its output. A subclass, not a
    wrapped bound method: the render driver copies the instance to apply the scene file's
    options, and the copy must run with them."""
    if graded_method(cls) == "splat":
        def splat(self, scene, rng, *args):
            n_pixels = scene.camera.width * scene.camera.height
            return check_splats(cls.splat(self, scene, rng, *args), n_pixels, name)
        return type(cls.__name__, (cls,), {"splat": splat})

    def radiance(self, scene, rays, rng):
        return check_radiance(cls.radiance(self, scene, rays, rng), len(rays), name)
    return type(cls.__name__, (cls,), {"radiance": radiance})


class Server:
    """The child's state: the submission, loaded scenes, the pipes."""

    def __init__(self, config: dict, wire):
        self.wire = wire
        self.request_fd, self.reply_fd = config["request_fd"], config["reply_fd"]
        self.trusted = bool(config.get("trusted"))
        self.root = os.path.realpath(config["submission_root"])
        self.scenes = {}
        self.integrators, self.camera_rays, self.load_error = {}, None, ""
        try:
            self.integrators, self.camera_rays = load_submission(config["submission"])
        except ContractError as error:
            self.load_error = f"your implementation breaks the contract: {error}"
        except BaseException as error:  # whatever the import does is reported
            self.load_error = "importing your implementation failed:\n" + _traceback(error)

    # -- requests ------------------------------------------------------------------------
    def serve(self) -> None:
        while True:
            try:
                header, arrays = self.wire.read_frame(self.request_fd)
            except self.wire.WireError:
                return
            if header.get("kind") == "quit":
                return
            reply, out = self.handle(header, arrays)
            try:
                sys.stdout.flush()
                sys.stderr.flush()
            except (OSError, ValueError):
                pass
            self.wire.write_frame(self.reply_fd, reply, out)

    def handle(self, header: dict, arrays: dict):
        """({"status": ...}, arrays) for one request; errors become error frames."""
        memory = CONFIG["limits"]["memory_mb"]
        try:
            kind = header["kind"]
            if kind == "render":
                return {"status": "ok"}, self.render(header)
            if kind == "radiance":
                return {"status": "ok"}, self.radiance(header, arrays)
            if kind == "rays":
                return {"status": "ok"}, self.rays(header, arrays)
            return _error("protocol", f"unknown request {kind!r}"), {}
        except MemoryError:
            return _error("memory", f"your code ran out of memory (limit {memory} MB for the "
                          "student process): do not keep per-bounce arrays of every path"), {}
        except NotImplementedError as error:
            return _error("not-implemented", "not implemented yet: "
                          + (str(error) or "NotImplementedError") + "\n"
                          + _traceback(error, 800)), {}
        except ContractError as error:
            return _error("output", str(error)), {}
        except RecursionError as error:
            return _error("exception", "RecursionError (recursion too deep: use a loop over "
                          "bounces)\n" + _traceback(error, 1200)), {}
        except BaseException as error:  # SystemExit included: reported, not obeyed
            return _error("exception", "your code raised an exception:\n" + _traceback(error)), {}

    def scene(self, name: str, params: dict):
        from pathtracer import load_scene
        from pathtracer.shapes import intersect
        key = (name, tuple(sorted(params.items())))
        if key not in self.scenes:
            scene = load_scene(name, **params)
            intersect.prepare(scene)
            self.scenes[key] = scene
        return self.scenes[key]

    def integrator(self, scene, name: str):
        """The submission's integrator ``name`` (checked), with the scene file's parameters
        when the file names the same integrator; render() adds the file's path options."""
        cls = self.integrators.get(name)
        if cls is None:
            raise ContractError(f"your implementation has no integrator named {name!r} (it has: "
                                f"{', '.join(sorted(self.integrators)) or 'none'})")
        method = graded_method(cls)
        if not hasattr(cls, method):     # pathtracer.Integrator itself has neither method
            raise ContractError(f"INTEGRATORS[{name!r}] has no {method}: implement {method} in your "
                                "own class")
        written = getattr(cls, method)
        if not self.trusted and not own_code(written, self.root):
            raise ContractError(
                f"INTEGRATORS[{name!r}].{method} is not written in your submission (it comes from "
                f"{getattr(written, '__module__', '?')}): implement {method} in your own "
                "class; the grader does not accept the library's classes or stubs")
        spec = scene.integrator
        options = dict(spec.params) if spec is not None and spec.name == name else {}
        return checked_class(cls, name)(**options)

    def reference_camera(self, camera, pixel, u_film):
        """Camera rays from the grader (the reference camera lives only there)."""
        from pathtracer.sensors.perspective import Rays
        self.wire.write_frame(self.reply_fd, {"status": "camera"},
                              {"pixel": pixel, "u_film": u_film})
        header, arrays = self.wire.read_frame(
            self.request_fd, expect={"o": ("f8", (len(pixel), 3)), "d": ("f8", (len(pixel), 3)),
                                     "tmax": ("f8", (len(pixel),))})
        return Rays(arrays["o"], arrays["d"], arrays["tmax"])

    def render(self, request: dict) -> dict:
        from pathtracer import render
        scene = self.scene(request["scene"], request["params"])
        integrator = self.integrator(scene, request["integrator"])
        # An explicit max_depth must override the scene file's, so it goes to render().
        depth = {} if request.get("max_depth") is None else {"max_depth": int(request["max_depth"])}
        result = render(scene, integrator, spp=int(request["spp"]), seed=int(request["seed"]),
                        processes=1, progress=False, camera=self.reference_camera, **depth)
        return {"mean": result.mean, "variance": result.variance}

    def radiance(self, request: dict, arrays: dict) -> dict:
        import numpy as np

        from pathtracer.core.rng import RandomStream, sample_keys
        from pathtracer.render.driver import integrator_for
        from pathtracer.sensors.perspective import Rays
        scene = self.scene(request["scene"], request["params"])
        integrator = integrator_for(scene, self.integrator(scene, request["integrator"]))
        n = len(arrays["o"])
        rng = RandomStream(sample_keys(int(request["seed"]), np.arange(n, dtype=np.int64)))
        rays = Rays(arrays["o"], arrays["d"], arrays["tmax"])
        return {"radiance": integrator.radiance(scene, rays, rng)}

    def rays(self, request: dict, arrays: dict) -> dict:
        import numpy as np
        if self.camera_rays is None:
            raise ContractError("your implementation has no camera_rays function")
        scene = self.scene(request["scene"], request["params"])
        rays = self.camera_rays(scene.camera, arrays["pixel"], arrays["u_film"])
        n = len(arrays["pixel"])
        out = {}
        for field in ("o", "d"):
            value = getattr(rays, field, None)
            if not isinstance(value, np.ndarray) or value.shape != (n, 3):
                raise ContractError(f"camera_rays: rays.{field} must be an array of shape ({n}, 3)")
            out[field] = value
        return out


def _error(kind: str, message: str) -> dict:
    return {"status": "error", "kind": kind, "message": message[:20000]}
