"""The reconstruction filter of a reference's film, and what it changes in its statistics.

Mitsuba's ``hdrfilm`` splats every sample over the pixels within its filter's radius
and divides by the summed weights; with the ``rgb_moments`` AOVs the developed film
then holds, per pixel, ``m1 = sum w f / sum w`` and ``m2 = sum w f^2 / sum w``. The
tracer's film does the same (:mod:`pathtracer.sensors.film`), and both sides turn the weighted
spread ``m2 - m1^2`` into a per-sample variance with the same effective sample count
(:func:`pathtracer.sensors.film.effective_counts`); docs/statistics.md ("Reconstruction
filters") says what the tests then assume.

Mitsuba's scalar variants evaluate tent and gaussian weights from a 31-entry table,
which moves pixel values at sharp edges by up to 0.4 % (tent) / 0.8 % (gaussian) of the
edge's contrast; the tracer follows the exact weights of the vectorised variants. So a
filtered reference comes either from a vectorised variant's film, or, in ``scalar_rgb``,
from single samples at known positions splatted by NumPy with the exact weights
(:mod:`mitsuba_refs.reference.filtered`): the same ``m1``, ``m2`` either way.
"""

from pathtracer.render.moments import variance_from_power_means
from pathtracer.sensors.film import ReconstructionFilter, effective_counts

#: Mitsuba filter class name -> our filter name
_KINDS = {"BoxFilter": "box", "TentFilter": "tent", "GaussianFilter": "gaussian"}


def film_filter(film):
    """The :class:`pathtracer.sensors.film.ReconstructionFilter` of a loaded Mitsuba film.

    Raises ``ValueError`` for filters the tracer does not implement.
    """
    rfilter = film.rfilter()
    name = str(rfilter).split("[")[0].strip()
    kind = _KINDS.get(name)
    if kind is None:
        raise ValueError(f"film reconstruction filter {name} is not supported "
                         f"(supported: {', '.join(sorted(_KINDS.values()))})")
    radius = float(rfilter.radius())
    # The film's sample_border (a box filter has no border: the tracer keeps it False).
    border = bool(film.sample_border()) and kind != "box"
    if kind == "gaussian":
        return ReconstructionFilter.make("gaussian", round(radius / 4.0, 6), border)
    return ReconstructionFilter.make(kind, round(radius, 6), border)


def check_variant(variant, rfilter, route):
    """Refuse a scalar variant's own film for a tent or gaussian filter (its weights are
    tabulated) on ``route``, a route that would use it (the ``rgb_moments`` wrapper, a
    camera inside a medium); the ``batch`` method (:mod:`mitsuba_refs.reference.filtered`) splats
    with the exact weights instead."""
    if not rfilter.is_box and variant.startswith("scalar"):
        raise ValueError(f"a {rfilter.describe()} film with {route} needs a vectorised "
                         f"Mitsuba variant (e.g. llvm_ad_rgb): {variant}'s film tabulates the "
                         "filter weights, which moves edge pixels by up to 0.8 % of the "
                         "edge's contrast")


def filter_metadata(rfilter):
    """JSON-able description of the filter for the reference's metadata."""
    border = {"sample_border": True} if rfilter.sample_border else {}
    if rfilter.kind == "gaussian":
        return {"type": "gaussian", "stddev": rfilter.stddev, **border}
    return {"type": rfilter.kind, "radius": rfilter.radius, **border}


def filter_from_metadata(metadata):
    """The filter recorded in a reference's metadata (box when none is recorded)."""
    spec = (metadata or {}).get("rfilter") or {"type": "box"}
    value = spec.get("stddev", spec.get("radius"))
    return ReconstructionFilter.make(spec["type"], value, bool(spec.get("sample_border", False)))


def per_sample_variance(m1, m2, n, rfilter):
    """Unbiased per-sample variance from filtered moments: ``(m2 - m1^2) n_eff / (n_eff - 1)``.

    ``n_eff`` is each pixel's effective sample count; for the box filter it is ``n`` and
    this is :func:`pathtracer.render.moments.variance_from_power_means` with ``n``.
    """
    if n < 2:
        raise ValueError("variance needs at least 2 samples per pixel")
    height, width = m1.shape[:2]
    n_eff = effective_counts(rfilter, width, height, n)[..., None]
    return variance_from_power_means(m1, m2, n_eff)


def reference_correlation(reference):
    """How the reference's film filter correlates pixels (:mod:`mitsuba_refs.stats.correlation`)."""
    # SciPy's statistics (~0.3 s) load inside mitsuba-refs' main, where a Ctrl-C is caught.
    from ..stats.correlation import pixel_correlation
    return pixel_correlation(filter_from_metadata(getattr(reference, "metadata", None)))


def pixel_value_counts(reference):
    """Per-pixel counts ``n_eff`` (H, W) with ``var / n_eff`` the variance of a pixel's value.

    ``reference.n`` everywhere for the box filter; with a wider filter ``var / n`` is a
    pixel's covariance row sum, and its own variance is the smaller ``var / n_eff``.
    """
    height, width = reference.mean.shape[:2]
    rfilter = filter_from_metadata(getattr(reference, "metadata", None))
    return effective_counts(rfilter, width, height, reference.n)
