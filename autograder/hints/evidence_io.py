"""A failed check's evidence on disk: in full, for the hint measurement, and compact, to commit.

Both forms are data only (JSON and ``.npz`` read with ``allow_pickle=False``): nothing read back
runs code, so a cache that a graded mutant could have written can mislead a measurement at
worst, never take over the process that reads it.

:func:`dump` / :func:`load` keep everything :func:`autograder.hints.explain.explain` may read,
at full precision: the evidence's tree of dicts, tuples and the project's own result
dataclasses (:data:`CLASSES`, restored as those classes, so their properties work) as JSON,
every array in the ``.npz`` beside it, the check by its id. :mod:`autograder.hints.accuracy`
keeps its cache this way.

:func:`write` / :func:`read` keep a few cases small enough to commit (a test cannot render the
mutants again): the numbers the rules read (the comparison's verdicts and ratios, the sweep's
per-depth agreement, the probe, R, the camera's geometry) as JSON, and the student's sweep
renders as luminance images (float16) with the sweep's per-tile z. Every rule reads images only
through their luminance, so an image rebuilt as luminance in each channel (LUMINANCE sums to
one) gives the rules the same numbers; Mitsuba's per-bounce references are the committed ones.
"""
from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from mitsuba_refs.reference.cache import get_reference
from mitsuba_refs.report.wording import mean_region, mean_verdict, variance_policy_verdict
from mitsuba_refs.stats.convergence import ConvergenceResult
from mitsuba_refs.stats.correlation import PixelCorrelation
from mitsuba_refs.stats.detectable import DetectableBias
from mitsuba_refs.stats.mean import MeanAgreement
from mitsuba_refs.stats.variance import VarianceAgreement
from mitsuba_refs.verdicts.compare import Comparison
from mitsuba_refs.verdicts.convergence import ConvergenceParts
from mitsuba_refs.verdicts.explain import Hint
from mitsuba_refs.verdicts.scenes import default_params
from pathtracer.core.color import LUMINANCE

from .. import grading
from .explain import Evidence

#: The classes a full record may hold, by name; any other object is refused when writing.
CLASSES = {cls.__name__: cls for cls in (
    Evidence, Comparison, ConvergenceParts, ConvergenceResult, PixelCorrelation, DetectableBias,
    MeanAgreement, VarianceAgreement, grading.CheckResult, grading.Part, SimpleNamespace)}


def _encode(value, arrays: dict):
    """``value`` as JSON-able data; its arrays go into ``arrays`` (name -> array)."""
    if value is None or isinstance(value, (bool, int, float)):
        return value
    if isinstance(value, Hint):
        return {"hint": str(value), "causes": list(value.causes)}
    if isinstance(value, str):
        return value
    if isinstance(value, np.generic):
        return _encode(value.item(), arrays)
    if isinstance(value, np.ndarray):
        if value.dtype.hasobject:
            raise TypeError("an array of Python objects is not evidence")
        name = f"a{len(arrays)}"
        arrays[name] = value
        return {"array": name}
    if isinstance(value, list):
        return [_encode(v, arrays) for v in value]
    if isinstance(value, tuple):
        return {"tuple": [_encode(v, arrays) for v in value]}
    if isinstance(value, dict):
        return {"dict": [[_encode(k, arrays), _encode(v, arrays)] for k, v in value.items()]}
    if isinstance(value, grading.Check):
        return {"check": value.id}
    name = type(value).__name__
    if CLASSES.get(name) is not type(value):
        raise TypeError(f"{type(value).__module__}.{name} is not among evidence_io.CLASSES")
    return {"object": name, "fields": {k: _encode(v, arrays) for k, v in vars(value).items()}}


def _decode(data, arrays):
    """The value :func:`_encode` turned into ``data``."""
    if isinstance(data, list):
        return [_decode(v, arrays) for v in data]
    if not isinstance(data, dict):
        return data
    if "hint" in data:
        return Hint(data["hint"], data["causes"])
    if "array" in data:
        return arrays[data["array"]]
    if "tuple" in data:
        return tuple(_decode(v, arrays) for v in data["tuple"])
    if "dict" in data:
        return {_decode(k, arrays): _decode(v, arrays) for k, v in data["dict"]}
    if "check" in data:
        return grading.CHECKS_BY_ID[data["check"]]
    cls = CLASSES[data["object"]]                       # KeyError: not a class we wrote
    obj = cls.__new__(cls)
    for key, value in data["fields"].items():
        object.__setattr__(obj, key, _decode(value, arrays))   # frozen dataclasses too
    return obj


def dump(ev, folder: Path, name: str, entry: dict = None) -> None:
    """``folder/name.json`` and ``name.npz``: the evidence ``ev`` (None too) in full, and the
    JSON-able ``entry`` it belongs to beside it."""
    arrays = {}
    record = dict(entry or {}, evidence=_encode(ev, arrays))
    folder.mkdir(parents=True, exist_ok=True)
    (folder / f"{name}.json").write_text(json.dumps(record) + "\n")
    np.savez_compressed(folder / f"{name}.npz", **arrays)


def load(folder: Path, name: str) -> tuple:
    """(the evidence, the entry) written by :func:`dump`."""
    record = json.loads((folder / f"{name}.json").read_text())
    with np.load(folder / f"{name}.npz", allow_pickle=False) as stored:
        arrays = {key: stored[key] for key in stored.files}
    return _decode(record.pop("evidence"), arrays), record


# ----------------------------------------------------------------------------------------
# The compact form (committed cases of tests/test_hint_accuracy.py)
MEAN = ("agree", "rel_bias", "rel_bias_ci", "worst_region", "worst_z", "verdict")
VARIANCE = ("agree", "ratio", "policy_agree", "policy_verdict", "max_ratio")
CONVERGENCE = ("passed", "correlated", "floor_detected", "floor_spp", "bias_rel", "slope",
               "slope_ci")
SWEEP = ("agree", "rel_bias", "rel_bias_ci")


def _plain(value):
    if isinstance(value, (np.floating, np.integer, np.bool_)):
        return value.item()
    if isinstance(value, tuple):
        return [_plain(v) for v in value]
    if isinstance(value, float) and not np.isfinite(value):
        return str(value)
    return value


#: Fields kept in words: the verdict's line and region as the report says them.
WORDS = {"worst_region": mean_region, "verdict": mean_verdict,
         "policy_verdict": variance_policy_verdict}


def _fields(obj, names) -> dict | None:
    if obj is None:
        return None
    return {n: _plain(WORDS[n](obj) if n in WORDS else getattr(obj, n)) for n in names}


def _number(value):
    return float(value) if value in ("nan", "inf", "-inf") else value


def _namespace(fields) -> SimpleNamespace | None:
    if fields is None:
        return None
    return SimpleNamespace(**{k: tuple(_number(x) for x in v) if isinstance(v, list)
                              else _number(v) for k, v in fields.items()})


def write(ev, folder: Path, name: str, **extra) -> None:
    """``folder/name.json`` (+ ``name.npz`` with the sweep's luminance images); ``extra``
    (e.g. the mutant's true cause) is kept in the JSON."""
    if ev.images is not None or ev.history:
        raise ValueError("light-tracing images and check histories are not kept in compact form")
    c = ev.comparison
    record = dict(check=ev.check.id, mean=_fields(c.mean, MEAN),
                  variance=_fields(c.variance, VARIANCE),
                  convergence=_fields(c.convergence, CONVERGENCE),
                  probe=list(ev.probe) if ev.probe is not None else None,
                  independence=_plain(ev.independence), camera=ev.camera,
                  incomplete=ev.incomplete,
                  sweep={str(d): _fields(s[0], SWEEP) for d, s in (ev.sweep or {}).items()},
                  **extra)
    folder.mkdir(parents=True, exist_ok=True)
    (folder / f"{name}.json").write_text(json.dumps(record, indent=1) + "\n")
    if ev.sweep:
        arrays = {}
        for d, (agreement, test, _) in ev.sweep.items():
            arrays[f"depth{d}"] = (np.asarray(test) @ LUMINANCE).astype(np.float16)
            arrays[f"z{d}"] = np.asarray(agreement.z_tiles, dtype=np.float32)
        np.savez_compressed(folder / f"{name}.npz", **arrays)


def read(folder: Path, name: str) -> tuple:
    """(Evidence, the JSON record) written by :func:`write` (sweep references: the committed
    ones)."""
    record = json.loads((folder / f"{name}.json").read_text())
    check = grading.CHECKS_BY_ID[record["check"]]
    comparison = SimpleNamespace(mean=_namespace(record["mean"]),
                                 variance=_namespace(record["variance"]),
                                 convergence=_namespace(record["convergence"]),
                                 bounce=None, bounce_results=None)
    sweep = None
    if record["sweep"]:
        images = np.load(folder / f"{name}.npz")
        estimator = grading.BOUNCE_REFERENCE.get(check.integrator, "path")
        params = default_params(check.scene)
        sweep = {}
        for d, fields in record["sweep"].items():
            ref = get_reference(check.scene, {**params, "max_depth": int(d)}, estimator,
                                render=False).mean
            test = images[f"depth{d}"].astype(np.float64)[..., None] * np.ones(3)
            agreement = _namespace(fields)
            agreement.z_tiles = images[f"z{d}"].astype(np.float64)
            sweep[int(d)] = (agreement, test, ref)
    evidence = Evidence(check=check, comparison=comparison, sweep=sweep,
                        independence=_number(record["independence"]), camera=record["camera"],
                        probe=tuple(record["probe"]) if record["probe"] is not None else None,
                        incomplete=record["incomplete"])
    return evidence, record
