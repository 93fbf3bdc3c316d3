"""The grader <-> student-process message format: plain data, never pickle.

A *frame* is::

    4 bytes   big-endian length L of the header (at most MAX_HEADER)
    L bytes   UTF-8 JSON object: the header
    payload   the raw bytes of the arrays the header lists, in order

The header's ``"arrays"`` entry lists ``[name, dtype, shape]`` triples; ``dtype`` is one of
:data:`DTYPES` (little-endian float64 or int64), so the payload's size follows from the
header alone. JSON can only build dicts, lists, strings, numbers, booleans and None, and
the payload only becomes a NumPy array of a declared plain dtype: reading a frame never
runs code or builds objects chosen by the sender. The grader, which reads frames written
by student code, additionally checks every reply against the exact names, dtypes and
shapes it expects (:func:`read_frame`'s ``expect``).

This module is shared by both sides and copied into the student runtime, so it imports
only the standard library and NumPy.
"""
from __future__ import annotations

import json
import os
import select
import struct
import time

import numpy as np

#: Largest header accepted (an error message and a few numbers fit easily).
MAX_HEADER = 64 * 1024
#: The only array types on the wire.
DTYPES = {"f8": np.dtype("<f8"), "i8": np.dtype("<i8")}
_LENGTH = struct.Struct(">I")


class WireError(Exception):
    """A frame that cannot be read: malformed, too large, cut off, or not what was expected."""


class WireTimeout(WireError):
    """The deadline passed before a whole frame arrived."""


# ----------------------------------------------------------------------------------------
# Writing


def write_frame(fd: int, header: dict, arrays: dict | None = None,
                deadline: float | None = None) -> None:
    """Write one frame: ``header`` (JSON-able dict) plus ``arrays`` (name -> array).

    With a ``deadline`` (``time.monotonic()`` value) ``fd`` must be non-blocking, and
    :class:`WireTimeout` is raised if the reader has not taken the frame by then: a reader
    that stops reading cannot block the writer.
    """
    arrays = arrays or {}
    listed, payload = [], []
    for name, value in arrays.items():
        kind = "i8" if np.asarray(value).dtype.kind in "iub" else "f8"
        data = np.ascontiguousarray(value, dtype=DTYPES[kind])
        listed.append([name, kind, list(data.shape)])
        payload.append(data.tobytes())
    text = json.dumps({**header, "arrays": listed}, allow_nan=False).encode()
    if len(text) > MAX_HEADER:
        raise WireError(f"header of {len(text)} bytes exceeds {MAX_HEADER}")
    _write_all(fd, _LENGTH.pack(len(text)) + text, deadline)
    for chunk in payload:
        _write_all(fd, chunk, deadline)


def _wait(poller, deadline: float | None, what: str) -> None:
    """Return when ``poller`` reports its fd ready; WireTimeout once ``deadline`` passes."""
    if deadline is None:
        return
    remaining = deadline - time.monotonic()
    if remaining <= 0 or not poller.poll(remaining * 1000):
        raise WireTimeout(what)


def _write_all(fd: int, data: bytes, deadline: float | None) -> None:
    view = memoryview(data)
    poller = select.poll()
    poller.register(fd, select.POLLOUT)
    while view:
        _wait(poller, deadline, "the reader did not take the frame before the deadline")
        try:
            written = os.write(fd, view)
        except BlockingIOError:
            continue
        view = view[written:]


# ----------------------------------------------------------------------------------------
# Reading


def read_frame(fd: int, deadline: float | None = None, expect: dict | None = None,
               max_payload: int = 1 << 31) -> tuple[dict, dict]:
    """Read one frame from ``fd``; returns ``(header, arrays)``.

    Parameters
    ----------
    fd : int
        A pipe's read end.
    deadline : float, optional
        ``time.monotonic()`` value after which :class:`WireTimeout` is raised.
    expect : dict, optional
        ``name -> (dtype, shape)`` the arrays must be exactly (names, order-free; shape
        entries of None match any length). Without it any arrays are accepted.
    max_payload : int
        Most payload bytes accepted.

    Raises
    ------
    WireTimeout
        The deadline passed.
    WireError
        End of file, a malformed header, arrays other than ``expect``, a payload too large.
    """
    (length,) = _LENGTH.unpack(_read_exact(fd, _LENGTH.size, deadline))
    if length > MAX_HEADER:
        raise WireError(f"header of {length} bytes (at most {MAX_HEADER})")
    try:
        header = json.loads(_read_exact(fd, length, deadline).decode("utf-8"),
                            parse_constant=_refuse_constant)
    except (ValueError, RecursionError) as error:
        raise WireError(f"header is not JSON ({error})") from None
    if not isinstance(header, dict):
        raise WireError("header is not a JSON object")
    listed = _array_list(header.pop("arrays", []))
    if expect is not None:
        _check_expected(listed, expect)
    sizes = [DTYPES[kind].itemsize * int(np.prod(shape, dtype=np.int64)) for _, kind, shape in listed]
    if sum(sizes) > max_payload:
        raise WireError(f"payload of {sum(sizes)} bytes (at most {max_payload})")
    arrays = {}
    for (name, kind, shape), size in zip(listed, sizes):
        data = _read_exact(fd, size, deadline)
        arrays[name] = np.frombuffer(data, dtype=DTYPES[kind]).reshape(shape).copy()
    return header, arrays


def _refuse_constant(name):
    raise ValueError(f"{name} is not allowed")


def _array_list(listed) -> list:
    """Validate the header's ``arrays`` entry: [[name, dtype, [dims]], ...]."""
    if not isinstance(listed, list) or len(listed) > 16:
        raise WireError("'arrays' must be a list of at most 16 entries")
    out, names = [], set()
    for entry in listed:
        ok = (isinstance(entry, list) and len(entry) == 3 and isinstance(entry[0], str)
              and entry[1] in DTYPES and isinstance(entry[2], list) and len(entry[2]) <= 4
              and all(type(d) is int and 0 <= d < 1 << 31 for d in entry[2]))
        if not ok or entry[0] in names:
            raise WireError(f"malformed array entry {str(entry)[:80]}")
        names.add(entry[0])
        out.append((entry[0], entry[1], tuple(entry[2])))
    return out


def check_arrays(arrays: dict, expect: dict) -> None:
    """Raise WireError unless ``arrays`` (name -> array read by :func:`read_frame`) are
    exactly ``expect`` (name -> (dtype, shape), None in a shape matches any length)."""
    _check_expected([(name, "i8" if value.dtype.kind == "i" else "f8", value.shape)
                     for name, value in arrays.items()], expect)


def _check_expected(listed, expect: dict) -> None:
    got = {name: (kind, shape) for name, kind, shape in listed}
    if set(got) != set(expect):
        raise WireError(f"arrays {sorted(got)}, expected {sorted(expect)}")
    for name, (kind, shape) in expect.items():
        got_kind, got_shape = got[name]
        same_shape = len(got_shape) == len(shape) and all(
            want is None or want == have for want, have in zip(shape, got_shape))
        if got_kind != kind or not same_shape:
            raise WireError(f"array {name!r}: {got_kind} {list(got_shape)}, expected {kind} "
                            f"{[d if d is not None else 'n' for d in shape]}")


def _read_exact(fd: int, size: int, deadline: float | None) -> bytes:
    chunks, missing = [], size
    poller = select.poll()
    poller.register(fd, select.POLLIN)
    while missing:
        _wait(poller, deadline, "no reply before the deadline")
        chunk = os.read(fd, min(missing, 1 << 20))
        if not chunk:
            raise WireError("end of file")
        chunks.append(chunk)
        missing -= len(chunk)
    return b"".join(chunks)
