"""Differences of convention named by ``mitsuba-refs check --images``: how often right, how often wrongly.

A correct renderer's images (Mitsuba 3's own, ``scalar_rgb``, through its Python API) are
given a convention another renderer might follow (a factor pi, a white balance, sRGB output,
a clamp at 1, a flip, a shift by one pixel or by half of one, one bounce too few), a plain
bias that is no convention (a light 5 % too bright or too dark, one wall's albedo changed,
the emitters hidden, two bounces too few), a gaussian or tent reconstruction filter (named
"another filter" whichever of the two fits best) or the fov along another axis, and judged
by ``check`` exactly as a user's files would be: 8 replica PFMs of 8 spp with their
sidecars, against the committed reference. Each check records whether the mean disagreed
and which convention its first hint named.

    python -m experiments.conventions --trials 10
    python -m experiments.conventions --trials 3 --scenes cornell-box --json /tmp/c.json

Seeds are multiples of 8192: Mitsuba's ``scalar_rgb`` seeds a film's blocks from
``seed * width * height`` (mod 2^32), which multiples of 8192 keep apart for up to 127
renders of a 64 x 64 film. Results go to ``--json`` (default
docs/data/conventions_measure.json) and the table to stdout (docs/external.md, "Differences
of convention").
"""
from __future__ import annotations

import argparse
import json
import math
import tempfile
import time
from pathlib import Path

import numpy as np

from mitsuba_refs.errors import RefsInputError
from mitsuba_refs.external.check import check
from mitsuba_refs.stats import conventions as conv

from .bench import cpu_name

ROOT = Path(__file__).resolve().parent.parent
#: Scenes, their film and the parameter of one wall's albedo (Mitsuba's scene parameters).
SCENES = {"cornell-box": ((64, 64), "red.reflectance.value"),
          "smallpt": ((64, 48), "red.reflectance.value")}
#: Each scene's fov_axis, and the one the injected renderer measures its fov along instead
#: (on the square Cornell box x and y are the same: the diagonal).
OWN_AXIS = {"cornell-box": "smaller", "smallpt": "y"}
OTHER_AXIS = {"cornell-box": "diagonal", "smallpt": "x"}
#: The path length of every check (the committed references at 3 and at 2 exist).
DEPTH = 3
REPLICAS, REPLICA_SPP = 8, 8
SEED_STEP = 8192
#: The images' variants that need renders of their own: name -> (max_depth, albedo factor,
#: hide emitters, reconstruction filter, supersampling). A supersampled variant is rendered
#: at twice the film size with a quarter of the samples and averaged over 2 x 2 pixels.
VARIANTS = {"correct": (DEPTH, 1.0, False, "box", 1),
            "other fov axis": (DEPTH, 1.0, False, "box", 1),
            "one bounce fewer": (DEPTH - 1, 1.0, False, "box", 1),
            "two bounces fewer": (DEPTH - 2, 1.0, False, "box", 1),
            "wall albedo x0.8": (DEPTH, 0.8, False, "box", 1),
            "emitters hidden": (DEPTH, 1.0, True, "box", 1),
            "twice the size": (DEPTH, 1.0, False, "box", 2),
            "gaussian filter": (DEPTH, 1.0, False, "gaussian", 1),
            "tent filter": (DEPTH, 1.0, False, "tent", 1)}


#: Renders whose pixel samples are not all spread over the pixel: name -> samples of each
#: replica drawn at the pixel centre (the first, as Cycles draws it; or every one).
CENTRE_VARIANTS = {"first sample at centre": 1, "every sample at centre": REPLICA_SPP}


def _shift(images, dy, dx):
    """Images moved by (dy, dx), the pixels moved in copied from the edge (a renderer's film
    has something there)."""
    moved = []
    for image in images:
        out, valid = conv.shifted(image, dy, dx)
        edge = np.pad(image, ((abs(dy),) * 2, (abs(dx),) * 2, (0, 0)), mode="edge")
        h, w = image.shape[:2]
        padded = edge[abs(dy) - dy:abs(dy) - dy + h, abs(dx) - dx:abs(dx) - dx + w]
        moved.append(np.where(valid[..., None], out, padded))
    return moved


def half_left(images):
    """Twice-size images averaged over 2 x 2 pixels offset by one small pixel: the image
    moved half a pixel left (its last column from the edge)."""
    moved = []
    for image in images:
        padded = np.pad(image, ((0, 0), (0, 1), (0, 0)), mode="edge")[:, 1:]
        h, w = padded.shape[0] // 2, padded.shape[1] // 2
        moved.append(padded.reshape(h, 2, w, 2, -1).mean(axis=(1, 3)))
    return moved


def half_down(images):
    """Twice-size images averaged over 2 x 2 pixels offset by one small pixel: moved half a
    pixel down (its first row from the edge)."""
    moved = []
    for image in images:
        padded = np.pad(image, ((1, 0), (0, 0), (0, 0)), mode="edge")[:-1]
        h, w = padded.shape[0] // 2, padded.shape[1] // 2
        moved.append(padded.reshape(h, 2, w, 2, -1).mean(axis=(1, 3)))
    return moved


def _each(function):
    return lambda images: [function(image) for image in images]


#: name -> (variant rendered, what is done to each image, the convention expected to be named
#: and its value; None: nothing may be named).
INJECTIONS = {
    "none": ("correct", None, None),
    **{f"factor {name}": ("correct", _each(lambda x, k=k: x * k), ("factor", k))
       for name, k in (("pi", math.pi), ("1/pi", 1 / math.pi), ("2", 2.0), ("1/2", 0.5),
                       ("4 pi", 4 * math.pi), ("1/(4 pi)", 1 / (4 * math.pi)))},
    "gains 1.1, 1, 0.85": ("correct", _each(lambda x: x * np.array([1.1, 1.0, 0.85])),
                           ("channel_gains", (1.1, 1.0, 0.85))),
    "gains 0.95, 1, 1.05": ("correct", _each(lambda x: x * np.array([0.95, 1.0, 1.05])),
                            ("channel_gains", (0.95, 1.0, 1.05))),
    "sRGB output": ("correct", _each(conv.srgb_encode), ("srgb", None)),
    "gamma 2.2 output": ("correct", _each(conv.gamma_encode), ("gamma", conv.GAMMA)),
    "clamped at 1": ("correct", _each(lambda x: np.minimum(x, 1.0)), ("clamp", 1.0)),
    "upside down": ("correct", _each(lambda x: x[::-1]), ("flip_vertical", None)),
    "mirrored": ("correct", _each(lambda x: x[:, ::-1]), ("flip_horizontal", None)),
    "one pixel right": ("correct", lambda images: _shift(images, 0, 1), ("shift", (0, 1))),
    "one pixel down": ("correct", lambda images: _shift(images, 1, 0), ("shift", (1, 0))),
    "half a pixel left": ("twice the size", half_left, ("half_shift", (0, -0.5))),
    "half a pixel down": ("twice the size", half_down, ("half_shift", (0.5, 0))),
    "one bounce too few": ("one bounce fewer", None, ("bounces", DEPTH - 1)),
    "gaussian filter": ("gaussian filter", None, ("filter", "gaussian")),
    "tent filter": ("tent filter", None, ("filter", "tent")),
    "fov along another axis": ("other fov axis", None, ("fov_axis", None)),
    "first sample at the pixel centre": ("first sample at centre", None,
                                         ("centre_samples", 1 / REPLICA_SPP)),
    "every sample at the pixel centre": ("every sample at centre", None, ("centre_samples", 1.0)),
    "plain: light +2%": ("correct", _each(lambda x: x * 1.02), None),
    "plain: light +5%": ("correct", _each(lambda x: x * 1.05), None),
    "plain: light -5%": ("correct", _each(lambda x: x * 0.95), None),
    "plain: one wall's albedo x0.8": ("wall albedo x0.8", None, None),
    "plain: emitters hidden": ("emitters hidden", None, None),
    "plain: two bounces too few": ("two bounces fewer", None, None),
}


def mitsuba_replicas(scene: str, variant: str, trial: int) -> list[np.ndarray]:
    """``REPLICAS`` renders of ``scene`` by Mitsuba (``scalar_rgb``) at ``REPLICA_SPP`` spp,
    seeds ``SEED_STEP * j`` with ``j`` unique to the trial and the replica."""
    import mitsuba as mi  # the renderer under test: loaded only when this script runs
    mi.set_variant("scalar_rgb")
    (width, height), wall = SCENES[scene]
    depth, albedo, hide, rfilter, scale = VARIANTS[variant]
    text = (ROOT / "pathtracer/data/scenes" / f"{scene}.xml").read_text()
    text = text.replace('<rfilter type="box"/>', f'<rfilter type="{rfilter}"/>')
    if variant == "other fov axis":
        text = text.replace(f'<string name="fov_axis" value="{OWN_AXIS[scene]}"/>',
                            f'<string name="fov_axis" value="{OTHER_AXIS[scene]}"/>')
    spp = REPLICA_SPP // scale ** 2
    loaded = mi.load_string(text, width=width * scale, height=height * scale, max_depth=depth,
                            spp=spp)
    if albedo != 1.0:
        params = mi.traverse(loaded)
        params[wall] = params[wall] * albedo
        params.update()
    integrator = mi.load_dict({"type": "path", "max_depth": depth, "hide_emitters": hide})
    # A film of twice the size has 4x the pixels: multiples of 8192 x 4 x 4096 would repeat
    # after 32 seeds (seed x width x height mod 2^32), multiples of 64 do not.
    step = SEED_STEP // 128 if scale > 1 else SEED_STEP
    return [np.array(mi.render(loaded, integrator=integrator, seed=step * (1 + trial * REPLICAS + k),
                               spp=spp), dtype=np.float64)
            for k in range(REPLICAS)]


def centre_replicas(scene: str, variant: str, trial: int) -> list[np.ndarray]:
    """``REPLICAS`` renders like :func:`mitsuba_replicas` whose first ``c`` samples of every
    pixel (:data:`CENTRE_VARIANTS`) go through the pixel centre: Mitsuba's own estimator
    (``integrator.sample``) on its own camera ray of the centre, one Python call per sample
    and pixel, averaged with a render of the other ``REPLICA_SPP - c`` samples."""
    import mitsuba as mi  # the renderer under test: loaded only when this script runs
    mi.set_variant("scalar_rgb")
    (width, height), _ = SCENES[scene]
    centre = CENTRE_VARIANTS[variant]
    loaded = mi.load_file(str(ROOT / "pathtracer/data/scenes" / f"{scene}.xml"), width=width,
                          height=height, max_depth=DEPTH, spp=REPLICA_SPP)
    sensor, sampler = loaded.sensors()[0], mi.load_dict({"type": "independent"})
    integrator = mi.load_dict({"type": "path", "max_depth": DEPTH})
    images = []
    for k in range(REPLICAS):
        j = 1 + trial * REPLICAS + k
        total = np.zeros((height, width, 3))
        for y in range(height):
            for x in range(width):
                # Seeds far from the box renders' (seed x pixels + block, mod 2^32).
                sampler.seed(3_000_000_000 + (j * height + y) * width + x)
                for _ in range(centre):
                    ray, _ = sensor.sample_ray(0.0, sampler.next_1d(),
                                               mi.Point2f((x + 0.5) / width, (y + 0.5) / height),
                                               mi.Point2f(0.5, 0.5))
                    total[y, x] += np.array(integrator.sample(loaded, sampler, ray)[0])
                    sampler.advance()
        rest = REPLICA_SPP - centre
        if rest:
            total += rest * np.array(mi.render(loaded, integrator=integrator, seed=SEED_STEP * j,
                                               spp=rest), dtype=np.float64)
        images.append(total / REPLICA_SPP)
    return images


def write_replicas(folder: Path, images) -> str:
    """PFMs (bottom row first) with ``{"spp": REPLICA_SPP}`` sidecars; their glob pattern."""
    folder.mkdir(parents=True, exist_ok=True)
    for k, image in enumerate(images):
        path = folder / f"replica-{k}.pfm"
        height, width, _ = image.shape
        with open(path, "wb") as out:
            out.write(f"PF\n{width} {height}\n-1.0\n".encode())
            out.write(np.ascontiguousarray(image[::-1], dtype="<f4").tobytes())
        Path(f"{path}.json").write_text(json.dumps({"spp": REPLICA_SPP}))
    return str(folder / "replica-*.pfm")


def named_as_expected(named: dict | None, expected) -> bool:
    """Whether the convention a check named is the injected one (and its value, where it has
    one, within 5 %)."""
    if named is None or expected is None or named["convention"] != expected[0]:
        return False
    value, want = named["value"], expected[1]
    if want is None or value is None or isinstance(want, str):
        return True      # a filter's type is a best guess, counted apart (filter_type_right)
    return bool(np.allclose(np.atleast_1d(value), np.atleast_1d(want), rtol=0.05))


def judge(scene: str, pattern: str, alpha: float) -> dict:
    """One ``check --images`` of the replicas: verdict, p-value, the convention named, time."""
    start = time.perf_counter()
    try:
        result = check(scene, images=pattern, params={"max_depth": DEPTH}, convergence=False,
                       alpha=alpha)
    except RefsInputError as refused:      # e.g. nearly noiseless replicas judged dependent
        return {"agree": None, "p_value": None, "named": None, "refused": str(refused),
                "seconds": time.perf_counter() - start}
    named = next((hint.finding for hint in result.hints if getattr(hint, "finding", None)), None)
    return {"agree": bool(result.mean.agree), "p_value": float(result.mean.p_value),
            "named": named, "seconds": time.perf_counter() - start}


def measure(scenes, trials: int, alphas, folder: Path, log=print, injections=None) -> list[dict]:
    """Every injection (or those named) on every scene, ``trials`` times, judged at each
    level of ``alphas``."""
    injections = list(injections or INJECTIONS)
    records = []
    for scene in scenes:
        for trial in range(trials):
            start = time.perf_counter()
            needed = {INJECTIONS[name][0] for name in injections}
            rendered = {variant: (centre_replicas if variant in CENTRE_VARIANTS
                                  else mitsuba_replicas)(scene, variant, trial)
                        for variant in needed}
            render_seconds = time.perf_counter() - start
            for name in injections:
                variant, inject, expected = INJECTIONS[name]
                images = rendered[variant] if inject is None else inject(rendered[variant])
                pattern = write_replicas(folder / scene / str(trial) / name.replace("/", "_"), images)
                for alpha in alphas:
                    record = judge(scene, pattern, alpha)
                    record.update(scene=scene, trial=trial, injection=name, alpha=alpha,
                                  expected=None if expected is None else list(expected[:1]),
                                  correct=named_as_expected(record["named"], expected))
                    if expected is not None and isinstance(expected[1], str):
                        record["filter_type_right"] = bool(
                            record["correct"] and record["named"]["value"] == expected[1])
                    records.append(record)
            log(f"{scene} trial {trial}: rendered in {render_seconds:.1f} s, "
                f"{sum(r['seconds'] for r in records if r['scene'] == scene and r['trial'] == trial):.1f} s of checks")
    return records


#: The columns of the JSON's rows, one row per check (rows, not objects: 1500 checks).
COLUMNS = ("scene", "injection", "trial", "alpha", "agree", "p_value", "named", "named_value",
           "named_p_value", "chi_square_before", "chi_square_after", "correct", "refused",
           "filter_type_right", "seconds")


def _rounded(value):
    """Four significant digits."""
    if isinstance(value, float):
        return float(f"{value:.4g}")
    if isinstance(value, (list, tuple)):
        return [_rounded(v) for v in value]
    return value


def rows(records) -> list[list]:
    """The records as rows of :data:`COLUMNS`."""
    out = []
    for r in records:
        named = r["named"] or {}
        flat = dict(r, named=named.get("convention"), named_value=named.get("value"),
                    named_p_value=named.get("p_value"),
                    chi_square_before=named.get("chi_square_before"),
                    chi_square_after=named.get("chi_square_after"), refused=r.get("refused"),
                    filter_type_right=r.get("filter_type_right"))
        out.append(_rounded([flat[c] for c in COLUMNS]))
    return out


def table(records, alpha: float) -> str:
    """The markdown table of docs/external.md: per injection, checks, disagreements, correct
    names, wrong names (a convention named that was not injected), mean seconds per check;
    "refused": checks that stopped with an input error (replicas judged dependent)."""
    lines = ["| injected | scene | checks | refused | mean disagrees | named correctly | named wrongly | s/check |",
             "|---|---|---|---|---|---|---|---|"]
    for name, (_, _, expected) in INJECTIONS.items():
        for scene in sorted({r["scene"] for r in records}):
            rows = [r for r in records if r["injection"] == name and r["scene"] == scene
                    and r["alpha"] == alpha]
            if not rows:
                continue
            wrong = sum(1 for r in rows if r["named"] is not None and not r["correct"])
            right = sum(1 for r in rows if r["correct"])
            seconds = sum(r["seconds"] for r in rows) / len(rows)
            disagree = sum(1 for r in rows if r["agree"] is False)
            refused = sum(1 for r in rows if r.get("refused"))
            lines.append(f"| {name} | {scene} | {len(rows)} | {refused} | {disagree} | "
                         f"{right if expected else '–'} | {wrong} | {seconds:.2f} |")
    return "\n".join(lines)


def merged(old: dict, new: dict, injections) -> dict:
    """``old``'s rows of the injections not measured again, then ``new``'s; each run's
    CPU, seconds and injections listed under ``runs``."""
    at = COLUMNS.index("injection")
    kept = [row for row in old["rows"] if row[at] not in injections]
    runs = old.get("runs") or [{"cpu": old["cpu"], "seconds": old["seconds"],
                                "trials": old["trials"], "injections": "all"}]
    runs.append({"cpu": new["cpu"], "seconds": new["seconds"], "trials": new["trials"],
                 "injections": list(injections)})
    return dict(old, rows=kept + new["rows"], runs=runs)


def main(argv=None) -> int:
    """The command line: measure, write the JSON, print the tables."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=10)
    parser.add_argument("--scenes", nargs="+", default=list(SCENES), choices=list(SCENES))
    parser.add_argument("--alpha", type=float, nargs="+", default=[1e-3])
    parser.add_argument("--json", type=Path, default=ROOT / "docs/data/conventions_measure.json")
    parser.add_argument("--injections", nargs="+", choices=list(INJECTIONS), metavar="NAME",
                        help="measure these only; their rows replace theirs in an existing "
                             "--json, the others are kept")
    args = parser.parse_args(argv)
    if args.trials * REPLICAS >= 127:
        parser.error("at most 15 trials: seeds beyond 127 x 8192 repeat on a 64 x 64 film")
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="conventions-") as folder:
        records = measure(args.scenes, args.trials, args.alpha, Path(folder),
                          injections=args.injections)
    seconds = time.perf_counter() - start
    for alpha in args.alpha:      # first: the tables survive a failure to write the file
        print(f"\nalpha = {alpha:g}\n" + table(records, alpha))
    args.json.parent.mkdir(parents=True, exist_ok=True)
    document = {"cpu": cpu_name(), "seconds": seconds, "trials": args.trials,
                "replicas": REPLICAS, "replica_spp": REPLICA_SPP, "max_depth": DEPTH,
                "columns": COLUMNS, "rows": rows(records)}
    if args.injections and args.json.exists():
        document = merged(json.loads(args.json.read_text()), document, args.injections)
    args.json.write_text(json.dumps(document, separators=(",", ":")).replace("],[", "],\n[") + "\n")
    print(f"\n{len(records)} checks in {seconds:.0f} s on {cpu_name()}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
