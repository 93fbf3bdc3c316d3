"""Comparisons as JSON records, with their images as EXR beside them; results files written and read.

A results file (schema :data:`RESULTS_SCHEMA`) holds one record (schema :data:`SCHEMA`)
per comparison. Each record saves the images its verdicts came from (test and reference,
mean and per-sample variance, :func:`pathtracer.io.exr.write_mean_variance`) in the
file's folder and names them relative to it, so that ``mitsuba-refs report`` redraws
every picture from the results file alone. Strict JSON: NaN is ``null``, an infinity
``"inf"`` (:mod:`.encoding`).
"""
from __future__ import annotations

import json
import os
import re
from pathlib import Path

import numpy as np

from pathtracer.io.exr import warn_clamped, write_mean_variance
from pathtracer.io.output import atomic_path

from ..errors import RefsInputError
from ..verdicts.detect import is_weak
from .encoding import number, plain
from .verdicts import verdict_entries

__all__ = ["SCHEMA", "RESULTS_SCHEMA", "comparison_record", "write_json", "load_results",
           "record_path", "default_stem"]

SCHEMA = "mitsuba-refs/result/1"
RESULTS_SCHEMA = "mitsuba-refs/results/1"
#: What every record of a results file must have for the reports to read it.
REQUIRED = ("scene", "renderer", "integrator", "spp", "agree", "verdicts")


def default_stem(result) -> str:
    """The file-name stem of a comparison's images: ``<scene stem>-<integrator>``, in
    letters, digits, ``.``, ``_`` and ``-``."""
    text = f"{Path(str(result.scene)).stem}-{result.integrator}"
    return re.sub(r"[^A-Za-z0-9._-]+", "_", text).strip("._") or "comparison"


def _relative(path, folder: Path) -> str:
    """``path`` relative to ``folder`` (as given when it cannot be)."""
    try:
        return os.path.relpath(Path(path).resolve(), folder.resolve())
    except ValueError:         # another drive
        return str(path)


def _save_images(result, folder: Path, stem: str) -> dict | None:
    """Write ``<stem>-test.exr`` and ``<stem>-reference.exr`` (mean and per-sample variance)
    into ``folder``; their names relative to it, or None when the comparison kept no images."""
    arrays = result.arrays or {}
    if arrays.get("test_mean") is None or arrays.get("reference_mean") is None:
        return None
    folder.mkdir(parents=True, exist_ok=True)
    sides = {"test": ("test_mean", "test_variance", {"renderer": result.renderer, "spp": int(result.spp)}),
             "reference": ("reference_mean", "reference_variance",
                           {"key": result.reference_key, "integrator": result.reference_integrator})}
    names = {}
    for side, (mean_name, variance_name, attributes) in sides.items():
        mean = np.asarray(arrays[mean_name], dtype=np.float64)
        variance = arrays.get(variance_name)
        variance = np.zeros_like(mean) if variance is None else np.asarray(variance, dtype=np.float64)
        path = folder / f"{stem}-{side}.exr"
        with atomic_path(path) as temporary:
            clamped = write_mean_variance(temporary, mean, variance,
                                          {"role": side, "scene": str(result.scene), **attributes})
        warn_clamped(path, clamped)
        names[side] = path.name
    return names


def _film(result) -> dict:
    image = (result.arrays or {}).get("reference_mean")
    if image is None:
        image = (result.arrays or {}).get("test_mean")
    if image is None:
        return {"width": None, "height": None}
    return {"width": int(np.shape(image)[1]), "height": int(np.shape(image)[0])}


def _run_totals(runs: list) -> dict:
    """How many renders the runs are, their seconds, and their CPU-seconds when every run has them."""
    seconds = [run.get("seconds") for run in runs if isinstance(run, dict)]
    cpu = [run.get("cpu_seconds") for run in runs if isinstance(run, dict)]
    return {"renders": len(runs),
            "render_seconds": number(sum(s for s in seconds if isinstance(s, (int, float)))),
            "cpu_seconds": (number(sum(cpu)) if cpu and all(isinstance(c, (int, float)) for c in cpu)
                            else None)}


def _detect(result) -> dict | None:
    """What ``--detect`` chose (:class:`mitsuba_refs.verdicts.detect.SppChoice`), JSON-able."""
    choice = getattr(result, "detect", None)
    if choice is None:
        return None
    return plain({"target": choice.target, "spp": choice.spp, "met": choice.met,
                  "predicted": choice.predicted, "needed_spp": choice.needed,
                  "allowed_spp": choice.allowed, "floor": choice.floor,
                  "reference_spp_needed": choice.reference_needed,
                  "seconds_per_spp": choice.seconds_per_spp, "reason": choice.reason})


def comparison_record(result, out_dir, *, stem: str | None = None) -> dict:
    """A JSON-serialisable record of one comparison (schema :data:`SCHEMA`).

    Parameters
    ----------
    result : Comparison
        What :func:`mitsuba_refs.verdicts.compare.compare` (or ``check``) returned.
    out_dir : path or None
        The folder of the results file: the test and reference images are written there as
        ``<stem>-test.exr`` and ``<stem>-reference.exr``, and every path of the record (images,
        pictures) is relative to it. None writes no images (``"images": null``) and keeps the
        pictures' paths as the comparison has them.
    stem : str, optional
        File-name stem of the images (default :func:`default_stem`).

    Returns
    -------
    dict
        ``schema``, ``scene``, ``renderer``, ``integrator``, ``command`` (an external renderer's
        template or images, else None), ``params``, ``spp``, ``agree``, ``outcome`` (AGREES,
        DISAGREES or INCONCLUSIVE), ``tolerance_percent`` (``--tolerance``, or None),
        ``weak`` (an agreement whose mean test could not see a 5 % global bias), ``detect``
        (what ``--detect`` chose and why, or None),
        ``rendered``, ``reference`` (``key``, ``integrator``, ``width``, ``height``), ``alpha``,
        ``verdicts`` (:mod:`.verdicts`: mean, variance, convergence, bounces), ``hints``,
        ``convention`` (the difference of convention a hint names, as numbers, or None:
        :mod:`mitsuba_refs.verdicts.conventions`),
        ``notes``, ``pictures`` (name -> path), ``images`` (``test``, ``reference`` -> EXR
        path, or None), ``runs``, ``seconds`` (the whole comparison), ``renders``,
        ``render_seconds``, ``cpu_seconds`` (None unless every run has ``cpu_seconds``).
    """
    folder = Path(out_dir) if out_dir is not None else None
    images = _save_images(result, folder, stem or default_stem(result)) if folder is not None else None
    pictures = {str(name): (_relative(path, folder) if folder is not None else str(path))
                for name, path in (result.pictures or {}).items()}
    runs = plain(list(result.runs or []))
    return {
        "schema": SCHEMA,
        "scene": str(result.scene),
        "renderer": result.renderer or f"pathtracer {result.integrator}",
        "integrator": str(result.integrator),
        "command": result.command or None,
        "params": plain(dict(result.params or {})),
        "spp": int(result.spp),
        "agree": bool(result.agree),
        "outcome": result.outcome,
        "tolerance_percent": None if result.rounds is None else result.rounds.tolerance_percent,
        "weak": is_weak(result),
        "detect": _detect(result),
        "rendered": result.rendered,
        "reference": {"key": result.reference_key, "integrator": result.reference_integrator,
                      **_film(result)},
        "alpha": number(result.mean.alpha),
        "verdicts": verdict_entries(result),
        "hints": [str(hint) for hint in result.hints or []],
        "convention": next((hint.finding for hint in result.hints or []
                            if getattr(hint, "finding", None)), None),
        "notes": [str(note) for note in result.notes or []],
        "pictures": pictures,
        "images": images,
        "runs": runs,
        "seconds": number(result.seconds),
        **_run_totals(runs),
    }


def _unique(stem: str, used: set) -> str:
    candidate, count = stem, 1
    while candidate in used:
        count += 1
        candidate = f"{stem}-{count}"
    used.add(candidate)
    return candidate


def write_json(results: list, path, *, alpha: float | None = None, budget: dict | None = None) -> list[dict]:
    """Write a results file: ``{"schema": RESULTS_SCHEMA, "results": [record, ...], ...}``.

    The images of every comparison go beside it (:func:`comparison_record`; two comparisons
    of one scene and integrator get ``-2``, ``-3`` ... stems). The file is written
    atomically (a temporary file renamed into place).

    Parameters
    ----------
    results : list of Comparison
    path : path
        The JSON file; its folder is created.
    alpha : float, optional
        The level of each test; by default the one every comparison shares (None if they differ).
    budget : dict, optional
        How the caller split an error budget over its tests (stored as given, under ``budget``).

    Returns
    -------
    list of dict
        The records, each with ``source`` (this file's path) added, as :func:`load_results`
        returns them.
    """
    path = Path(path)
    folder = path.parent
    folder.mkdir(parents=True, exist_ok=True)
    used: set = set()
    records = [comparison_record(result, folder, stem=_unique(default_stem(result), used))
               for result in results]
    alphas = {record["alpha"] for record in records}
    document = {"schema": RESULTS_SCHEMA, "generator": "mitsuba-refs",
                "alpha": number(alpha) if alpha is not None else (alphas.pop() if len(alphas) == 1 else None),
                "agree": all(record["agree"] for record in records), "results": records}
    if budget is not None:
        document["budget"] = plain(budget)
    text = json.dumps(document, indent=1, ensure_ascii=False, allow_nan=False) + "\n"
    with atomic_path(path) as temporary:
        temporary.write_text(text, encoding="utf-8")
    return [{**record, "source": str(path)} for record in records]


def load_results(path) -> list[dict]:
    """The records of a results file, each with ``source`` (the file's path) added.

    Raises
    ------
    RefsInputError
        In one line naming the file: missing, unreadable, not JSON, not a results file of
        schema :data:`RESULTS_SCHEMA`, or a record that is not a :data:`SCHEMA` record.
    """
    path = Path(path)
    if path.is_dir():
        raise RefsInputError(f"{path}: is a folder, not a results file (give the JSON file --json wrote)")
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise RefsInputError(f"{path}: no such file") from None
    except (OSError, UnicodeDecodeError) as error:
        raise RefsInputError(f"{path}: cannot be read: {getattr(error, 'strerror', None) or error}") from None
    try:
        document = json.loads(text)
    except json.JSONDecodeError as error:
        raise RefsInputError(f"{path}: not JSON ({error.msg} at line {error.lineno}, "
                             f"column {error.colno})") from None
    schema = document.get("schema") if isinstance(document, dict) else None
    if schema != RESULTS_SCHEMA:
        raise RefsInputError(f"{path}: not a mitsuba-refs results file (schema {schema!r}, expected "
                             f"{RESULTS_SCHEMA!r}: the file that --json writes)")
    records = document.get("results")
    if not isinstance(records, list):
        raise RefsInputError(f"{path}: 'results' is not a list of comparison records")
    for index, record in enumerate(records, start=1):
        found = record.get("schema") if isinstance(record, dict) else None
        if found != SCHEMA:
            raise RefsInputError(f"{path}: result {index} has schema {found!r}, expected {SCHEMA!r}")
        missing = [key for key in REQUIRED if key not in record]
        if missing or not isinstance(record["verdicts"], dict):
            raise RefsInputError(f"{path}: result {index} lacks {', '.join(missing) or 'verdicts'}")
    return [{**record, "source": str(path)} for record in records]


def record_path(record: dict, relative) -> Path:
    """A path of a record (image, picture) as it is from here: relative to the folder of the
    results file it came from (``source``), else as written."""
    source = record.get("source")
    if source is None or Path(relative).is_absolute():
        return Path(relative)
    return Path(os.path.normpath(Path(source).parent / relative))
