"""Run a submission in a sandboxed process that cannot cheat, escape or outlive its test.

One :class:`StudentProcess` serves one graded test. It starts a fresh interpreter from the
*student runtime* (:mod:`.runtime`: the tracer without the reference solution) running
:mod:`autograder.sandbox.child`, and talks to it over two pipes in plain frames
(:mod:`autograder.sandbox.wire`: a JSON header and raw float64 arrays, checked against the
exact names, dtypes and shapes expected; never pickle, so a reply cannot run code here).

Layers, from the strongest (docs/autograder.md, "Which boundary holds where"):

* **A user of its own** when the grader runs as root and ``AUTOGRADER_STUDENT_USER`` names
  one (Gradescope's setup creates ``student``): the references, the solution, the grader
  and the results are not readable or writable by it (:func:`.environment.audit_environment`
  checks this before grading and refuses to grade otherwise), it cannot signal the grader,
  and every process of that user is killed when the test ends.
* **No capabilities, no new privileges** (:mod:`autograder.sandbox.privileges`): a child of a
  root grader without a student user drops every capability before the submission runs, or
  refuses to run it.
* **Landlock** (:mod:`autograder.sandbox.landlock`, where the kernel has it): the child reads
  only the runtime, the submission's folder and the libraries, and writes nothing, whatever
  its user; no ptrace of, nor signals to, processes outside it.
* **A seccomp allowlist** (:mod:`autograder.sandbox.seccomp`, :mod:`autograder.sandbox.syscalls`):
  default deny; no new processes, no signals or prlimit to other processes, no file writes,
  no pipes, sockets or memfd, whatever the user.
* **The grader not dumpable** (:func:`.environment.protect_grader`): its memory is closed to
  the child even where both are one user.
* **Resource limits**: address space, CPU time (behind the grader's wall-clock deadline),
  output size, no core dumps, open files, threads of its real uid, queued signals.
* **Its own session**: the whole process group is killed at the end of the test.
* **An audit hook** in the child, for clear messages only (reading files outside the
  runtime, the submission and the libraries; starting processes).

Whatever the child does (raise, hang, exit, crash, exhaust memory, print megabytes, send
garbage) the parent turns it into a :class:`StudentFailure` with a message a student can
act on, kills it, and grading goes on with the next test.
"""
from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass

import numpy as np

from mitsuba_refs.verdicts.scenes import loaded_scene
from pathtracer import render
from pathtracer.core.rng import RandomStream, sample_keys
from pathtracer.integrators import make_integrator
from pathtracer.render.driver import integrator_for
from pathtracer.sensors.perspective import Rays, camera_rays

from ..sandbox import wire
from . import runtime as runtimes
from .environment import Environment, SetupError, kill_user_processes, protect_grader

#: The implementation that means "the reference solution" (graded in the solution runtime).
SOLUTION = "autograder.solution"
#: Most processes (threads included) of the student process's real uid while it runs (as
#: the grader's own non-root user: that many more than the user runs when it starts).
STUDENT_PROCESSES = 64
#: Most open files of the student process.
STUDENT_FILES = 64
#: Largest batch of camera rays the child may ask the grader for at once.
MAX_CAMERA_BATCH = 1 << 20
#: What an error frame may say it is.
ERROR_KINDS = ("import", "memory", "not-implemented", "output", "exception", "protocol",
               "setup")


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


# ----------------------------------------------------------------------------------------
# The student process


class StudentProcess:
    """A submission in a sandboxed child, for one test.

    Parameters
    ----------
    impl : str
        A ``.py`` file or package folder, or :data:`SOLUTION`.
    limits : Limits, optional
    trusted : bool
        Run in the *solution* runtime, where the reference integrators exist and a
        submission may build on them: for the reference solution and the instructors' bug
        zoo and alternatives only. Implied by ``impl == SOLUTION``.
    environment : Environment, optional

    Use as a context manager; :meth:`render` has the signature of the ``render=`` hook of
    :func:`mitsuba_refs.verdicts.compare.compare`.
    """

    def __init__(self, impl: str, limits: Limits | None = None, *, trusted: bool = False,
                 environment: Environment | None = None, probe: bool = False):
        self.trusted = trusted or impl == SOLUTION
        self.environment = environment or Environment()
        # A solution runtime is readable by others only when the child needs it to be.
        public = not self.trusted or self.environment.ids() is not None
        self.runtime = runtimes.cached("solution" if self.trusted else "student", public)
        if impl == SOLUTION:
            impl = str(self.runtime / "solution")
        if not os.path.exists(impl):
            raise StudentFailure(f"no submission at {impl}", "import")
        self.impl = os.path.realpath(impl)
        self.limits = limits or Limits()
        self.process = None
        self.deadline = None
        self.sandbox = []
        self._private = tempfile.mkdtemp(prefix="autograder-")          # 0700: grader only
        self._scratch = tempfile.mkdtemp(prefix="autograder-cwd-")      # the child's cwd
        os.chmod(self._scratch, 0o755)
        self.output_path = os.path.join(self._private, "student-output.txt")
        self._pipes = ()
        self.probe_only = probe

    # -- lifecycle -----------------------------------------------------------------------
    def __enter__(self):
        if self.process is None:
            self.start()
        return self

    def __exit__(self, *exc):
        self.close()
        return False

    def start(self):
        """Start the child and wait for its "ready" frame (import errors are raised here)."""
        if self.process is not None:
            raise RuntimeError("this StudentProcess was started already")
        ids = self.environment.ids()
        protect_grader()        # before the child exists: its memory is not the child's to read
        request_r, request_w = os.pipe()
        reply_r, reply_w = os.pipe()
        # The folder the submission was handed in: its package or file and their siblings.
        root = self.impl if self.probe_only else os.path.dirname(self.impl)
        config = dict(
            request_fd=request_r, reply_fd=reply_w, site=self.environment.site,
            submission=self.impl, submission_root=root, trusted=self.trusted,
            limits=dict(cpu_seconds=int(self.limits.seconds) + 10,
                        memory_mb=int(self.limits.memory_mb),
                        output_bytes=int(self.limits.output_bytes),
                        processes=STUDENT_PROCESSES, files=STUDENT_FILES, own_user=bool(ids)),
            probe=self.probe_only)
        argv = [self.environment.python, "-S", "-E", "-s", "-B", "-c", runtimes.BOOT,
                str(self.runtime), json.dumps(config)]
        env = {"PATH": "/usr/bin:/bin", "LANG": "C.UTF-8", "HOME": self._scratch,
               "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
        user = dict(user=ids[0], group=ids[1], extra_groups=[]) if ids else {}
        self.deadline = time.monotonic() + self.limits.seconds
        with open(self.output_path, "wb") as capture:
            try:
                self.process = subprocess.Popen(
                    argv, stdin=subprocess.DEVNULL, stdout=capture, stderr=capture,
                    pass_fds=(request_r, reply_w), cwd=self._scratch, env=env,
                    start_new_session=True, **user)
            except OSError as error:
                for fd in (request_w, reply_r):
                    os.close(fd)
                raise SetupError(f"cannot start the student process ({argv[0]}): {error}") from None
            finally:
                os.close(request_r)
                os.close(reply_w)
        os.set_blocking(request_w, False)       # writes wait on the deadline, never forever
        self._pipes = (request_w, reply_r)
        try:
            header, _ = self._receive({})
            if header["status"] != "ready":
                if header.get("kind") == "setup" and isinstance(header.get("message"), str):
                    raise SetupError(header["message"][:2000])
                raise self._error(header)
        except BaseException:
            self.close()
            raise
        self.sandbox = [str(s) for s in header.get("sandbox", [])]
        if not ids:
            warn_unconfined(self.sandbox)

    def close(self):
        """Stop the child and every process it may have left behind."""
        if self.process is not None:
            if self.process.poll() is None:
                try:
                    wire.write_frame(self._pipes[0], {"kind": "quit"}, deadline=time.monotonic() + 0.5)
                    self.process.wait(0.5)
                except (OSError, wire.WireError, subprocess.TimeoutExpired):
                    pass
            self._kill()
        for fd in self._pipes:
            try:
                os.close(fd)
            except OSError:
                pass
        self._pipes = ()
        shutil.rmtree(self._private, ignore_errors=True)
        shutil.rmtree(self._scratch, ignore_errors=True)

    def _kill(self):
        process = self.process
        try:
            os.killpg(process.pid, signal.SIGKILL)
        except (ProcessLookupError, PermissionError):
            pass
        ids = self.environment.ids()
        if ids:
            kill_user_processes(ids[0])
        try:
            process.wait(5)
        except subprocess.TimeoutExpired:
            pass

    # -- the conversation ----------------------------------------------------------------
    def _receive(self, expect: dict, camera=None):
        """The next reply frame; serves the child's camera requests on the way."""
        while True:
            try:
                header, arrays = wire.read_frame(self._pipes[1], self.deadline,
                                                 expect=None, max_payload=_payload_limit(expect))
            except wire.WireTimeout:
                raise self._timeout() from None
            except wire.WireError as error:
                raise self._broken(error) from None
            status = header.get("status")
            try:
                if status == "camera" and camera is not None:
                    self._answer_camera(arrays, camera)
                    continue
                if status in ("ok", "ready"):
                    wire.check_arrays(arrays, expect)
                    self._check_output()
                    return header, arrays
                if status == "error" and not arrays:
                    self._check_output()        # printing too much explains the error
                    return header, arrays
            except wire.WireTimeout:
                raise self._timeout() from None
            except wire.WireError as error:
                self._kill()
                raise StudentFailure(f"the student process sent a malformed reply ({error})",
                                     "protocol") from None
            self._kill()
            raise StudentFailure(f"the student process sent an unexpected reply (status "
                                 f"{str(status)[:40]!r})", "protocol")

    def _timeout(self) -> StudentFailure:
        self._kill()
        self._check_output()
        return StudentFailure(
            f"time limit: your code did not finish within the {self.limits.seconds:.0f} s this "
            "test allows (an endless loop? paths that never terminate: Russian roulette or "
            "max_depth ignored?)", "timeout")

    def _answer_camera(self, arrays: dict, camera) -> None:
        pixel, u_film = arrays.get("pixel"), arrays.get("u_film")
        scene = camera["scene"]
        n_pixels = scene.camera.width * scene.camera.height
        ok = (set(arrays) == {"pixel", "u_film"} and pixel.dtype.kind == "i" and pixel.ndim == 1
              and u_film.dtype.kind == "f" and u_film.shape == (len(pixel), 2)
              and len(pixel) <= MAX_CAMERA_BATCH and np.isfinite(u_film).all()
              and ((pixel >= 0) & (pixel < n_pixels)).all())
        if not ok:
            raise wire.WireError("bad camera request")
        rays = camera_rays(scene.camera, pixel, u_film)
        wire.write_frame(self._pipes[0], {"kind": "camera"},
                         {"o": rays.o, "d": rays.d, "tmax": rays.tmax}, self.deadline)

    def request(self, header: dict, arrays: dict | None, expect: dict, camera=None) -> dict:
        """Send one request and return the reply's arrays (errors: StudentFailure)."""
        if self.process is None:
            self.start()
        if self.process.poll() is not None:
            raise self._death()
        try:
            wire.write_frame(self._pipes[0], header, arrays, self.deadline)
        except wire.WireTimeout:
            raise self._timeout() from None
        except OSError:
            raise self._death() from None
        reply, data = self._receive(expect, camera)
        if reply["status"] == "error":
            raise self._error(reply)
        return data

    def _error(self, header: dict) -> StudentFailure:
        kind, message = header.get("kind"), header.get("message")
        if kind not in ERROR_KINDS or not isinstance(message, str):
            self._kill()
            return StudentFailure("the student process sent a malformed error reply", "protocol")
        return StudentFailure(message[:20000], kind)

    def _broken(self, error) -> StudentFailure:
        """The pipe ended or carried garbage: a dead child explains itself, else malformed."""
        if self.process.poll() is None:
            try:
                self.process.wait(1)
            except subprocess.TimeoutExpired:
                self._kill()
                return StudentFailure(f"the student process sent a malformed reply ({error})",
                                      "protocol")
        return self._death()

    # -- output and death ----------------------------------------------------------------
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
            self._kill()
            raise StudentFailure(
                f"your code printed more than {self.limits.output_bytes // 1024} KB of output "
                "(print statements in the radiance loop?); remove them. It begins with:\n"
                + self.output(300), "output")

    def _death(self) -> StudentFailure:
        """A failure describing how the child ended."""
        self._kill()
        code = self.process.returncode
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
            name = signal.Signals(-code).name if -code in signal.Signals._value2member_map_ \
                else str(-code)
            why = {"SIGSEGV": "a segmentation fault (a crash inside a C extension?)",
                   "SIGKILL": "it was killed (out of memory?)",
                   "SIGXCPU": "it used up its CPU-time limit",
                   "SIGXFSZ": "it printed more output than allowed",
                   "SIGSYS": "a system call of another architecture, which the grading "
                             "sandbox forbids",
                   "SIGABRT": "it aborted"}.get(name, "a signal")
            return StudentFailure(f"your code crashed the grading process: {name}, {why}" + tail,
                                  "crash")
        return StudentFailure(
            f"your code ended the grading process (exit code {code}, e.g. sys.exit() or "
            f"os._exit()) before returning a result" + tail, "crash")

    # -- what the grader asks ------------------------------------------------------------
    def render(self, scene, integrator, params, spp, seed, processes=None, max_depth=None,
               camera="reference"):
        """``(mean, variance)`` of the student's integrator; validated, else StudentFailure.

        ``integrator`` ``"reference:NAME"`` renders the reference integrator *here* with the
        student's ``camera_rays`` (the camera check).
        """
        name = integrator if isinstance(integrator, str) else integrator.name
        params = {str(k): str(v) for k, v in (params or {}).items()}
        if name.startswith("reference:"):
            mean, variance = self._render_with_student_camera(scene, name.split(":", 1)[1],
                                                              params, spp, seed, max_depth)
        else:
            loaded = _scene(scene, params)
            shape = (loaded.camera.height, loaded.camera.width, 3)
            header = dict(kind="render", scene=scene, params=params, integrator=name,
                          spp=int(spp), seed=int(seed),
                          max_depth=None if max_depth is None else int(max_depth))
            out = self.request(header, None, {"mean": ("f8", shape), "variance": ("f8", shape)},
                               camera={"scene": loaded})
            mean = validate_image(out["mean"], "mean", shape)
            variance = validate_image(out["variance"], "variance", shape)
        return mean, variance

    def _render_with_student_camera(self, scene, name, params, spp, seed, max_depth):
        loaded = _scene(scene, params)

        def student_camera(camera, pixel, u_film):
            o, d = self.rays(scene, params, pixel, u_film)
            length = np.linalg.norm(d, axis=1, keepdims=True)
            if not (length > 0).all():
                raise StudentFailure("camera_rays returned zero-length directions", "output")
            return Rays(o, d / length, camera_rays(camera, pixel, u_film).tmax)

        options = {} if max_depth is None else {"max_depth": int(max_depth)}
        result = render(loaded, make_integrator(name), spp=int(spp), seed=int(seed), processes=1,
                        progress=False, camera=student_camera, **options)
        return result.mean, result.variance

    def probe(self, scene, params, integrator, n=4096, seed=99):
        """(distinct results of the student's integrator, of the reference one) for ``n``
        copies of the centre pixel's ray with independent random streams."""
        params = {str(k): str(v) for k, v in (params or {}).items()}
        loaded = _scene(scene, params)
        camera = loaded.camera
        pixel = np.full(n, (camera.height // 2) * camera.width + camera.width // 2)
        rays = camera_rays(camera, pixel, np.full((n, 2), 0.5))
        out = self.request(dict(kind="radiance", scene=scene, params=params, integrator=integrator,
                                seed=int(seed)), {"o": rays.o, "d": rays.d, "tmax": rays.tmax},
                           {"radiance": ("f8", (n, 3))})
        student = validate_array(out["radiance"], "radiance", (n, 3))
        reference = integrator_for(loaded, integrator)      # with the file's path options
        ref = reference.radiance(loaded, rays, RandomStream(sample_keys(int(seed),
                                                                        np.arange(n))))
        return _distinct(student), _distinct(ref)

    def rays(self, scene, params, pixel, u_film):
        """The student's ``camera_rays`` for given pixels and film samples: ``(o, d)``."""
        params = {str(k): str(v) for k, v in (params or {}).items()}
        pixel = np.asarray(pixel, dtype=np.int64)
        n = len(pixel)
        out = self.request(dict(kind="rays", scene=scene, params=params),
                           {"pixel": pixel, "u_film": np.asarray(u_film, dtype=np.float64)},
                           {"o": ("f8", (n, 3)), "d": ("f8", (n, 3))})
        return (validate_array(out["o"], "ray origins", (n, 3)),
                validate_array(out["d"], "ray directions", (n, 3)))


def probe_sandbox(environment: Environment | None = None) -> list:
    """The layers a student process closes around itself here (SetupError when one that
    must hold cannot): a child that closes its sandbox and loads no submission."""
    runtime = runtimes.cached("student", (environment or Environment()).ids() is not None)
    with StudentProcess(str(runtime), Limits(60), environment=environment, probe=True) as student:
        return student.sandbox


#: Said once, on stderr, where nothing confines the file system of a submission running as
#: the grader's own user.
NOT_A_BOUNDARY = ("autograder: local grading is not a security boundary here: the submission runs "
                  "as the grader's own user and nothing confines its file system ({why})")
_WARNED = []


def warn_unconfined(layers) -> None:
    """Print :data:`NOT_A_BOUNDARY` once when ``layers`` have no file-system confinement."""
    missing = [layer for layer in layers if layer.startswith("no file-system confinement")]
    if missing and not _WARNED:
        _WARNED.append(True)
        print(NOT_A_BOUNDARY.format(why=missing[0].split("(", 1)[-1].rstrip(")")), file=sys.stderr)


def _distinct(values: np.ndarray) -> int:
    return int(len(np.unique(np.round(values, 12), axis=0)))


def _payload_limit(expect: dict) -> int:
    """Bytes a reply may carry: what is expected, or a camera request."""
    expected = sum(8 * int(np.prod([d or 1 for d in shape])) for _, shape in expect.values())
    return max(expected, MAX_CAMERA_BATCH * 24)


def _scene(name, params):
    """The grader's own copy of a built-in scene (cached by content)."""
    return loaded_scene(name, params)


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
    """A finite, non-negative (H, W, 3) image, else StudentFailure."""
    x = validate_array(x, f"the rendered {what} image", shape)
    if x.ndim != 3 or x.shape[2] != 3:
        raise StudentFailure(f"the rendered {what} image has shape {x.shape}, expected (H, W, 3)",
                             "output")
    if (x < 0).any():
        raise StudentFailure(f"the rendered {what} image has negative values", "output")
    return x


