"""Helpers of the light-pdf mutants: the pieces of the solid-angle pdf p = d^2 / (|cos_l| A)."""
import numpy as np

from pathtracer.vec import dot


def light_cosine(scene, sample, u_choice, emitter=None):
    """|cos theta| at the sampled light point, recovered from p = d^2 / (|cos| A N)."""
    n = scene.num_emitters
    which = (np.full(len(u_choice), emitter) if emitter is not None
             else np.minimum((u_choice * n).astype(np.int64), n - 1))
    area = np.array([scene.shape_area[e.shape] if e.kind == "area" else np.nan
                     for e in scene.emitters])[which]
    scale = 1.0 if emitter is not None else n
    with np.errstate(divide="ignore", invalid="ignore"):
        cos = sample.dist ** 2 / (sample.pdf * area * scale)
    return np.where(np.isfinite(cos) & (sample.pdf > 0), np.clip(cos, 1e-12, 1.0), 1.0)


def area_rows(sample):
    return ~sample.delta & np.isfinite(sample.dist) & (sample.pdf > 0)


def scale_sample(sample, factor):
    """Multiply the pdf by ``factor`` (so divide the weight) where the sample is an area light."""
    rows = area_rows(sample)
    f = np.where(rows, factor, 1.0)
    sample.pdf = sample.pdf * f
    sample.weight = sample.weight / f[:, None]
    return sample


def hit_distance2(ref_p, hit):
    d = hit.p - ref_p
    return dot(d, d)


def hit_cosine(hit, d):
    return np.clip(np.abs(dot(hit.n, d)), 1e-12, 1.0)
