r"""
Per-pixel first and second moments of any nested integrator, in RGB.

Mitsuba's ``moment`` integrator reports moments in XYZ only. This wrapper
(registered as ``rgb_moments``) calls the nested integrator once per camera
sample and returns, besides the nested radiance :math:`L`, six AOVs

.. math::

    \texttt{m1.R},\ \texttt{m1.G},\ \texttt{m1.B} = L_c, \qquad
    \texttt{m2.R},\ \texttt{m2.G},\ \texttt{m2.B} = L_c^2 .

With a box reconstruction filter every sample lands in its own pixel with
weight one, so the developed film holds the per-pixel sample means
:math:`\bar m_1 = \frac1n\sum L_i` and :math:`\bar m_2 = \frac1n\sum L_i^2`.
From these, the unbiased per-sample variance is

.. math::

    s^2 = \frac{n}{n-1}\left(\bar m_2 - \bar m_1^2\right),

and the variance of the pixel mean is :math:`s^2 / n`. Channels are read by
name (``m1.R`` ...), never by position. With a tent or gaussian filter the film
holds filter-weighted moments instead (:mod:`mitsuba_refs.reference.rfilter`).

Moments of several passes (independent seeds, :math:`n_j` samples each)
combine exactly: :math:`\bar m_k = \sum_j n_j \bar m_{k,j} / \sum_j n_j`.
"""

import numpy as np

MOMENT_AOVS = ("m1.R", "m1.G", "m1.B", "m2.R", "m2.G", "m2.B")
NAME = "rgb_moments"


class MomentIntegrator:
    """Wrap ``nested`` (a child integrator) and output RGB moments as AOVs.

    Made into a ``mi.SamplingIntegrator`` subclass per variant by
    :func:`register` (nanobind classes cannot take a mixin base).
    """

    def __init__(self, props):
        import mitsuba as mi
        mi.SamplingIntegrator.__init__(self, props)
        self.nested = None
        for name in props.keys():
            value = props[name]
            if isinstance(value, mi.Integrator):
                if self.nested is not None:
                    raise ValueError("rgb_moments takes exactly one nested integrator")
                self.nested = value
        if self.nested is None:
            raise ValueError("rgb_moments needs a nested integrator")

    def sample(self, scene, sampler, ray, medium=None, active=True):
        import mitsuba as mi
        spec, valid, aovs = self.nested.sample(scene, sampler, ray, medium,
                                               active)
        c = mi.Color3f(spec)
        moments = [c[0], c[1], c[2], c[0] * c[0], c[1] * c[1], c[2] * c[2]]
        return spec, valid, moments + list(aovs)

    def aov_names(self):
        return list(MOMENT_AOVS) + list(self.nested.aov_names())

    def to_string(self):
        return f"MomentIntegrator[nested={self.nested}]"


def register():
    """Register ``rgb_moments`` with the active Mitsuba variant."""
    import mitsuba as mi

    from .integrators._common import make_class
    cls = make_class(MomentIntegrator)
    mi.register_integrator(NAME, lambda props: cls(props))


def moment_dict(nested):
    """Integrator dictionary wrapping the nested integrator dictionary."""
    return {"type": NAME, "nested": dict(nested)}


def read_moments(film):
    """Return ``(m1, m2)`` float64 arrays (H, W, 3) read by channel name from
    a developed Mitsuba film rendered with :class:`MomentIntegrator`."""
    bitmap = film.bitmap()
    names = [field.name for field in bitmap.struct_()]
    data = np.array(bitmap, copy=False)
    if data.ndim == 2:
        data = data[..., None]

    def channels(prefix):
        try:
            idx = [names.index(f"{prefix}.{c}") for c in "RGB"]
        except ValueError as exc:
            raise RuntimeError(f"film lacks channel {prefix}.R/G/B "
                               f"(channels: {names})") from exc
        return data[..., idx].astype(np.float64)

    return channels("m1"), channels("m2")

