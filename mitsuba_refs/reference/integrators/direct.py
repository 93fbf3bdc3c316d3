r"""
Direct illumination: our ``direct`` maps onto Mitsuba's own ``direct`` plugin.

Mitsuba's ``direct`` integrator with ``emitter_samples = 1`` and
``bsdf_samples = 1`` computes, at the first visible surface point :math:`x`,

.. math::

    \langle L \rangle = L_e(x) +
        w_e\, \frac{f_s\, |\cos\theta_e|\, L_e\, V}{p_e(\omega_e)} +
        w_b\, \frac{f_s\, |\cos\theta_b|\, L_e}{p_b(\omega_b)},
    \qquad w_e, w_b: \text{power heuristic},

one emitter sample and one BSDF sample combined by MIS, which is the
lecture's ``direct`` estimator. No custom integrator is needed: this module
only names the mapping so that :mod:`mitsuba_refs.reference.render` and the docs agree.
"""


def mitsuba_direct_dict(hide_emitters=False):
    """Integrator dictionary of Mitsuba's ``direct`` as used for references."""
    return {"type": "direct", "emitter_samples": 1, "bsdf_samples": 1,
            "hide_emitters": bool(hide_emitters)}
