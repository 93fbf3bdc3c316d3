r"""Reusable chi-square goodness-of-fit tests for sampling routines.

A sampling routine and the density it claims are consistent when the
histogram of many samples matches the integral of the density over each
histogram cell. This module bins samples, integrates the density over the
same cells numerically, pools cells with small expected counts and applies
Pearson's test (:func:`scipy.stats.chisquare`).

Domains
-------
* :func:`chi2_sphere` -- unit directions, cells in :math:`(\cos\theta, \phi)`
  around an arbitrary ``axis`` (a rotation preserves solid angle, so cells
  can be centred on a narrow lobe); ``z_power > 1`` makes the
  :math:`\cos\theta` rings finer near the axis. Samples flagged invalid go to
  an extra cell whose expected mass is :math:`1 - \int p\,d\omega`, so a
  density that integrates to less than one (a BSDF that rejects some
  samples) is tested exactly.
* :func:`chi2_plane` -- points of a rectangle (disk and triangle warps).

False-failure budget
--------------------
Every test runs at the suite's per-test level :data:`ALPHA` (1e-3 / MAX_STATISTICAL_TESTS, from
tests/budget.py): a *correct* sampler fails a given test with probability at
most ALPHA, and tests/test_budget.py checks that all the suite's statistical
assertions together stay below 0.1 % (Bonferroni). All tests use fixed seeds,
so a given run is reproducible. Numerical integration errors of the
expected counts are kept far below the statistical noise by sub-sampling
every cell on a fine midpoint grid.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

from tests.budget import ALPHA  # the suite's per-test level

MIN_EXPECTED = 5.0


@dataclass
class Chi2Result:
    """Outcome of a chi-square test.

    Attributes
    ----------
    statistic, p_value : float
    dof : int
        Degrees of freedom (pooled cells - 1).
    passed : bool
        ``p_value >= alpha``.
    message : str
        Summary with the worst cells, for assertion messages.
    """

    statistic: float
    p_value: float
    dof: int
    passed: bool
    message: str


def _split(result):
    """Accept ``points`` or ``(points, valid)`` from a sampling callback."""
    if isinstance(result, tuple):
        points, valid = result
        return np.asarray(points, dtype=np.float64), np.asarray(valid, dtype=bool)
    points = np.asarray(result, dtype=np.float64)
    return points, np.ones(points.shape[0], dtype=bool)


def chi2_from_counts(observed: np.ndarray, expected: np.ndarray, alpha: float = ALPHA,
                     min_expected: float = MIN_EXPECTED, labels=None) -> Chi2Result:
    """Pearson test of cell counts after pooling cells with small expectations.

    Cells whose expected count is below ``min_expected`` are pooled into one
    cell (if that pool is still too small it joins the smallest remaining
    cell). ``expected`` is rescaled to the observed total, as
    :func:`scipy.stats.chisquare` requires; a sample in a cell of zero
    expectation therefore makes the test fail.
    """
    observed = np.asarray(observed, dtype=np.float64).ravel()
    expected = np.maximum(np.asarray(expected, dtype=np.float64).ravel(), 0.0)
    total = observed.sum()
    expected = expected * (total / expected.sum())

    small = expected < min_expected
    obs = list(observed[~small])
    exp = list(expected[~small])
    if small.any():
        pool_o, pool_e = observed[small].sum(), expected[small].sum()
        if pool_e < min_expected and exp:
            k = int(np.argmin(exp))
            obs[k] += pool_o
            exp[k] += pool_e
        else:
            obs.append(pool_o)
            exp.append(pool_e)
    obs, exp = np.array(obs), np.array(exp)
    if obs.size < 2:
        return Chi2Result(0.0, 1.0, 0, True, "a single cell: nothing to test")
    if np.any((exp <= 0) & (obs > 0)):
        return Chi2Result(np.inf, 0.0, obs.size - 1, False, "samples where the density is zero")

    statistic, p_value = stats.chisquare(obs, exp)
    contrib = (obs - exp) ** 2 / exp
    worst = np.argsort(contrib)[::-1][:5]
    lines = [f"chi2 = {statistic:.1f}, dof = {obs.size - 1}, p = {p_value:.3g} (alpha = {alpha:g})"]
    lines += [f"  cell {k}: observed {obs[k]:.0f}, expected {exp[k]:.1f}" for k in worst]
    return Chi2Result(float(statistic), float(p_value), obs.size - 1, bool(p_value >= alpha),
                      "\n".join(lines))


# --------------------------------------------------------------------------
# Sphere
# --------------------------------------------------------------------------

def _frame(axis) -> np.ndarray:
    """Rows s, t, n of an orthonormal frame with n = normalize(axis)."""
    n = np.asarray(axis, dtype=np.float64)
    n = n / np.linalg.norm(n)
    helper = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    s = np.cross(helper, n)
    s /= np.linalg.norm(s)
    return np.stack((s, np.cross(n, s), n))


def _z_edges(res_z: int, z_power: float) -> np.ndarray:
    """Increasing cos(theta) edges from -1 to 1, finer near +1 when ``z_power > 1``."""
    t = np.linspace(0.0, 1.0, res_z + 1) ** z_power
    return (1.0 - 2.0 * t)[::-1]


def _integrate_sphere(pdf, frame: np.ndarray, z_edges: np.ndarray, res_phi: int, subdiv) -> np.ndarray:
    r"""Integral of ``pdf`` over every (z, phi) cell: midpoint rule on a grid of sub-cells.

    :math:`d\omega = dz\,d\phi`, so the cell integral is a plain 2-D
    integral; ``subdiv = (sz, sphi)`` sub-cells per cell. The midpoint rule
    is exact for densities linear in z; near a discontinuity that crosses a
    cell its error is at most the mass of one strip of sub-cells.
    """
    sub_z, sub_phi = (subdiv, subdiv) if np.isscalar(subdiv) else subdiv
    res_z = z_edges.size - 1
    phi_edges = np.linspace(0.0, 2.0 * np.pi, res_phi + 1)
    frac_z = (np.arange(sub_z) + 0.5) / sub_z
    frac_phi = (np.arange(sub_phi) + 0.5) / sub_phi
    dphi = (phi_edges[1] - phi_edges[0]) / sub_phi
    phi = (phi_edges[:-1, None] + (phi_edges[1] - phi_edges[0]) * frac_phi[None, :]).ravel()
    result = np.empty((res_z, res_phi))
    for i in range(res_z):
        z = z_edges[i] + (z_edges[i + 1] - z_edges[i]) * frac_z
        dz = (z_edges[i + 1] - z_edges[i]) / sub_z
        zz, pp = np.meshgrid(z, phi, indexing="ij")
        r = np.sqrt(np.maximum(1.0 - zz ** 2, 0.0))
        local = np.stack((r * np.cos(pp), r * np.sin(pp), zz), axis=-1).reshape(-1, 3)
        values = np.asarray(pdf(local @ frame), dtype=np.float64).reshape(sub_z, res_phi, sub_phi)
        result[i] = values.sum(axis=(0, 2)) * dz * dphi
    return result


def chi2_sphere(sample, pdf, n_samples: int = 200_000, res=(10, 20), axis=(0.0, 0.0, 1.0),
                z_power: float = 1.0, subdiv=(64, 32), seed: int = 0, alpha: float = ALPHA,
                min_expected: float = MIN_EXPECTED, z_edges=None) -> Chi2Result:
    r"""Chi-square test of a direction sampler against its solid-angle density.

    Parameters
    ----------
    sample : callable
        ``sample(u)`` with ``u`` an (n, 3) array of uniform numbers returns
        directions (n, 3), or ``(directions, valid)``; invalid samples are
        counted in a separate cell of expected mass :math:`1 - \int p`.
    pdf : callable
        ``pdf(directions)`` -> (m,) solid-angle density of valid samples.
    n_samples : int
    res : (int, int)
        Number of cells in :math:`\cos\theta` and :math:`\phi`.
    axis : (3,) array_like
        Pole of the binning frame (e.g. the mirror direction of a lobe).
    z_power : float
        > 1 concentrates the :math:`\cos\theta` rings near ``axis``.
    z_edges : array_like, optional
        Explicit increasing ring edges from -1 to 1 (overrides ``res[0]``
        and ``z_power``), e.g. to resolve a lobe squeezed against the horizon.
    subdiv : int or (int, int)
        Midpoint sub-cells per cell in z and phi for the integration. Keep
        support boundaries (e.g. the horizon of a one-sided BSDF) on cell
        edges where possible: with ``axis`` = +z, an even ``res[0]`` and
        ``z_power = 1``, z = 0 is an edge.
    seed : int
        Seed of the uniform numbers (fixed: reproducible runs).
    alpha : float
        Significance level, :data:`ALPHA` (the suite's per-test level) by default.
    """
    rng = np.random.default_rng(seed)
    points, valid = _split(sample(rng.random((n_samples, 3))))
    frame = _frame(axis)
    local = points[valid] @ frame.T
    if z_edges is None:
        z_edges = _z_edges(res[0], z_power)
    z_edges = np.asarray(z_edges, dtype=np.float64)
    res = (z_edges.size - 1, res[1])
    zi = np.clip(np.searchsorted(z_edges, local[:, 2], side="right") - 1, 0, res[0] - 1)
    phi = np.mod(np.arctan2(local[:, 1], local[:, 0]), 2.0 * np.pi)
    pi_ = np.clip((phi / (2.0 * np.pi) * res[1]).astype(np.int64), 0, res[1] - 1)
    observed = np.bincount(zi * res[1] + pi_, minlength=res[0] * res[1]).astype(np.float64)

    mass = _integrate_sphere(pdf, frame, z_edges, res[1], subdiv).ravel()
    expected = mass * n_samples
    null_expected = max(n_samples * (1.0 - mass.sum()), 0.0)
    observed = np.append(observed, np.count_nonzero(~valid))
    expected = np.append(expected, null_expected)
    return chi2_from_counts(observed, expected, alpha=alpha, min_expected=min_expected)


# --------------------------------------------------------------------------
# Plane
# --------------------------------------------------------------------------

def chi2_plane(sample, pdf, bounds=((-1.0, 1.0), (-1.0, 1.0)), n_samples: int = 200_000,
               res=(16, 16), subdiv: int = 32, seed: int = 0, alpha: float = ALPHA,
               min_expected: float = MIN_EXPECTED) -> Chi2Result:
    """Chi-square test of a sampler of 2-D points against its area density on a rectangle.

    ``sample(u)`` with ``u`` an (n, 2) array returns (n, 2) points; ``pdf``
    maps (m, 2) points to densities. Points outside ``bounds`` fail the test.
    """
    rng = np.random.default_rng(seed)
    points, valid = _split(sample(rng.random((n_samples, 2))))
    (x0, x1), (y0, y1) = bounds
    ix = np.floor((points[:, 0] - x0) / (x1 - x0) * res[0]).astype(np.int64)
    iy = np.floor((points[:, 1] - y0) / (y1 - y0) * res[1]).astype(np.int64)
    inside = valid & (ix >= 0) & (ix < res[0]) & (iy >= 0) & (iy < res[1])
    observed = np.bincount(ix[inside] * res[1] + iy[inside], minlength=res[0] * res[1]).astype(np.float64)

    fx = (np.arange(res[0] * subdiv) + 0.5) / (res[0] * subdiv)
    fy = (np.arange(res[1] * subdiv) + 0.5) / (res[1] * subdiv)
    gx, gy = np.meshgrid(x0 + (x1 - x0) * fx, y0 + (y1 - y0) * fy, indexing="ij")
    values = np.asarray(pdf(np.stack((gx.ravel(), gy.ravel()), axis=1))).reshape(res[0], subdiv, res[1], subdiv)
    cell_area = (x1 - x0) * (y1 - y0) / (res[0] * res[1] * subdiv * subdiv)
    expected = values.sum(axis=(1, 3)).ravel() * cell_area * n_samples

    observed = np.append(observed, np.count_nonzero(~inside))
    expected = np.append(expected, max(n_samples - expected.sum(), 0.0))
    return chi2_from_counts(observed, expected, alpha=alpha, min_expected=min_expected)
