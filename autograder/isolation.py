"""Run the student's code in a child process with a wall-clock, memory and output limit.

One :class:`StudentProcess` serves one graded test: the parent sends render requests
(scene name, film parameters, integrator name, spp, seed, max_depth) over a pipe and gets
back ``(mean, variance)``. The child

* is forked from a *fork server* started before any reference is loaded, so it holds no
  reference image in memory, and it is never told a reference's path or the results file's;
* starts its own session (process group), closes stdin, and sends stdout and stderr to a
  capture file capped by ``RLIMIT_FSIZE``: a submission that prints more than the limit fails
  the test;
* has ``RLIMIT_AS`` (address space) as its memory limit, no core dumps, and a CPU-time limit
  as a second line behind the parent's wall-clock deadline;
* drops to an unprivileged user when the grader runs as root and ``AUTOGRADER_STUDENT_USER``
  names one (the Gradescope setup script creates it; references and results are then not
  readable or writable by the student's code at all);
* checks every ``radiance`` call itself (shape ``(n, 3)``, real dtype, finite values) so that
  the message names the first bad ray.

Whatever the child does (raise, hang, ``os._exit``, segfault, exhaust memory, print
megabytes) the parent turns it into a :class:`StudentFailure` with a message a student can
act on, kills the whole process group, and grading goes on with the next test.
"""
from __future__ import annotations

import multiprocessing
import os
import resource
import signal
import sys
import tempfile
import time
import traceback
import types
from dataclasses import dataclass

import numpy as np

#: Environment variables the child must not see (paths of references and results).
PRIVATE_ENV = ("MITSUBA_REFS_CACHE", "AUTOGRADER_RESULTS", "AUTOGRADER_REFERENCES")
#: Unprivileged user the child switches to when the grader runs as root.
ENV_STUDENT_USER = "AUTOGRADER_STUDENT_USER"


@dataclass
class Limits:
    """Resource limits of one test's student process.

    Attributes
    ----------
    seconds : float  wall-clock limit for everything the test asks of the student's code
    memory_mb : int  address-space limit (``RLIMIT_AS``) of the child
    output_bytes : int  most stdout + stderr the child may print
    """

    seconds: float = 60.0
    memory_mb: int = 1024
    output_bytes: int = 1 << 20


class StudentFailure(Exception):
    """The student's code failed in a way that fails the test (message for the student)."""

    def __init__(self, message: str, kind: str = "error"):
        super().__init__(message)
        self.kind = kind


_CONTEXT = None


def context():
    """The fork-server context (started lazily; preloads NumPy and the tracer only)."""
    global _CONTEXT
    if _CONTEXT is None:
        ctx = multiprocessing.get_context("forkserver")
        ctx.set_forkserver_preload(["numpy", "pathtracer", "autograder.isolation"])
        _CONTEXT = ctx
    return _CONTEXT


def start_fork_server() -> None:
    """Start the fork server now, before the parent loads any reference."""
    from multiprocessing import forkserver
    context()
    forkserver.ensure_running()


# ----------------------------------------------------------------------------------------
# Parent side


class StudentProcess:
    """The student's implementation in an isolated child, for one test.

    Use as a context manager; :meth:`render` has the signature of the ``render=`` hook of
    :func:`mitsuba_refs.compare.compare`.
    """

    def __init__(self, impl: str, limits: Limits | None = None):
        # The child works in a private folder: a relative path must be made absolute here.
        self.impl = os.path.abspath(impl) if os.path.exists(impl) else impl
        self.limits = limits or Limits()
        self.process = None
        self.conn = None
        self.deadline = None
        self.calls = 0
        self.last_render = None
        self._tmp = tempfile.TemporaryDirectory(prefix="autograder-")
        self.output_path = os.path.join(self._tmp.name, "student-output.txt")

    # -- lifecycle -----------------------------------------------------------------------
    def __enter__(self):
        self.start()
        return self

    def __exit__(self, *exc):
        self.close()
        return False

    def start(self):
        ctx = context()
        parent, child = ctx.Pipe(duplex=True)
        limits = (float(self.limits.seconds), int(self.limits.memory_mb),
                  int(self.limits.output_bytes))
        os.chmod(self._tmp.name, 0o777)
        self.process = ctx.Process(target=child_main, name="student",
                                   args=(child, self.impl, limits, self.output_path), daemon=True)
        self.deadline = time.monotonic() + self.limits.seconds
        # The child must not re-run the parent's main script (pytest's or a user's).
        main = sys.modules.get("__main__")
        sys.modules["__main__"] = types.ModuleType("__main__")
        try:
            self.process.start()
        finally:
            sys.modules["__main__"] = main
        child.close()
        self.conn = parent

    def close(self):
        if self.process is not None:
            if self.process.is_alive():
                try:
                    self.conn.send(("quit", None))
                except (OSError, ValueError):
                    pass
                self.process.join(0.5)
            self._kill()
        if self.conn is not None:
            self.conn.close()
            self.conn = None
        self._tmp.cleanup()

    def _kill(self):
        proc = self.process
        if proc.pid is not None:
            for target in (lambda: os.killpg(proc.pid, signal.SIGKILL),
                           lambda: os.kill(proc.pid, signal.SIGKILL)):
                try:
                    target()
                except (ProcessLookupError, PermissionError, OSError):
                    pass
        proc.join(5)

    # -- requests ------------------------------------------------------------------------
    def output(self, limit: int = 2000) -> str:
        """The first ``limit`` characters the student's code printed."""
        try:
            with open(self.output_path, "rb") as f:
                return f.read(limit).decode("utf-8", "replace")
        except OSError:
            return ""

    def output_size(self) -> int:
        try:
            return os.path.getsize(self.output_path)
        except OSError:
            return 0

    def _check_output(self):
        if self.output_size() >= self.limits.output_bytes:
            raise StudentFailure(
                f"your code printed more than {self.limits.output_bytes // 1024} KB of output "
                "(print statements in the radiance loop?); remove them. It begins with:\n"
                + self.output(300), "output")

    def request(self, kind: str, payload: dict):
        """Send one request and wait (at most until the test's deadline) for the reply."""
        if self.process is None:
            self.start()
        if not self.process.is_alive():
            raise self._death()
        try:
            self.conn.send((kind, payload))
        except (OSError, ValueError, BrokenPipeError):
            raise self._death() from None
        remaining = self.deadline - time.monotonic()
        try:
            ready = remaining > 0 and self.conn.poll(remaining)
        except (OSError, EOFError):
            ready = True
        if not ready:
            self._kill()
            self._check_output()
            raise StudentFailure(
                f"time limit: your code did not finish within the {self.limits.seconds:.0f} s "
                "this test allows (an endless loop? paths that never terminate: Russian "
                "roulette or max_depth ignored?)", "timeout")
        try:
            reply = self.conn.recv()
        except (EOFError, OSError):
            raise self._death() from None
        except Exception as error:  # an unpicklable or garbled reply
            self._kill()
            raise StudentFailure(f"the grading process returned an unreadable reply ({error})",
                                 "crash") from None
        self._check_output()
        status = reply[0]
        if status == "error":
            raise StudentFailure(reply[2], reply[1])
        return reply[1:]

    def _death(self) -> StudentFailure:
        """A failure describing how the child ended."""
        self.process.join(2)
        code = self.process.exitcode
        self._kill()
        try:
            self._check_output()
        except StudentFailure as failure:
            return failure
        printed = self.output(600).strip()
        tail = f"\nIt printed:\n{printed}" if printed else ""
        if code is None:
            return StudentFailure("your code stopped answering (closed the grader's pipe)" + tail,
                                  "crash")
        if code < 0:
            name = signal.Signals(-code).name if -code in signal.Signals._value2member_map_ else str(-code)
            why = {"SIGSEGV": "a segmentation fault (a crash inside a C extension?)",
                   "SIGKILL": "it was killed (out of memory?)",
                   "SIGXCPU": "it used up its CPU-time limit",
                   "SIGXFSZ": "it printed more output than allowed",
                   "SIGABRT": "it aborted"}.get(name, "a signal")
            return StudentFailure(f"your code crashed the grading process: {name}, {why}" + tail,
                                  "crash")
        return StudentFailure(
            f"your code ended the grading process (exit code {code}, e.g. sys.exit() or "
            f"os._exit()) before returning a result" + tail, "crash")

    def render(self, scene, integrator, params, spp, seed, processes=None, max_depth=None,
               camera="reference"):
        """``(mean, variance)`` of the student's integrator; validated, else StudentFailure."""
        name = integrator if isinstance(integrator, str) else integrator.name
        params = {str(k): str(v) for k, v in (params or {}).items()}
        payload = dict(scene=scene, params=params, integrator=name, spp=int(spp),
                       seed=int(seed), max_depth=max_depth, camera=camera)
        self.calls += 1
        mean, variance = self.request("render", payload)
        width, height = int(params.get("width", 0)), int(params.get("height", 0))
        mean = validate_image(mean, "mean", (height, width, 3) if width and height else None)
        variance = validate_image(variance, "variance", mean.shape)
        self.last_render = (seed, max_depth, mean, variance)
        return mean, variance

    def probe(self, scene, params, integrator, n=4096, seed=99):
        """(distinct results of the student's integrator, of the reference one) for ``n``
        copies of the centre pixel's ray with independent random streams."""
        params = {str(k): str(v) for k, v in (params or {}).items()}
        student, reference = self.request("probe", dict(scene=scene, params=params,
                                                        integrator=integrator, n=n, seed=seed))
        return int(student), int(reference)

    def rays(self, scene, params, pixel, u_film):
        """The student's ``camera_rays`` for given pixels and film samples: ``(o, d)``."""
        params = {str(k): str(v) for k, v in (params or {}).items()}
        o, d = self.request("rays", dict(scene=scene, params=params, pixel=np.asarray(pixel),
                                         u_film=np.asarray(u_film)))
        return (validate_array(o, "ray origins", (len(pixel), 3)),
                validate_array(d, "ray directions", (len(pixel), 3)))


def validate_array(x, what, shape=None) -> np.ndarray:
    """A finite real float64 array of ``shape``, else StudentFailure."""
    if not isinstance(x, np.ndarray):
        raise StudentFailure(f"{what}: expected a NumPy array, got {type(x).__name__}", "output")
    if x.dtype.kind not in "fiu":
        raise StudentFailure(f"{what}: expected real floats, got dtype {x.dtype}", "output")
    if shape is not None and tuple(x.shape) != tuple(shape):
        raise StudentFailure(f"{what}: shape {x.shape}, expected {tuple(shape)}", "output")
    x = x.astype(np.float64)
    bad = ~np.isfinite(x)
    if bad.any():
        where = np.argwhere(bad)[0]
        raise StudentFailure(f"{what}: {int(bad.sum())} NaN/Inf values (first at index "
                             f"{tuple(int(i) for i in where)})", "output")
    return x


def validate_image(x, what, shape=None) -> np.ndarray:
    x = validate_array(x, f"the rendered {what} image", shape)
    if x.ndim != 3 or x.shape[2] != 3:
        raise StudentFailure(f"the rendered {what} image has shape {x.shape}, expected (H, W, 3)",
                             "output")
    return x


# ----------------------------------------------------------------------------------------
# Child side


def _apply_limits(seconds: float, memory_mb: int, output_bytes: int, output_path: str) -> None:
    os.setsid()
    for name in PRIVATE_ENV:
        os.environ.pop(name, None)
    fd = os.open(output_path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o666)
    devnull = os.open(os.devnull, os.O_RDONLY)
    os.dup2(devnull, 0)
    os.dup2(fd, 1)
    os.dup2(fd, 2)
    os.close(fd)
    os.close(devnull)
    sys.stdout = os.fdopen(1, "w", buffering=1, closefd=False)
    sys.stderr = os.fdopen(2, "w", buffering=1, closefd=False)
    user = os.environ.pop(ENV_STUDENT_USER, None)
    if user and os.geteuid() == 0:
        import pwd
        entry = pwd.getpwnam(user)
        os.setgroups([])
        os.setgid(entry.pw_gid)
        os.setuid(entry.pw_uid)
        os.chdir(os.path.dirname(output_path))
    else:
        os.chdir(os.path.dirname(output_path))
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
    cpu = int(seconds) + 10
    resource.setrlimit(resource.RLIMIT_CPU, (cpu, cpu + 5))
    resource.setrlimit(resource.RLIMIT_FSIZE, (output_bytes, output_bytes))
    memory = memory_mb * 1024 * 1024
    resource.setrlimit(resource.RLIMIT_AS, (memory, memory))


def _student_traceback(error: BaseException, limit: int = 3000) -> str:
    text = "".join(traceback.format_exception(type(error), error, error.__traceback__))
    if len(text) > limit:
        text = "...\n" + text[-limit:]
    return text


class _Checked:
    """Wraps an integrator's ``radiance`` with the contract's checks."""

    def __init__(self, radiance, name):
        self.radiance, self.name = radiance, name

    def __call__(self, scene, rays, rng):
        n = len(rays)
        out = self.radiance(scene, rays, rng)
        if not isinstance(out, np.ndarray):
            raise ContractError(f"{self.name}.radiance returned {type(out).__name__}, expected a "
                                f"NumPy array of shape ({n}, 3)")
        if out.shape != (n, 3):
            raise ContractError(f"{self.name}.radiance returned shape {out.shape} for {n} rays, "
                                f"expected ({n}, 3): one RGB radiance per ray")
        if out.dtype.kind != "f":
            raise ContractError(f"{self.name}.radiance returned dtype {out.dtype}, expected floats")
        bad = ~np.isfinite(out)
        if bad.any():
            row = int(np.argwhere(bad)[0][0])
            raise ContractError(
                f"{self.name}.radiance returned {int(bad.any(axis=1).sum())} rays with NaN or Inf "
                f"(first: ray {row}, value {out[row].tolist()}; a division by a zero pdf or "
                "cosine?)")
        negative = out < 0
        if negative.any():
            row = int(np.argwhere(negative)[0][0])
            raise ContractError(f"{self.name}.radiance returned negative radiance for "
                                f"{int(negative.any(axis=1).sum())} rays (first: ray {row}, "
                                f"value {out[row].tolist()})")
        return out


class ContractError(Exception):
    """The student's output breaks the contract."""


def _checked_camera(camera_rays):
    def checked(camera, pixel, u_film):
        rays = camera_rays(camera, pixel, u_film)
        n = len(pixel)
        for field in ("o", "d"):
            value = getattr(rays, field, None)
            if not isinstance(value, np.ndarray) or value.shape != (n, 3):
                raise ContractError(f"camera_rays: rays.{field} must be an array of shape ({n}, 3)")
            if not np.isfinite(value).all():
                raise ContractError(f"camera_rays: rays.{field} has NaN/Inf values")
        return rays
    return checked


class _Server:
    """The child's state: the implementation, loaded scenes, the original camera."""

    def __init__(self, impl_spec):
        import importlib
        render_module = importlib.import_module("pathtracer.render")   # the module, not the function
        self.render_module = render_module
        self.reference_camera = render_module.camera_rays
        self.scenes = {}
        self.impl, self.import_error = None, None
        try:
            from .contract import load_implementation
            self.impl = load_implementation(impl_spec)
        except BaseException as error:  # noqa: BLE001 - anything the import does is reported
            self.import_error = ("import", "importing your implementation failed:\n"
                                 + _student_traceback(error))

    def scene(self, name, params):
        key = (name, tuple(sorted(params.items())))
        if key not in self.scenes:
            from pathtracer import load_scene
            self.scenes[key] = load_scene(name, **params)
        return self.scenes[key]

    def integrator(self, scene, name, max_depth):
        from pathtracer.integrators import INTEGRATORS as REFERENCE
        if name.startswith("reference:"):
            cls = REFERENCE[name.split(":", 1)[1]]
        else:
            cls = self.impl.integrators.get(name)
            if cls is None:
                raise ContractError(f"your implementation has no integrator named {name!r} "
                                    f"(it has: {', '.join(sorted(self.impl.integrators)) or 'none'})")
        spec = scene.integrator
        options = dict(spec.params) if spec is not None and spec.name == name else {}
        if max_depth is not None:
            options["max_depth"] = int(max_depth)
        integrator = cls(**options)
        integrator.radiance = _Checked(integrator.radiance, name)
        return integrator

    def camera(self, which):
        if which == "student":
            if self.impl.camera_rays is None:
                raise ContractError("your implementation has no camera_rays function")
            self.render_module.camera_rays = _checked_camera(self.impl.camera_rays)
        else:
            self.render_module.camera_rays = self.reference_camera

    def probe(self, payload):
        """Distinct results of ``n`` copies of one camera ray, each with its own random
        stream: (student's count, reference integrator's count)."""
        from pathtracer import geometry
        from pathtracer.integrators import INTEGRATORS as REFERENCE
        from pathtracer.rng import RandomStream, sample_keys
        scene = self.scene(payload["scene"], payload["params"])
        geometry.prepare(scene)
        self.camera("reference")
        n, name = int(payload["n"]), payload["integrator"]
        camera = scene.camera
        pixel = np.full(n, (camera.height // 2) * camera.width + camera.width // 2)
        rays = self.render_module.camera_rays(camera, pixel, np.full((n, 2), 0.5))
        counts = []
        for integrator in (self.integrator(scene, name, None),
                           REFERENCE[name]() if name in REFERENCE else None):
            if integrator is None:
                counts.append(-1)
                continue
            rng = RandomStream(sample_keys(int(payload["seed"]), np.arange(n, dtype=np.int64)))
            out = integrator.radiance(scene, rays, rng)
            counts.append(int(len(np.unique(np.round(out, 12), axis=0))))
        return tuple(counts)

    def handle(self, kind, payload):
        if kind == "ping":
            return ("ok", True)
        if self.import_error:
            return ("error",) + self.import_error
        if kind == "render":
            from pathtracer import render
            scene = self.scene(payload["scene"], payload["params"])
            integrator = self.integrator(scene, payload["integrator"], payload["max_depth"])
            self.camera(payload["camera"])
            result = render(scene, integrator, spp=payload["spp"], seed=payload["seed"],
                            processes=1, progress=False)
            return ("ok", result.mean, result.variance)
        if kind == "probe":
            return ("ok",) + self.probe(payload)
        if kind == "rays":
            scene = self.scene(payload["scene"], payload["params"])
            self.camera("student")
            rays = self.render_module.camera_rays(scene.camera, payload["pixel"], payload["u_film"])
            return ("ok", np.asarray(rays.o, np.float64), np.asarray(rays.d, np.float64))
        return ("error", "protocol", f"unknown request {kind!r}")


def child_main(conn, impl_spec, limits, output_path):
    """Entry point of the student process."""
    seconds, memory_mb, output_bytes = limits
    _apply_limits(seconds, memory_mb, output_bytes, output_path)
    server = _Server(impl_spec)
    while True:
        try:
            kind, payload = conn.recv()
        except (EOFError, OSError):
            return
        if kind == "quit":
            return
        try:
            reply = server.handle(kind, payload)
        except MemoryError:
            reply = ("error", "memory", f"your code ran out of memory (limit {memory_mb} MB "
                     "for the student process): do not keep per-bounce arrays of every path")
        except NotImplementedError as error:
            reply = ("error", "not-implemented", "not implemented yet: "
                     + (str(error) or "NotImplementedError") + "\n" + _student_traceback(error, 800))
        except ContractError as error:
            reply = ("error", "output", str(error))
        except RecursionError as error:
            reply = ("error", "exception", "RecursionError (recursion too deep: use a loop over "
                     "bounces)\n" + _student_traceback(error, 1200))
        except BaseException as error:  # noqa: BLE001 - SystemExit included: reported, not obeyed
            reply = ("error", "exception", "your code raised an exception:\n"
                     + _student_traceback(error))
        try:
            sys.stdout.flush()
            sys.stderr.flush()
        except (OSError, ValueError):
            pass
        try:
            conn.send(reply)
        except (OSError, ValueError):
            return
