"""The reference cache: look up, validate, render on demand, store.

Layout (one pair per reference, in :func:`cache_dir`)::

    <scene>__<integrator>[__<k>-<v>_...]__<spp>spp-s<seed>.exr   mean + variance
    <same stem>.json                                              metadata sidecar

The lookup needs only the standard library, NumPy, OpenEXR and the
tracer's XML reader (no Mitsuba): the *key* is computed from

- the content (SHA-256) of the scene file and of every file it includes
  (``<string name="filename">`` such as meshes, ``<include>``),
- the parameters (``-D`` values, as strings),
- the Mitsuba integrator dictionary our integrator maps to, with the
  ``max_depth``/``rr_depth``/``hide_emitters`` the tracer's loader reads
  from the file (literal or ``$param``) or the overrides set,
- an overridden film size (only when given),
- the requested spp and seed, and a format version.

The Mitsuba version and variant are recorded (``full_hash`` also covers
them) but are not part of the key, so a committed reference loads without
Mitsuba. ``mitsuba-refs build`` rebuilds references made by another
Mitsuba version.

A cached reference is used only if it is *valid*: sidecar readable, key
equal to the recomputed key (else *stale*), EXR readable with all six
channels, shape equal to the recorded film size, all values finite,
variances >= 0, and the pixel checksum equal to the recorded one (else
*corrupt*). Invalid references are rebuilt when Mitsuba is available and
never returned.

Writes are atomic and locked (:func:`store`, :func:`cache_lock`): concurrent
builders and readers of one reference see a whole pair of files or none.
Before a render the folder is checked to be writable (:func:`check_writable`),
and a render with non-finite values is refused (:func:`check_finite`).
"""

import contextlib
import hashlib
import json
import os
import re
import sys
import tempfile
import threading
from pathlib import Path
from typing import NamedTuple

import numpy as np

from pathtracer.core import interrupts
from pathtracer.io.exr import read_mean_variance
from pathtracer.scene.errors import SceneError
from pathtracer.scene.load import BUILTIN_DIR
from pathtracer.scene.xml_files import XMLSyntaxError, read_elements, scene_files

from ..errors import CacheNotWritable, ReferenceUnavailable, RefsInputError, is_mitsuba_error, mitsuba_error_line
from . import config, split
from .cache_location import cache_dir, lookup_dirs
from .exr import pixel_checksum, write_reference_exr
from .render import (
    INTEGRATOR_MAP,
    MEAN_ONLY,
    Reference,
    integrator_dict,
    reference_settings,
    render_reference,
    resolve_scene,
)

try:
    import fcntl
except ImportError:   # Windows: no locks (validate's checksums catch a torn pair)
    fcntl = None

FORMAT_VERSION = 1


def _sha256_file(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def parse_xml(path):
    """The root element of the XML file ``path``, read by the tracer's reader
    (:func:`pathtracer.scene.xml_files.read_elements`).

    Raises
    ------
    RefsInputError
        The file is not well-formed XML (the message names file, line and column).
    """
    try:
        return read_elements(path, str(path))
    except XMLSyntaxError as error:
        raise RefsInputError(f"{path}:{error.line}:{error.column}: not well-formed XML: "
                             f"{error.syntax}") from None


def included_files(scene_path):
    """The files the scene file ``scene_path`` reads (meshes, textures, ``<include>``s),
    found as the tracer's loader finds them (:func:`pathtracer.scene.xml_files.scene_files`),
    as :class:`~pathlib.Path`; a file found nowhere is listed where it was first looked for
    (:func:`scene_hash` reports it missing).

    Raises
    ------
    RefsInputError
        An included file is not well-formed XML, or the includes form a cycle.
    """
    try:
        return [Path(p) for p in scene_files(str(scene_path))]
    except SceneError as error:
        raise RefsInputError(str(error)) from None


def scene_hash(scene):
    """SHA-256 over the scene file and its included files' contents."""
    path = resolve_scene(scene)
    h = hashlib.sha256()
    h.update(b"scene\0" + bytes.fromhex(_sha256_file(path)))
    for inc in included_files(path):
        if not inc.exists():
            raise RefsInputError(f"{path}: refers to a missing file {inc}")
        h.update(inc.name.encode() + b"\0" + bytes.fromhex(_sha256_file(inc)))
    return h.hexdigest()


def canonical_integrator(integrator):
    """Our integrator name under which the reference is stored
    (``recursive`` and ``smallpt`` share ``path``'s references, ``volpath_phase``
    those of ``volpath``)."""
    if integrator in MEAN_ONLY:
        return INTEGRATOR_MAP.get(integrator, "path")
    return integrator


def _identity(scene, params, integrator, spp, seed, options=None, resolution=None):
    """What the reference renders. The Mitsuba integrator dictionary carries the
    effective ``max_depth``/``rr_depth``/``hide_emitters`` read by the tracer's
    loader (literal, ``$param`` or ``options``), so a literal value in the file
    changes the key; an overridden film size adds ``resolution``."""
    path = resolve_scene(scene)
    params = {str(k): str(v) for k, v in (params or {}).items()}
    content = scene_hash(path)
    _, transport, settings = reference_settings(path, params, options, resolution)
    ident = {
        "format": FORMAT_VERSION,
        "scene_hash": content,
        "params": dict(sorted(params.items())),
        "integrator": canonical_integrator(integrator),
        "mitsuba_integrator": integrator_dict(integrator, transport, settings.integrator),
        "spp": int(spp),
        "seed": int(seed),
    }
    if resolution is not None:
        ident["resolution"] = list(settings.resolution)
    if settings.sampler != "independent":
        # Rendered with an independent sampler instead (render.independent_samplers).
        ident["sampler"] = f"independent (file: {settings.sampler})"
    return ident


def reference_key(scene, params, integrator, spp, seed, options=None, resolution=None):
    """The lookup key (hex SHA-256); computed without Mitsuba."""
    ident = _identity(scene, params, integrator, spp, seed, options, resolution)
    blob = json.dumps(ident, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(blob.encode()).hexdigest()


def scene_label(scene) -> str:
    """The scene's part of a reference's file name: a built-in scene's name, or a user's file
    name with a short hash of its content and included files' (:func:`scene_hash`), so that
    files of one name with different contents (four users' ``scene.xml``) never share a
    reference, and one scene reached by another path (another machine of a cluster, a
    later run elsewhere) finds its reference."""
    path = resolve_scene(scene).resolve()
    if path.parent == Path(BUILTIN_DIR).resolve():
        return path.stem
    return f"{path.stem}-{scene_hash(path)[:8]}"


def reference_stem(scene, params, integrator, spp, seed, options=None, resolution=None):
    """File stem of a reference (readable; uniqueness via the scene's file
    (:func:`scene_label`), the params, the integrator overrides (``set-``) and an
    overridden film size)."""
    parts = [scene_label(scene), canonical_integrator(integrator)]
    if params:
        parts.append("_".join(f"{k}-{v}" for k, v in sorted(params.items())))
    if options:
        parts.append("set-" + "_".join(f"{k}-{v}" for k, v in sorted(options.items())))
    if resolution is not None:
        parts.append(f"{int(resolution[0])}x{int(resolution[1])}")
    parts.append(f"{int(spp)}spp-s{int(seed)}")
    stem = "__".join(parts)
    return re.sub(r"[^A-Za-z0-9_.=-]", "-", stem)


def reference_paths(scene, params, integrator, spp, seed, directory=None, options=None,
                    resolution=None):
    """``(exr_path, json_path)`` of a reference."""
    d = Path(directory) if directory is not None else cache_dir()
    stem = reference_stem(scene, params, integrator, spp, seed, options, resolution)
    return d / f"{stem}.exr", d / f"{stem}.json"


def validate(scene, params, integrator, spp, seed, directory=None, options=None,
             resolution=None):
    """Check a cached reference.

    The sidecar and the EXR are read under the cache's shared lock
    (:func:`cache_lock`), so a concurrent :func:`store` is seen either
    entirely or not at all.

    Returns
    -------
    (status, detail, reference)
        ``status`` is ``"ok"`` (``reference`` is the loaded
        :class:`~mitsuba_refs.reference.render.Reference`), ``"missing"``, ``"stale"``
        or ``"corrupt"`` (``reference`` is None).

    Raises
    ------
    RefsInputError
        The scene file is not well-formed, refers to missing files, or
        ``params`` names a parameter the file does not declare.
    """
    exr_path, json_path = reference_paths(scene, params, integrator, spp,
                                          seed, directory, options, resolution)
    key = reference_key(scene, params, integrator, spp, seed, options, resolution)
    with cache_lock(exr_path.parent, exclusive=False):
        if not exr_path.exists() and not json_path.exists():
            return "missing", f"no {exr_path.name}", None
        try:
            metadata = json.loads(json_path.read_text())
        except (OSError, ValueError) as exc:
            return "corrupt", f"sidecar {json_path.name} unreadable: {exc}", None
        if metadata.get("key") != key:
            return "stale", "key mismatch (scene, included files, params, " \
                            "integrator, spp or seed changed)", None
        before = interrupts.count()
        try:
            with _output_silenced():
                mean, var, attrs = read_mean_variance(exr_path)
        except Exception as exc:  # OpenEXR raises various types
            # OpenEXR turns a Ctrl-C during the read into an error of its own: an interrupt
            # is never a verdict on the file (pathtracer.core.interrupts).
            interrupts.reraise_if_interrupted(before, exc)
            return "corrupt", f"{exr_path.name} unreadable: {exc}", None
    shape = (int(metadata.get("height", -1)), int(metadata.get("width", -1)), 3)
    if mean.shape != shape:
        return "corrupt", f"shape {mean.shape}, expected {shape}", None
    if not (np.isfinite(mean).all() and np.isfinite(var).all()):
        return "corrupt", "non-finite values", None
    if (var < 0).any():
        return "corrupt", "negative variance", None
    checksum = pixel_checksum(mean.astype(np.float32), var.astype(np.float32))
    if checksum != metadata.get("pixel_sha256") or \
            checksum != attrs.get("pixel_sha256"):
        return "corrupt", "pixel checksum mismatch", None
    if attrs.get("key") != key:
        return "corrupt", "EXR header key differs from sidecar", None
    metadata = dict(metadata, exr_file=str(exr_path))
    return "ok", "valid", Reference(mean=mean, var=var,
                                    n=int(metadata["spp"]), metadata=metadata)


#: Serialises :func:`_output_silenced`: two threads saving and restoring the process-wide
#: descriptors in interleaved order (the autograder validates from several threads) would
#: leave stdout on the null device for good.
_SILENCE_LOCK = threading.Lock()


@contextlib.contextmanager
def _output_silenced():
    """Send file descriptors 1 and 2 to the null device: OpenEXR's C++ library prints
    its own lines about a corrupt file, which :func:`validate` reports as one ``detail``."""
    with _SILENCE_LOCK:
        sys.stdout.flush()
        sys.stderr.flush()
        saved = [os.dup(1), os.dup(2)]
        try:
            with open(os.devnull, "wb") as null:
                os.dup2(null.fileno(), 1)
                os.dup2(null.fileno(), 2)
            yield
        finally:
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            os.close(saved[0])
            os.close(saved[1])


#: Lock file of a cache folder; :func:`store` holds it exclusively while it
#: renames a reference's pair of files into place, :func:`validate` shared.
LOCK_NAME = ".mitsuba-refs.lock"


@contextlib.contextmanager
def cache_lock(directory, exclusive):
    """Hold the ``fcntl`` lock of the cache folder ``directory``.

    A shared lock is skipped where the lock file cannot be opened (a
    read-only or not yet created cache, which nobody is writing to through
    this module); an exclusive one is needed only by :func:`store`, which
    has already created the folder. Without ``fcntl`` (Windows) nothing is
    locked and a torn pair is caught by :func:`validate`'s checksums.
    """
    if fcntl is None:
        yield
        return
    path = Path(directory) / LOCK_NAME
    flags = os.O_RDWR | os.O_CREAT if exclusive else os.O_RDONLY
    try:
        fd = os.open(path, flags, 0o666)
    except OSError:
        if exclusive:
            raise
        yield
        return
    try:
        fcntl.flock(fd, fcntl.LOCK_EX if exclusive else fcntl.LOCK_SH)
        yield
    finally:
        os.close(fd)  # closing releases the lock


def not_writable(directory, error):
    """The :class:`CacheNotWritable` for an ``OSError`` met writing to ``directory``."""
    reason = error.strerror or type(error).__name__
    return CacheNotWritable(
        f"cannot write to the reference cache {directory} ({reason}): a reference has to be "
        f"rendered and stored there; set {config.ENV_CACHE} to a writable folder")


def check_writable(directory):
    """Raise :class:`CacheNotWritable` unless a file can be created in ``directory``
    (created if missing). Called before rendering, so that no render is lost."""
    directory = Path(directory)
    try:
        directory.mkdir(parents=True, exist_ok=True)
        fd, probe = tempfile.mkstemp(dir=directory, prefix=".write-test-")
        os.close(fd)
        os.unlink(probe)
    except OSError as error:
        raise not_writable(directory, error) from None


def _temporary_path(directory, final_name):
    """A new, uniquely named empty file next to ``final_name`` (hidden, ``.tmp``)."""
    fd, name = tempfile.mkstemp(dir=directory, prefix=f".{final_name}.", suffix=".tmp")
    os.close(fd)
    # mkstemp makes the file private (0600); a reference gets the usual umask-based mode.
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(name, 0o666 & ~umask)
    return Path(name)


def store(reference, scene, params, integrator, spp, seed, directory=None, options=None,
          resolution=None, replace=True):
    """Write ``reference`` (EXR + JSON sidecar) atomically; return the paths.

    Both files are written under unique temporary names in the cache folder
    and renamed into place (``os.replace``, atomic) together under the
    cache's exclusive lock, so concurrent writers and readers of the same
    reference never see a torn file or a mismatched pair: the last writer
    wins; with ``replace=False`` a pair already published under the same key is kept (the
    first publisher wins; a reference's pixels are a function of its key, so they are the
    same). Temporary files are removed on any failure.

    Raises
    ------
    CacheNotWritable
        The folder cannot be created or written (one line, names the folder).
    """
    exr_path, json_path = reference_paths(scene, params, integrator, spp,
                                          seed, directory, options, resolution)
    meta = dict(reference.metadata)
    key = reference_key(scene, params, integrator, spp, seed, options, resolution)
    meta["key"] = key
    meta["scene_hash"] = scene_hash(scene)
    meta["requested_spp"] = int(spp)
    meta["format"] = FORMAT_VERSION
    full = json.dumps([key, meta.get("mitsuba_version"), meta.get("variant")])
    meta["full_hash"] = hashlib.sha256(full.encode()).hexdigest()
    meta.pop("scene_file", None)
    meta.pop("exr_file", None)
    attrs = {"spp": int(reference.n), "seed": int(seed),
             "integrator": meta.get("integrator", integrator),
             "variant": str(meta.get("variant", "")),
             "mitsuba_version": str(meta.get("mitsuba_version", "")),
             "scene": str(meta.get("scene", "")),
             "scene_hash": meta["scene_hash"], "key": key,
             "full_hash": meta["full_hash"]}
    directory = exr_path.parent
    temporary = []
    try:
        directory.mkdir(parents=True, exist_ok=True)
        temporary.append(_temporary_path(directory, exr_path.name))
        meta["pixel_sha256"] = write_reference_exr(temporary[0], reference.mean,
                                                   reference.var, attrs)
        temporary.append(_temporary_path(directory, json_path.name))
        temporary[1].write_text(json.dumps(meta, indent=1, sort_keys=True) + "\n")
        with cache_lock(directory, exclusive=True):
            if replace or not _published(json_path, exr_path, key):
                os.replace(temporary[0], exr_path)
                os.replace(temporary[1], json_path)
                temporary.clear()
    except OSError as error:
        raise not_writable(directory, error) from None
    finally:
        for path in temporary:
            path.unlink(missing_ok=True)
    return exr_path, json_path


def _published(json_path, exr_path, key):
    """True when the pair of ``key`` is already in place (read under the exclusive lock)."""
    try:
        return exr_path.exists() and json.loads(json_path.read_text()).get("key") == key
    except (OSError, ValueError):
        return False


def mitsuba_available():
    """True when ``import mitsuba`` works."""
    try:
        import mitsuba  # noqa: F401  (only whether it imports)
    except ImportError:
        return False
    return True


def get_reference(scene, params, integrator, spp=config.REF_SPP,
                  seed=config.REF_SEED, *, directory=None, render=True, log=None, options=None,
                  resolution=None):
    """Return a valid cached reference, or render and cache one.

    Parameters
    ----------
    scene, params, integrator, spp, seed
        As for :func:`mitsuba_refs.reference.render.render_reference`.
    directory : path, optional
        Cache folder (default :func:`cache_dir`).
    render : bool
        Render (Mitsuba's default variant) when no valid reference is cached (needs Mitsuba).
    options : dict, optional
        Overrides of ``max_depth``, ``rr_depth``, ``hide_emitters`` (the tracer's
        render options of the same names).
    resolution : (int, int), optional
        Film size replacing the file's.

    Raises
    ------
    ReferenceUnavailable
        No valid cached reference and Mitsuba is unavailable (or
        ``render=False``); the message says what was wrong with the cache.
    CacheNotWritable
        A render is needed but the cache folder cannot be written; raised
        before rendering (it is a ``ReferenceUnavailable`` too).
    RefsInputError
        The scene file or ``params`` are wrong, Mitsuba refuses the file
        (its message in one line), or the render is not finite
        (:func:`check_finite`); nothing is stored.

    See :func:`build_reference` to render one even when a valid one is cached, in a chosen
    Mitsuba variant.
    """
    params, where = _normalised(params, options, resolution)
    # Bad parameters are the user's error whatever the cache holds: report them first.
    reference_key(scene, params, integrator, spp, seed, **where)
    for folder in lookup_dirs(directory):
        status, detail, ref = validate(scene, params, integrator, spp, seed, folder, **where)
        if status == "ok":
            return ref
    request = _Request(scene, params, integrator, spp, seed, directory, where)
    return _render_and_store(request, render=render, variant=None, log=log, why=(status, detail))


def build_reference(scene, params, integrator, spp=config.REF_SPP, seed=config.REF_SEED, *,
                    directory=None, variant=None, log=None, options=None, resolution=None):
    """Render a reference and cache it, even if a valid one is cached (``mitsuba-refs build``).

    Parameters as for :func:`get_reference`; ``variant`` is the Mitsuba variant to render in
    (default :func:`mitsuba_refs.reference.variant.choose_variant`'s). Raises as it does.
    """
    params, where = _normalised(params, options, resolution)
    reference_key(scene, params, integrator, spp, seed, **where)
    request = _Request(scene, params, integrator, spp, seed, directory, where)
    return _render_and_store(request, render=True, variant=variant, log=log,
                             why=("forced", "--force"))


class _Request(NamedTuple):
    """One reference of the cache: what :func:`reference_key` and :func:`validate` take."""

    scene: str | Path
    params: dict
    integrator: str
    spp: int
    seed: int
    directory: str | Path | None
    where: dict


def _normalised(params, options, resolution):
    """``params`` as strings, and ``options`` and ``resolution`` as the cache keys them."""
    params = {str(k): str(v) for k, v in (params or {}).items()}
    options = {str(k): v for k, v in (options or {}).items() if v is not None} or None
    resolution = tuple(int(v) for v in resolution) if resolution is not None else None
    return params, dict(options=options, resolution=resolution)


def _render_and_store(request: _Request, *, render, variant, log, why):
    """Render ``request`` with Mitsuba, check, store and validate it; ``why`` = (status,
    detail) of the cached one, for the messages."""
    scene, params, integrator, spp, seed, directory, where = request
    status, detail = why
    exr_path, _ = reference_paths(scene, params, integrator, spp, seed, directory, **where)
    if render:
        check_writable(exr_path.parent)
    if not render or not mitsuba_available():
        why = "rendering disabled" if not render else "Mitsuba 3 is not installed"
        raise ReferenceUnavailable(
            f"reference {exr_path} is {status} ({detail}) and {why}; "
            f"install mitsuba==3.9.1 and run `mitsuba-refs build`")
    if log:
        log(f"{reference_stem(scene, params, integrator, spp, seed, **where)}: "
            f"{status} ({detail}), rendering")
    variant, calls = _site_split(request, variant)
    try:
        with split.calls_split_by(calls):
            ref = render_reference(scene, params, integrator, spp, seed,
                                   variant=variant, log=log, **where)
    except RuntimeError as error:
        if is_mitsuba_error(error):
            raise RefsInputError(mitsuba_error_line(error, resolve_scene(scene))) from None
        raise
    check_finite(ref, scene)
    store(ref, scene, params, integrator, spp, seed, directory, **where,
          replace=status != "missing")
    status, detail, loaded = validate(scene, params, integrator, spp, seed,
                                      directory, **where)
    if status != "ok":
        raise RuntimeError(f"freshly written {exr_path} fails validation: {detail}")
    return loaded


def _site_split(request: _Request, variant):
    """``(variant, split)`` of :func:`render_reference` where :func:`split.rendering_on` names a
    site (a cluster), else ``(variant, None)`` (:func:`split.calls_split_by`)."""
    site = split.current_site()
    if site is None:
        return variant, None
    variant = variant or site.variant
    job = split.ReferenceJob(str(resolve_scene(request.scene)), request.params,
                             request.integrator, request.spp, request.seed, variant,
                             **request.where)
    return variant, site.split_for(job)


#: The largest per-sample radiance whose square float32 holds (Mitsuba's films are float32).
FLOAT32_SQUARE_LIMIT = float(np.sqrt(np.finfo(np.float32).max))


def check_finite(reference, scene):
    """Refuse a rendered reference with NaN or infinite values before it is stored.

    Raises
    ------
    RefsInputError
        Says which values are not finite (or beyond float32, in which the EXR stores
        them) and, when only the variance is, why: squared radiance above ~1.8e19
        overflows float32 (Mitsuba's films, the EXR).
    """
    # Stored as float32: what float32 cannot hold is as good as infinite.
    largest = np.finfo(np.float32).max
    mean_ok, var_ok = np.abs(reference.mean) <= largest, np.abs(reference.var) <= largest
    if mean_ok.all() and var_ok.all():
        return
    where = resolve_scene(scene)
    if mean_ok.all():
        largest = float(np.abs(reference.mean).max())
        raise RefsInputError(
            f"{where}: the reference variance overflows in {int((~var_ok).sum())} of "
            f"{var_ok.size} pixel channels (mean radiance up to {largest:.3g}): Mitsuba keeps "
            f"each sample's squared radiance in float32, which holds radiance up to "
            f"{FLOAT32_SQUARE_LIMIT:.2g}; scale the emitters' radiance down (the comparison "
            f"does not depend on a common scale)")
    raise RefsInputError(
        f"{where}: Mitsuba rendered NaN or infinite radiance in {int((~mean_ok).sum())} of "
        f"{mean_ok.size} pixel channels; check the scene's values (radiance, reflectance, "
        f"vertices) for nan, inf or overflow")
