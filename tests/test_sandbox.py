"""The student process's sandbox (autograder/sandbox/) layer by layer, and the hostile zoo in
the two setups tests/test_autograder.py does not run it in.

* The seccomp allowlist: its numbers are the kernel's (checked against the installed kernel
  headers), and its BPF program, run here by a small interpreter for x86-64 and aarch64
  alike, allows the list, refuses everything else and checks the filtered arguments.
* Landlock, capabilities and the grader's non-dumpable state, each in a process of its own,
  with a control that shows what the layer closes.
* The hostile zoo, every attack, as root with a student user (Gradescope's setup) and as one
  non-root user that grades its own submission (the grader and the child share the user:
  only the sandbox stands between them); then every attack at once through the pytest plugin
  as that user, whose ``results.json`` must be valid and final.

As root the tests create a throwaway user (``useradd``) and remove it at the end; without
root the single-user tests run as the current user and the student-user ones are skipped.
Runtime: ~3 min on 2 shared cores, most of it the two zoo runs and the plugin run.
"""
from __future__ import annotations

import errno
import json
import os
import pwd
import re
import shutil
import struct
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

from autograder import results
from autograder.isolation.environment import kill_user_processes, user_processes
from autograder.sandbox import landlock, seccomp, syscalls

ROOT = Path(__file__).resolve().parent.parent
HOSTILE = ROOT / "tests" / "hostile"
ATTACKS = sorted(p for p in HOSTILE.glob("*.py") if not p.name.startswith("_"))
ESCAPES = ("LEAK", "WROTE", "ESCAPED")
MARKERS = (Path("/tmp/autograder-hostile-pickle-ran"), Path("/tmp/autograder-hostile-daemon-ran"))
SYSTEM_PYTHON = Path(f"/usr/bin/python3.{sys.version_info.minor}")
SITE = Path(__import__("numpy").__file__).resolve().parent.parent
TIME_SCALE = os.environ.get("AUTOGRADER_CI_TIME_SCALE", "6")
SANDBOX = ROOT / "autograder" / "sandbox"


# -- the seccomp allowlist ---------------------------------------------------------------

def _kernel_table(header: Path) -> dict:
    text = header.read_text()
    raw = dict(re.findall(r"#define (__NR(?:3264)?_\w+)\s+(\w+)", text))
    table = {}
    for key, value in raw.items():
        for _ in range(4):                       # __NR_fcntl -> __NR3264_fcntl -> 25
            value = raw.get(value, value)
        if value.isdigit():
            table[key.split("_", 3)[-1] if key.startswith("__NR3264_") else key[5:]] = int(value)
    table.setdefault("newfstatat", table.get("fstatat"))
    return table


@pytest.mark.parametrize("machine, header", [
    ("x86_64", "/usr/include/x86_64-linux-gnu/asm/unistd_64.h"),
    ("aarch64", "/usr/include/asm-generic/unistd.h")])
def test_syscall_numbers_are_the_kernels(machine, header):
    """Every number in autograder/sandbox/syscalls.py is the kernel's (linux-libc-dev)."""
    if not Path(header).exists():
        pytest.skip(f"needs the kernel headers ({header})")
    kernel = _kernel_table(Path(header))
    mine = syscalls.numbers(machine)
    assert {name: nr for name, nr in mine.items() if kernel.get(name) != nr} == {}
    named = (*syscalls.ALLOWED, *syscalls.FILTERED, *syscalls.UNIMPLEMENTED)
    assert [name for name in named if name in kernel and name not in mine] == []


def run_filter(program: list, nr: int, arch: int, args=()) -> int:
    """What a classic-BPF seccomp program returns for one call (LD_ABS, JEQ, JGE, JSET, RET)."""
    data = struct.pack("<IIQ6Q", nr & 0xFFFFFFFF, arch, 0,
                       *[a & 0xFFFFFFFFFFFFFFFF for a in (list(args) + [0] * 6)[:6]])
    pc = acc = 0
    for _ in range(len(program) + 1):
        code, jt, jf, k = program[pc]
        if code == seccomp.LD_ABS:
            acc, pc = struct.unpack_from("<I", data, k)[0], pc + 1
        elif code in (seccomp.JEQ, seccomp.JGE, seccomp.JSET):
            hit = {seccomp.JEQ: acc == k, seccomp.JGE: acc >= k, seccomp.JSET: bool(acc & k)}[code]
            pc += 1 + (jt if hit else jf)
        else:
            assert code == seccomp.RET
            return k
    raise AssertionError("the program does not end")


ALLOW, KILL = seccomp.ALLOW, seccomp.KILL_PROCESS
EPERM, EACCES, ENOSYS = (0x50000 | e for e in (errno.EPERM, errno.EACCES, errno.ENOSYS))
PID = 4242


@pytest.mark.parametrize("machine", ["x86_64", "aarch64"])
def test_filter_allows_the_list_and_refuses_everything_else(machine):
    """Default deny: of every number below 1024 only the allowlist passes; clone3 and openat2
    answer ENOSYS (glibc falls back); another architecture's call kills the process."""
    arch, table = syscalls.ARCHITECTURES[machine]
    program = seccomp.program(PID, machine)
    assert len(program) < 4096 and all(jt < 256 and jf < 256 for _, jt, jf, _ in program)
    plain = {table[name] for name in syscalls.ALLOWED if name in table}
    unimplemented = {table[name] for name in syscalls.UNIMPLEMENTED}
    for nr in range(1024):
        expected = ALLOW if nr in plain else ENOSYS if nr in unimplemented else None
        verdict = run_filter(program, nr, arch)
        if expected is not None:
            assert verdict == expected, nr
        elif nr not in syscalls.allowed_numbers(machine):
            assert verdict == EPERM, nr
    other = 0x40000003 if machine == "x86_64" else 0xC000003E     # i386, or x86-64 on arm
    assert run_filter(program, table["getpid"], other) == KILL
    if machine == "x86_64":
        assert run_filter(program, 0x40000000 | table["getpid"], arch) == ENOSYS     # x32
    assert len(syscalls.allowed_numbers("x86_64")) == 90 and len(syscalls.allowed_numbers("aarch64")) == 78


@pytest.mark.parametrize("machine", ["x86_64", "aarch64"])
def test_filter_checks_the_arguments(machine):
    """Threads but no processes, signals and prlimit64 only to itself, opening read-only,
    only the listed ioctl and fcntl commands."""
    arch, table = syscalls.ARCHITECTURES[machine]
    program = seccomp.program(PID, machine)
    thread_flags = 0x3D0F00                       # what glibc's pthread_create passes
    cases = [("clone", (thread_flags,), ALLOW), ("clone", (0x11,), EPERM),          # fork
             ("clone", (thread_flags | 0x10000000,), EPERM),                      # + NEWUSER
             ("kill", (PID, 9), ALLOW), ("kill", (0, 9), ALLOW), ("kill", (PID + 1, 9), EPERM),
             ("kill", (-1, 9), EPERM), ("tgkill", (PID, PID + 3, 6), ALLOW),
             ("tgkill", (1, 1, 9), EPERM), ("prlimit64", (0, 0, 0, 1), ALLOW),
             ("prlimit64", (PID, 0), ALLOW), ("prlimit64", (PID - 1, 0), EPERM),
             ("openat", (-100, 0, os.O_RDONLY | os.O_CLOEXEC), ALLOW),
             ("openat", (-100, 0, os.O_WRONLY), EACCES), ("openat", (-100, 0, os.O_RDWR), EACCES),
             ("openat", (-100, 0, os.O_RDONLY | os.O_CREAT), EACCES),
             ("openat", (-100, 0, os.O_RDONLY | os.O_TRUNC), EACCES),
             ("openat", (-100, 0, os.O_APPEND), EACCES),
             ("ioctl", (1, 0x5401), ALLOW), ("ioctl", (1, 0x40086602), EPERM),   # FS_IOC_SETFLAGS
             ("ioctl", (0, 0x5412), EPERM),                                      # TIOCSTI
             ("fcntl", (3, 1030), ALLOW), ("fcntl", (3, 4), ALLOW),
             ("fcntl", (3, 1031), EPERM), ("fcntl", (3, 6), EPERM)]             # F_SETPIPE_SZ, F_SETLK
    if machine == "x86_64":
        cases += [("open", (0, os.O_RDONLY), ALLOW), ("open", (0, os.O_WRONLY | os.O_CREAT), EACCES)]
    for name, args, expected in cases:
        assert run_filter(program, table[name], arch, args) == expected, (name, args)


# -- Landlock, capabilities, the grader's memory -----------------------------------------

def _python(code: str, *args, user=None, timeout=60) -> dict:
    """Run ``code`` in a fresh interpreter (as ``user``, a pwd entry, when given); its JSON."""
    python = str(SYSTEM_PYTHON) if user is not None else sys.executable
    ids = dict(user=user.pw_uid, group=user.pw_gid, extra_groups=[]) if user is not None else {}
    done = subprocess.run([python, "-S", "-c", code, *map(str, args)], capture_output=True,
                          text=True, timeout=timeout, cwd="/", env={"PATH": "/usr/bin:/bin"}, **ids)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


LOAD = ("import importlib.util, sys\n"
        "def load(name, folder):\n"
        "    spec = importlib.util.spec_from_file_location(name, f'{folder}/{name}.py')\n"
        "    module = importlib.util.module_from_spec(spec)\n"
        "    spec.loader.exec_module(module)\n"
        "    return module\n")

LANDLOCKED = LOAD + r'''
import ctypes, json, os
ctypes.CDLL(None).prctl(38, 1, 0, 0, 0)                     # PR_SET_NO_NEW_PRIVS
landlock = load("landlock", sys.argv[1])
allowed, secret, scratch = sys.argv[2], sys.argv[3], sys.argv[4]
problem = landlock.restrict([allowed], [])

def can(action):
    try:
        action()
        return True
    except OSError:
        return False

print(json.dumps(dict(
    problem=problem,
    read_allowed=can(lambda: open(os.path.join(allowed, "syscalls.py")).read(1)),
    list_allowed=can(lambda: os.listdir(allowed)),
    read_secret=can(lambda: open(secret, "rb").read(1)),
    list_root=can(lambda: os.listdir("/")),
    write_scratch=can(lambda: open(os.path.join(scratch, "x"), "w")),
    unlink_scratch=can(lambda: os.unlink(os.path.join(scratch, "existing"))),
    write_allowed=can(lambda: open(os.path.join(allowed, "planted.py"), "w")),
    mkdir=can(lambda: os.mkdir(os.path.join(scratch, "d"))))))
'''


def test_landlock_reads_beneath_its_rules_and_writes_nowhere(tmp_path):
    """After landlock.restrict([folder]): that folder is readable, nothing else is (the
    committed references included), and nothing can be written, created or removed, not even
    in a folder the process owns."""
    version = landlock.abi()
    if version < 1:
        pytest.skip("this kernel has no Landlock")
    secret = next((ROOT / "mitsuba_refs" / "references").glob("*.exr"))
    allowed, scratch = tmp_path / "allowed", tmp_path / "scratch"
    allowed.mkdir()
    scratch.mkdir()
    (allowed / "syscalls.py").write_text("x")
    (scratch / "existing").write_text("x")
    found = _python(LANDLOCKED, SANDBOX, allowed, secret, scratch)
    assert found == dict(problem="", read_allowed=True, list_allowed=True, read_secret=False,
                         list_root=False, write_scratch=False, unlink_scratch=False,
                         write_allowed=False, mkdir=False), found
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["allowed", "existing", "scratch",
                                                            "syscalls.py"]


DROPPED = LOAD + r'''
import ctypes, json, os
privileges = load("privileges", sys.argv[1])
problem, report = privileges.drop()
status = privileges.status()
libc = ctypes.CDLL(None, use_errno=True)
header, data = privileges.CapHeader(privileges.LINUX_CAPABILITY_VERSION_3, 0), (privileges.CapData * 2)()
data[0].effective = data[0].permitted = 1 << 21                     # CAP_SYS_ADMIN back
regained = libc.capset(ctypes.byref(header), data) == 0
print(json.dumps(dict(problem=problem, report=report, status=status, regained=regained,
                      ruid=os.getuid(), shadow=os.access("/etc/shadow", os.W_OK))))
'''


def test_capabilities_are_dropped_for_good():
    """As root: every capability set empty (the bounding set too), no new privileges, the real
    uid moved away from 0, and no capability can be taken back (file access as uid 0 is left
    to Landlock; setuid calls to the seccomp filter)."""
    if os.geteuid() != 0:
        pytest.skip("needs root: the process that drops capabilities must have some")
    found = _python(DROPPED, SANDBOX)
    status = found["status"]
    assert found["problem"] == "", found
    assert all(status[key] == 0 for key in ("CapInh", "CapPrm", "CapEff", "CapAmb", "CapBnd")), status
    assert status["NoNewPrivs"] == 1 and not found["regained"], found
    assert found["ruid"] >= 0x70000000 and "no capabilities, empty bounding set" in found["report"]


GRADER = r'''
import ctypes, json, subprocess, sys
ctypes.CDLL(None).prctl(4, int(sys.argv[1]), 0, 0, 0)        # PR_SET_DUMPABLE
done = subprocess.run([sys.executable, "-S", "-c", sys.argv[2], *sys.argv[3:]],
                      capture_output=True, text=True)
sys.stderr.write(done.stderr)
print(done.stdout.strip().splitlines()[-1])
'''

READER = LOAD + r'''
import ctypes, errno, json, os
if sys.argv[1] != "-":
    problem, _ = load("privileges", sys.argv[1]).drop()
    assert not problem, problem
libc = ctypes.CDLL(None, use_errno=True)
parent = os.getppid()
fd = libc.open(f"/proc/{parent}/mem".encode(), os.O_RDONLY)
maps = libc.open(f"/proc/{parent}/environ".encode(), os.O_RDONLY)

class IoVec(ctypes.Structure):
    _fields_ = [("base", ctypes.c_void_p), ("length", ctypes.c_size_t)]

buffer = ctypes.create_string_buffer(8)
local, remote = IoVec(ctypes.addressof(buffer), 8), IoVec(0x10000, 8)
libc.process_vm_readv(parent, ctypes.byref(local), 1, ctypes.byref(remote), 1, 0)
vm = ctypes.get_errno() != errno.EPERM                    # EFAULT: the access check passed
seized = libc.ptrace(0x4206, parent, None, None) == 0     # PTRACE_SEIZE
if seized:
    libc.ptrace(17, parent, None, None)
print(json.dumps(dict(mem=fd >= 0, environ=maps >= 0, process_vm_readv=vm, ptrace=seized)))
'''


@pytest.fixture(scope="module")
def throwaway_user():
    """A new unprivileged user (removed afterwards), or None when the tests cannot make one."""
    if os.geteuid() != 0 or not shutil.which("useradd"):
        yield None
        return
    if not SYSTEM_PYTHON.exists():
        pytest.skip(f"needs {SYSTEM_PYTHON}, a Python {sys.version_info.major}."
                    f"{sys.version_info.minor} another user can run")
    name = f"aghostile{os.getpid()}"
    subprocess.run(["useradd", "--system", "--no-create-home", "--shell", "/usr/sbin/nologin", name],
                   check=True, capture_output=True)
    entry = pwd.getpwnam(name)
    try:
        yield entry
    finally:
        kill_user_processes(entry.pw_uid)
        subprocess.run(["userdel", name], capture_output=True)


def test_grader_memory_is_closed_to_the_child_as_root_without_capabilities():
    """A root child that dropped its capabilities (the sandbox's privileges.drop) cannot open
    its non-dumpable parent's /proc/<pid>/mem or environ, read it with process_vm_readv or
    seize it with ptrace (the parent is not dumpable, and it has capabilities the child lacks);
    with its capabilities the child could do all of it (the control: the issue's setup)."""
    if os.geteuid() != 0:
        pytest.skip("needs root")
    for dumpable in (0, 1):
        closed = _python(GRADER, dumpable, READER, SANDBOX)
        assert closed == dict(mem=False, environ=False, process_vm_readv=False, ptrace=False), closed
    assert _python(GRADER, 0, READER, "-") == dict(mem=True, environ=True, process_vm_readv=True,
                                                    ptrace=True)


def test_grader_memory_is_closed_to_the_child_of_the_same_user(throwaway_user):
    """One non-root user runs grader and child (no Yama restriction here): the non-dumpable
    grader's memory is closed to every way of reading it; a dumpable one's is open to all."""
    user = throwaway_user
    if user is None and os.geteuid() == 0:
        pytest.skip("needs useradd to run as a non-root user")
    closed = _python(GRADER, 0, READER, "-", user=user)
    assert closed == dict(mem=False, environ=False, process_vm_readv=False, ptrace=False), closed
    opened = _python(GRADER, 1, READER, "-", user=user)
    assert opened["mem"] and opened["environ"] and opened["process_vm_readv"], opened


def test_student_process_reports_its_layers():
    """A student process closes every layer this machine offers before it loads anything."""
    from autograder.isolation.process import probe_sandbox
    layers = probe_sandbox()
    assert "seccomp" in layers and "no-new-privileges" in layers, layers
    assert any(layer.startswith("no capabilities") for layer in layers), layers
    version = landlock.abi()
    assert (f"landlock ABI {version}" in layers) if version else any(
        layer.startswith("no file-system confinement") for layer in layers), layers


# -- the hostile zoo as root with a student user, and as one non-root user ------------------

ZOO_RUNNER = r'''
import json, os, sys
from pathlib import Path
from autograder import grading
from autograder.isolation import runtime
from autograder.isolation.process import Limits
check = grading.Check("quick", "path", "quad-light", (("mean", 1),), 10)
found = {}
for entry in sys.argv[2:]:
    path, seconds = entry.rsplit("=", 1)
    result = grading.run_check(check, path, limits=Limits(float(seconds), grading.MEMORY_MB, 64 * 1024))
    found[Path(path).stem] = dict(score=result.score, passed=result.passed, kind=result.failure_kind,
                                  failure=result.failure, report=result.report())
folders = [str(p).encode() for p in runtime._BUILT.values()]
left = []
for pid in filter(str.isdigit, os.listdir("/proc")):
    try:
        if any(f in Path(f"/proc/{pid}/cmdline").read_bytes() for f in folders):
            left.append(int(pid))
    except OSError:
        pass
Path(sys.argv[1]).write_text(json.dumps(dict(results=found, left=left)))
'''


def _constants(path: Path) -> dict:
    from tests.test_autograder import constants
    return constants(path).EXPECT


def _grader_env(home: Path, **extra) -> dict:
    env = {"PATH": "/usr/bin:/bin", "HOME": str(home), "LANG": "C.UTF-8", "PYTHONDONTWRITEBYTECODE": "1",
           "AUTOGRADER_TIME_SCALE": TIME_SCALE, "OPENBLAS_NUM_THREADS": "1"}
    return {**env, **extra}


def run_zoo(tmp_path: Path, env: dict, user=None) -> dict:
    """Grade every attack of tests/hostile (one quick check each) in a grader process with
    ``env``, as ``user`` (a pwd entry) when given; what each scored, and what was left."""
    for marker in MARKERS:
        marker.unlink(missing_ok=True)
    out = tmp_path / "zoo.json"
    scale = float(TIME_SCALE)
    jobs = [f"{p}={5 if _constants(p)['kind'] == 'timeout' else 10 * scale}" for p in ATTACKS]
    python = str(SYSTEM_PYTHON) if user is not None else sys.executable
    ids = dict(user=user.pw_uid, group=user.pw_gid, extra_groups=[]) if user is not None else {}
    done = subprocess.run([python, "-c", ZOO_RUNNER, str(out), *jobs], capture_output=True,
                          text=True, cwd=tmp_path, env=env, timeout=900, **ids)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-3000:]
    time.sleep(3.5)                                  # the escaped daemon would write after 3 s
    found = json.loads(out.read_text())
    found["markers"] = [str(m) for m in MARKERS if m.exists()]
    return found


def check_zoo(found: dict) -> None:
    """Every attack: zero points, the expected failure, no escape, nothing left behind."""
    assert sorted(found["results"]) == sorted(p.stem for p in ATTACKS)
    for path in ATTACKS:
        result, expect = found["results"][path.stem], _constants(path)
        assert result["score"] == 0 and not result["passed"], (path.stem, result["report"])
        if expect["kind"] == "black":       # the attack ran to its end and returned black
            assert not result["failure"], (path.stem, result["report"])
        elif expect["kind"]:
            assert result["kind"] == expect["kind"], (path.stem, result["report"])
            assert expect["words"] in result["failure"], (path.stem, result["report"])
        assert not any(word in result["report"] for word in ESCAPES), (path.stem, result["report"])
    assert not found["left"] and not found["markers"], found
    assert Path(ATTACKS[0]).exists() and not (HOSTILE / "pathtracer").exists()


@pytest.fixture(scope="module")
def one_user(throwaway_user):
    """(user or None for the current one, a home folder it owns) for the single-user setup."""
    if os.geteuid() == 0 and throwaway_user is None:
        pytest.skip("as root the single-user setup needs useradd (a throwaway non-root user)")
    home = Path(tempfile.mkdtemp(prefix="autograder-one-user-", dir="/tmp"))
    if throwaway_user is not None:
        os.chown(home, throwaway_user.pw_uid, throwaway_user.pw_gid)
    try:
        yield throwaway_user, home
    finally:
        shutil.rmtree(home, ignore_errors=True)


def test_hostile_zoo_as_root_with_a_student_user(throwaway_user, tmp_path):
    """Gradescope's setup: the grader is root, each child runs as the student user."""
    if throwaway_user is None:
        pytest.skip("needs root and useradd: the child runs as a user of its own")
    env = _grader_env(tmp_path, PYTHONPATH=str(ROOT), AUTOGRADER_STUDENT_USER=throwaway_user.pw_name,
                      AUTOGRADER_STUDENT_PYTHON=str(SYSTEM_PYTHON), AUTOGRADER_STUDENT_SITE=str(SITE))
    found = run_zoo(tmp_path, env)
    check_zoo(found)
    assert not user_processes(throwaway_user.pw_uid)


def test_hostile_zoo_as_one_non_root_user(one_user):
    """An instructor grading as themself: grader and child are the same non-root user, who may
    read the whole project (references included); only the sandbox is in the way."""
    user, home = one_user
    python_path = os.pathsep.join([str(ROOT), str(SITE)])
    found = run_zoo(home, _grader_env(home, PYTHONPATH=python_path), user=user)
    check_zoo(found)


LAUNCHER = ("import importlib.metadata as m, sys, pytest\n"
            "named = any(e.name == 'autograder' for e in m.entry_points(group='pytest11'))\n"
            "sys.exit(pytest.main(([] if named else ['-p', 'autograder.plugin']) + sys.argv[1:]))\n")


def test_every_attack_at_once_through_the_plugin_as_one_user(one_user):
    """The whole zoo in one submission (tests/hostile/_everything.py), graded by the pytest
    plugin as one non-root user: zero points, every test graded (none "not run": the grader
    lived), results.json valid and unchanged after the grader ended."""
    user, home = one_user
    submission = home / "submission"
    submission.mkdir(exist_ok=True)
    for file in HOSTILE.glob("*.py"):
        shutil.copy(file, submission / file.name)
    (submission / "student").mkdir(exist_ok=True)
    shutil.copy(HOSTILE / "_everything.py", submission / "student" / "__init__.py")
    out = home / "results" / "results.json"
    if user is not None:
        subprocess.run(["chown", "-R", f"{user.pw_uid}:{user.pw_gid}", str(home)], check=True)
    env = _grader_env(home, PYTHONPATH=os.pathsep.join([str(ROOT), str(SITE)]))
    python = str(SYSTEM_PYTHON) if user is not None else sys.executable
    ids = dict(user=user.pw_uid, group=user.pw_gid, extra_groups=[]) if user is not None else {}
    for marker in MARKERS:
        marker.unlink(missing_ok=True)
    done = subprocess.run([python, "-c", LAUNCHER, str(ROOT / "autograder" / "tests_for_students"),
                           "--impl", str(submission / "student"), "--gradescope", str(out), "-q",
                           "-p", "no:cacheprovider", "--rootdir", str(ROOT / "autograder"),
                           "-k", "cornell-box or camera"], capture_output=True, text=True, cwd=home,
                          env=env, timeout=900, **ids)
    assert out.exists(), done.stdout[-3000:] + done.stderr[-3000:]
    final = out.read_text()
    document = json.loads(final)
    results.validate(document)
    assert document["score"] == 0 and len(document["tests"]) == 5, document
    output = " ".join(t["output"] for t in document["tests"])
    assert not any(t["output"].startswith("not run") for t in document["tests"]), document
    assert not any(word in output for word in ESCAPES), output
    assert "Traceback" not in done.stderr and "INTERNALERROR" not in done.stdout, done.stdout[-3000:]
    time.sleep(4)
    assert out.read_text() == final and not any(m.exists() for m in MARKERS)


def test_a_results_file_that_cannot_be_written_is_one_line(tmp_path):
    """results.json in the way (here a folder): every write fails; the plugin says so in one
    line on stderr and exits 3, with no traceback."""
    out = tmp_path / "results.json"
    out.mkdir()
    done = subprocess.run([sys.executable, "-c", LAUNCHER, str(ROOT / "autograder" / "tests_for_students"),
                           "--gradescope", str(out), "-q", "-p", "no:cacheprovider", "--rootdir",
                           str(ROOT / "autograder"), "-k", "camera"], capture_output=True, text=True,
                          cwd=tmp_path, timeout=600,
                          env=dict(os.environ, AUTOGRADER_TIME_SCALE=TIME_SCALE,
                                   PYTHONPATH=str(ROOT)))
    lines = [line for line in done.stderr.splitlines() if "cannot write the results file" in line]
    assert done.returncode == 3, done.stdout[-2000:] + done.stderr[-2000:]
    assert lines and all(line == lines[0] for line in lines) and str(out) in lines[0], done.stderr
    assert "Traceback" not in done.stderr + done.stdout and "INTERNALERROR" not in done.stdout


def _patched_student(tmp_path, module: str, old: str, new: str):
    """A StudentProcess (probe) whose runtime has ``old`` replaced by ``new`` in ``module``."""
    from autograder.isolation import runtime as runtimes
    from autograder.isolation.process import Limits, StudentProcess
    folder = runtimes.build(tmp_path / "runtime", "student")
    path = folder / "grading_child" / module
    assert old in path.read_text()
    path.write_text(path.read_text().replace(old, new))
    student = StudentProcess(str(folder), Limits(60), probe=True)
    student.runtime = folder
    return student


def test_a_sandbox_that_cannot_close_is_refused_in_one_line(tmp_path):
    """A child that cannot install its filter (an unsupported machine, here pretended) sends a
    setup error before it imports anything: the grader raises SetupError, one line."""
    from autograder.isolation.environment import SetupError
    student = _patched_student(tmp_path, "seccomp.py", '    reason = supported()\n',
                               '    reason = "the grading sandbox\'s seccomp filter exists for '
                               'Linux on x86-64 and aarch64 only, not Linux ppc64le"\n')
    with pytest.raises(SetupError) as error:
        student.start()
    message = str(error.value)
    assert "\n" not in message and "ppc64le; refusing to run a submission" in message, message
    assert student.process.poll() is not None


def test_no_file_system_confinement_is_said_in_one_line(tmp_path, capsys):
    """Without Landlock (here pretended) a child of the grader's own user still closes every
    other layer, and the grader says once, on stderr, that this is not a security boundary."""
    from autograder.isolation import process
    student = _patched_student(tmp_path, "landlock.py", "    version = abi() if version is None else version\n",
                               "    version = 0\n")
    process._WARNED.clear()
    with student:
        layers = student.sandbox
    assert "seccomp" in layers and any(layer.startswith("no file-system confinement") for layer in layers)
    lines = [line for line in capsys.readouterr().err.splitlines() if "not a security boundary" in line]
    assert lines == [process.NOT_A_BOUNDARY.format(why="Landlock is not available in this kernel")]
