"""A failed check's evidence, kept small enough to commit, and brought back for the rules.

:mod:`autograder.hint_accuracy` keeps full pickles of the evidence it records; a test cannot
render the mutants again, so a few cases are also written in this compact form: the numbers
the rules of :mod:`autograder.hints` read (the comparison's verdicts and ratios, the sweep's
per-depth agreement, the probe, R, the camera's geometry) as JSON, and the student's sweep
renders as luminance images (float16) with the sweep's per-tile z (``.npz``). Every rule reads images only through their
luminance, so an image rebuilt as luminance in each channel (LUMINANCE sums to one) gives the
rules the same numbers; Mitsuba's per-bounce references are the committed ones.
"""
from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from mitsuba_refs.cache import get_reference
from mitsuba_refs.compare import default_params
from pathtracer.core.color import LUMINANCE

from . import grading
from .hints import Evidence

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


def _fields(obj, names) -> dict | None:
    return None if obj is None else {n: _plain(getattr(obj, n)) for n in names}


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
