r"""
Path tracer with BSDF sampling only (``lecture_path_bsdf``).

The lecture's first unbiased path tracer: directions are drawn from the BSDF
alone and emission is picked up wherever a path happens to hit an emitter.
No shadow rays, no multiple importance sampling.

Estimator (one sample, path :math:`x_0 \to x_1 \to \dots`):

.. math::

    \langle L \rangle = \sum_{k=1}^{K} \beta_{k-1}\, L_e(x_k, -\omega_{k-1}),
    \qquad
    \beta_0 = 1,\quad
    \beta_k = \beta_{k-1}\,
              \frac{f_s(x_k, \omega_{k-1}, \omega_k)\,|\cos\theta_k|}
                   {p(\omega_k)\, q_k}

where :math:`q_k` is the Russian roulette survival probability
(:math:`q_k = 1` while ``depth < rr_depth``, otherwise
:math:`q_k = \min(\max_c \beta_k \eta^2, 0.95)` with the throughput already
holding the current BSDF weight, as in Mitsuba's ``path``) and
:math:`K \le` ``max_depth`` is the number of vertices reached.

Conventions shared with Mitsuba's ``path`` plugin:

- ``max_depth`` counts path vertices: 1 = emitters seen directly,
  2 = one bounce (direct lighting, here found by BSDF sampling only),
  -1 = unbounded (the path ends by roulette, on a miss, or when the
  throughput becomes zero). Emission at the last vertex counts.
- ``rr_depth``: roulette starts once ``depth >= rr_depth``.
- ``hide_emitters``: camera rays pass through directly visible area emitters
  and miss the environment.

Because every emitter hit is counted with weight one, point lights (which no
ray can hit) contribute nothing: this estimator is only correct for scenes
without delta-position emitters. That is a property of the algorithm, not a
bug.
"""

import drjit as dr
import mitsuba as mi

from ._common import LectureIntegrator, emitted, is_scalar


class PathBSDFIntegrator(LectureIntegrator):
    """BSDF-sampling-only path tracer (see module docstring)."""

    NAME = "lecture_path_bsdf"

    def sample(self, scene, sampler, ray, medium=None, active=True):
        bsdf_ctx = mi.BSDFContext()
        scalar = is_scalar()
        hide = self.hide_emitters

        ray = mi.Ray3f(ray)
        active = mi.Bool(active)
        pi = self.first_intersection(scene, ray, active)
        # A camera ray that sees only a hidden environment is invalid (alpha).
        valid_ray = mi.Bool((not hide) and scene.environment() is not None)

        def body(ray, pi, depth, L, beta, eta, valid_ray, active, sampler):
            si = pi.compute_surface_interaction(ray, mi.RayFlags.All)

            # ---------------- emission, always weight one -----------------
            visible = si.is_valid() | (depth != 0) | (not hide)
            L = dr.select(active & visible,
                          L + beta * emitted(scene, si, active), L)
            valid_ray |= active & si.is_valid()

            active_next = active & (depth + 1 < self.max_depth) & si.is_valid()
            if scalar and not active_next:
                return ray, pi, depth, L, beta, eta, valid_ray, False, sampler

            # ----------------------- BSDF sampling ------------------------
            bsdf = si.bsdf(ray)
            bs, bsdf_weight = bsdf.sample(bsdf_ctx, si, sampler.next_1d(active_next),
                                          sampler.next_2d(active_next), active_next)
            beta = dr.select(active_next, beta * bsdf_weight, beta)
            eta = dr.select(active_next, eta * bs.eta, eta)
            ray = dr.select(active_next, si.spawn_ray(si.to_world(bs.wo)), ray)

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
            return ray, pi, depth, L, beta, eta, valid_ray, active, sampler

        state = (ray, pi, mi.UInt32(0), mi.Spectrum(0), mi.Spectrum(1),
                 mi.Float(1), valid_ray, active, sampler)
        state = dr.while_loop(state, lambda *s: s[7], body,
                              label=self.NAME)
        L, valid_ray = state[3], state[6]
        return dr.select(valid_ray, L, 0), valid_ray, []
