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
"""

import hashlib
import json
import os
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from . import config
from .exr import pixel_checksum, read_reference_exr, write_reference_exr
from .render import (MEAN_ONLY, Reference, integrator_dict, reference_settings,
                     resolve_scene)

FORMAT_VERSION = 1


class ReferenceUnavailable(RuntimeError):
    """No valid cached reference and Mitsuba cannot render one."""


def cache_dir():
    """``$MITSUBA_REFS_CACHE`` if set, else ``mitsuba_refs/references``."""
    env = os.environ.get(config.ENV_CACHE)
    if env:
        return Path(env)
    return Path(__file__).resolve().parent / "references"


def _sha256_file(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def included_files(scene_path):
    """Files a scene XML refers to (``filename`` strings, ``<include>``),
    resolved relative to the scene's folder, recursively for includes."""
    scene_path = Path(scene_path)
    root = ET.parse(scene_path).getroot()
    found = []
    for el in root.iter():
        name = None
        if el.tag == "string" and el.get("name") == "filename":
            name = el.get("value")
        elif el.tag == "include":
            name = el.get("filename")
        if not name or "$" in name:
            continue
        path = (scene_path.parent / name).resolve()
        found.append(path)
        if el.tag == "include" and path.suffix == ".xml" and path.exists():
            found.extend(included_files(path))
    return found


def scene_hash(scene):
    """SHA-256 over the scene file and its included files' contents."""
    path = resolve_scene(scene)
    h = hashlib.sha256()
    h.update(b"scene\0" + bytes.fromhex(_sha256_file(path)))
    for inc in included_files(path):
        if not inc.exists():
            raise FileNotFoundError(f"{path.name} includes missing file {inc}")
        h.update(inc.name.encode() + b"\0" + bytes.fromhex(_sha256_file(inc)))
    return h.hexdigest()


def canonical_integrator(integrator):
    """Our integrator name under which the reference is stored
    (``recursive`` and ``smallpt`` share ``path``'s references)."""
    return "path" if integrator in MEAN_ONLY else integrator


def _identity(scene, params, integrator, spp, seed, options=None, resolution=None):
    """What the reference renders. The Mitsuba integrator dictionary carries the
    effective ``max_depth``/``rr_depth``/``hide_emitters`` read by the tracer's
    loader (literal, ``$param`` or ``options``), so a literal value in the file
    changes the key; an overridden film size adds ``resolution``."""
    path = resolve_scene(scene)
    params = {str(k): str(v) for k, v in (params or {}).items()}
    _, transport, settings = reference_settings(path, params, options, resolution)
    ident = {
        "format": FORMAT_VERSION,
        "scene_hash": scene_hash(path),
        "params": dict(sorted(params.items())),
        "integrator": canonical_integrator(integrator),
        "mitsuba_integrator": integrator_dict(integrator, transport),
        "spp": int(spp),
        "seed": int(seed),
    }
    if resolution is not None:
        ident["resolution"] = list(settings.resolution)
    return ident


def reference_key(scene, params, integrator, spp, seed, options=None, resolution=None):
    """The lookup key (hex SHA-256); computed without Mitsuba."""
    ident = _identity(scene, params, integrator, spp, seed, options, resolution)
    blob = json.dumps(ident, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(blob.encode()).hexdigest()


def reference_stem(scene, params, integrator, spp, seed, options=None, resolution=None):
    """File stem of a reference (readable; uniqueness via the params, the
    integrator overrides (``set-``) and an overridden film size)."""
    name = resolve_scene(scene).stem
    parts = [name, canonical_integrator(integrator)]
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

    Returns
    -------
    (status, detail, reference)
        ``status`` is ``"ok"`` (``reference`` is the loaded
        :class:`~mitsuba_refs.render.Reference`), ``"missing"``, ``"stale"``
        or ``"corrupt"`` (``reference`` is None).
    """
    exr_path, json_path = reference_paths(scene, params, integrator, spp,
                                          seed, directory, options, resolution)
    if not exr_path.exists() and not json_path.exists():
        return "missing", f"no {exr_path.name}", None
    try:
        metadata = json.loads(json_path.read_text())
    except (OSError, ValueError) as exc:
        return "corrupt", f"sidecar {json_path.name} unreadable: {exc}", None
    key = reference_key(scene, params, integrator, spp, seed, options, resolution)
    if metadata.get("key") != key:
        return "stale", "key mismatch (scene, included files, params, " \
                        "integrator, spp or seed changed)", None
    try:
        mean, var, attrs = read_reference_exr(exr_path)
    except Exception as exc:  # OpenEXR raises various types
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


def store(reference, scene, params, integrator, spp, seed, directory=None, options=None,
          resolution=None):
    """Write ``reference`` (EXR + JSON sidecar) atomically; return the paths."""
    exr_path, json_path = reference_paths(scene, params, integrator, spp,
                                          seed, directory, options, resolution)
    exr_path.parent.mkdir(parents=True, exist_ok=True)
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
    tmp_exr = exr_path.with_suffix(".exr.tmp")
    meta["pixel_sha256"] = write_reference_exr(tmp_exr, reference.mean,
                                               reference.var, attrs)
    tmp_json = json_path.with_suffix(".json.tmp")
    tmp_json.write_text(json.dumps(meta, indent=1, sort_keys=True) + "\n")
    os.replace(tmp_exr, exr_path)
    os.replace(tmp_json, json_path)
    return exr_path, json_path


def mitsuba_available():
    """True when ``import mitsuba`` works."""
    try:
        import mitsuba  # noqa: F401
    except ImportError:
        return False
    return True


def get_reference(scene, params, integrator, spp=config.REF_SPP,
                  seed=config.REF_SEED, *, directory=None, variant=None,
                  render=True, force=False, log=None, options=None, resolution=None):
    """Return a valid cached reference, or render and cache one.

    Parameters
    ----------
    scene, params, integrator, spp, seed
        As for :func:`mitsuba_refs.render.render_reference`.
    directory : path, optional
        Cache folder (default :func:`cache_dir`).
    variant : str, optional
        Mitsuba variant if a render is needed.
    render : bool
        Render when no valid reference is cached (needs Mitsuba).
    force : bool
        Render even if a valid one is cached.
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
    """
    params = {str(k): str(v) for k, v in (params or {}).items()}
    options = {str(k): v for k, v in (options or {}).items() if v is not None} or None
    resolution = tuple(int(v) for v in resolution) if resolution is not None else None
    where = dict(options=options, resolution=resolution)
    # Bad parameters are the user's error whatever the cache holds: report them first.
    reference_key(scene, params, integrator, spp, seed, **where)
    status, detail = "forced", "--force"
    if not force:
        status, detail, ref = validate(scene, params, integrator, spp, seed,
                                       directory, **where)
        if status == "ok":
            return ref
    if not render or not mitsuba_available():
        why = "rendering disabled" if not render else "Mitsuba 3 is not installed"
        exr_path, _ = reference_paths(scene, params, integrator, spp, seed,
                                      directory, **where)
        raise ReferenceUnavailable(
            f"reference {exr_path} is {status} ({detail}) and {why}; "
            f"install mitsuba==3.9.1 and run `mitsuba-refs build`")
    if log:
        log(f"{reference_stem(scene, params, integrator, spp, seed, **where)}: "
            f"{status} ({detail}), rendering")
    from .render import render_reference
    ref = render_reference(scene, params, integrator, spp, seed,
                           variant=variant, log=log, **where)
    exr_path, json_path = store(ref, scene, params, integrator, spp, seed,
                                directory, **where)
    status, detail, loaded = validate(scene, params, integrator, spp, seed,
                                      directory, **where)
    if status != "ok":
        raise RuntimeError(f"freshly written {exr_path} fails validation: {detail}")
    return loaded
