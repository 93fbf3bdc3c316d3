r"""
Path tracer with next-event estimation and no MIS (``lecture_path_nee``).

At every vertex with a smooth (non-delta) BSDF component a shadow ray is sent
to a point sampled on an emitter; the path itself continues by BSDF sampling.
To avoid counting direct light twice, emission found by the continuing path
is only added where no shadow ray could have found it: on camera rays and
after a delta (mirror, glass) bounce.

Estimator (one sample):

.. math::

    \langle L \rangle = \sum_{k=1}^{K}
      \beta_{k-1} \Big(
        [\,k = 1 \lor \text{delta}_{k-1}\,]\; L_e(x_k, -\omega_{k-1})
        + [\,x_k \text{ smooth}\,]\;
          \frac{f_s(x_k, \omega_{k-1}, \omega_e)\,|\cos\theta_e|\,
                L_e(y, -\omega_e)\, V(x_k, y)}{p_e(\omega_e)}
      \Big)

with :math:`y` drawn by ``scene.sample_emitter_direction`` (an emitter chosen
uniformly, then a point on it; :math:`p_e` is the solid-angle density of the
whole choice, infinite for point lights where the ratio is
:math:`I / r^2`), weight one (no MIS), and :math:`\beta` the throughput
with Russian roulette exactly as in :mod:`.path_bsdf` / Mitsuba's ``path``.

Like ``path``, emitter sampling is only done when the path may continue
(``depth + 1 < max_depth``): ``max_depth = 2`` is direct lighting.
"""

import drjit as dr
import mitsuba as mi

from ._common import LectureIntegrator, emitted, is_scalar


class PathNEEIntegrator(LectureIntegrator):
    """Next-event-estimation path tracer without MIS (see module docstring)."""

    NAME = "lecture_path_nee"

    def sample(self, scene, sampler, ray, medium=None, active=True):
        bsdf_ctx = mi.BSDFContext()
        scalar = is_scalar()
        hide = self.hide_emitters

        ray = mi.Ray3f(ray)
        active = mi.Bool(active)
        pi = self.first_intersection(scene, ray, active)
        valid_ray = mi.Bool((not hide) and scene.environment() is not None)

        def body(ray, pi, depth, L, beta, eta, prev_delta, valid_ray, active,
                 sampler):
            si = pi.compute_surface_interaction(ray, mi.RayFlags.All)

            # ---- emission: only on camera rays and after delta bounces ----
            visible = si.is_valid() | (depth != 0) | (not hide)
            count = active & visible & prev_delta
            L = dr.select(count, L + beta * emitted(scene, si, count), L)
            valid_ray |= active & si.is_valid()

            active_next = active & (depth + 1 < self.max_depth) & si.is_valid()
            if scalar and not active_next:
                return (ray, pi, depth, L, beta, eta, prev_delta, valid_ray,
                        False, sampler)

            bsdf = si.bsdf(ray)

            # ------------- emitter sampling, weight one (no MIS) ----------
            active_em = active_next & mi.has_flag(bsdf.flags(),
                                                  mi.BSDFFlags.Smooth)
            ds, em_weight = scene.sample_emitter_direction(
                si, sampler.next_2d(active_next), True, active_em)
            active_em &= ds.pdf != 0
            wo = si.to_local(ds.d)
            bsdf_val = bsdf.eval(bsdf_ctx, si, wo, active_em)
            L = dr.select(active_em, L + beta * bsdf_val * em_weight, L)

            # ----------------------- BSDF sampling ------------------------
            bs, bsdf_weight = bsdf.sample(bsdf_ctx, si,
                                          sampler.next_1d(active_next),
                                          sampler.next_2d(active_next),
                                          active_next)
            beta = dr.select(active_next, beta * bsdf_weight, beta)
            eta = dr.select(active_next, eta * bs.eta, eta)
            ray = dr.select(active_next, si.spawn_ray(si.to_world(bs.wo)), ray)
            prev_delta = dr.select(
                active_next,
                mi.has_flag(bs.sampled_type, mi.BSDFFlags.Delta), prev_delta)

            # ------------------ roulette (Mitsuba's rule) -----------------
            depth = dr.select(active & si.is_valid(), depth + 1, depth)
            beta_max = dr.max(mi.unpolarized_spectrum(beta))
            q = dr.minimum(beta_max * dr.square(eta), 0.95)
            rr_active = depth >= self.rr_depth
            rr_continue = sampler.next_1d(active_next) < q
            beta = dr.select(active_next & rr_active, beta * dr.rcp(q), beta)
            active = active_next & ((depth < self.rr_depth) | rr_continue) & (beta_max != 0)

            pi = scene.ray_intersect_preliminary(ray, coherent=False,
                                                 active=active)
            return (ray, pi, depth, L, beta, eta, prev_delta, valid_ray,
                    active, sampler)

        state = (ray, pi, mi.UInt32(0), mi.Spectrum(0), mi.Spectrum(1),
                 mi.Float(1), mi.Bool(True), valid_ray, active, sampler)
        state = dr.while_loop(state, lambda *s: s[8], body, label=self.NAME)
        L, valid_ray = state[3], state[7]
        return dr.select(valid_ray, L, 0), valid_ray, []
