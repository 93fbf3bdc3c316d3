"""Tail probability of the maximum of correlated |normal|s (C <= 3), by nested Gauss-Legendre."""
from __future__ import annotations

import math

import numpy as np
from scipy import special

__all__ = ["p_max_abs", "correlation_from_differences"]

_NODES, _WEIGHTS = np.polynomial.legendre.leggauss(128)


def _tail(x):
    """Upper normal tail Φc(x) = P(Z >= x)."""
    return 0.5 * special.erfc(x / math.sqrt(2.0))


def _phi(x):
    return np.exp(-0.5 * x * x) / math.sqrt(2.0 * math.pi)


def _gl(a, b):
    """Nodes and weights mapping the reference rule onto [a, b] (a, b may be arrays)."""
    a = np.asarray(a, dtype=np.float64)[..., None]
    b = np.asarray(b, dtype=np.float64)[..., None]
    half = 0.5 * (b - a)
    return 0.5 * (a + b) + half * _NODES, half * _WEIGHTS


def p_max_abs(t: float, R: np.ndarray) -> float:
    r"""P(max_c |Z_c| >= t) for Z ~ N(0, R), R a C x C correlation matrix, C <= 3.

    Written as P(|Z_1|>=t) + P(|Z_1|<t, |Z_2|>=t) + P(|Z_1|<t, |Z_2|<t, |Z_3|>=t) with
    Z = L g (Cholesky), each term an integral of upper tails (keeps relative precision far
    in the tail).  For C > 3 the Bonferroni bound C * P(|Z|>=t) is returned.
    """
    t = float(abs(t))
    if not math.isfinite(t):
        return 0.0
    C = R.shape[0]
    p1 = float(special.erfc(t / math.sqrt(2.0)))
    if C == 1 or t == 0.0:
        return p1 if C == 1 else 1.0
    if C > 3:
        return min(1.0, C * p1)
    R = np.array(R, dtype=np.float64)
    R = 0.999 * R + 0.001 * np.eye(C)        # keep the Cholesky factor well conditioned
    L = np.linalg.cholesky(R)
    g1, w1 = _gl(-t, t)                        # shapes (128,)
    l21, l22 = L[1, 0], L[1, 1]
    m2 = l21 * g1
    p2 = float(np.sum(w1 * _phi(g1) * (_tail((t - m2) / l22) + _tail((t + m2) / l22))))
    if C == 2:
        return min(1.0, p1 + p2)
    l31, l32, l33 = L[2, 0], L[2, 1], L[2, 2]
    lo = (-t - m2) / l22
    hi = (t - m2) / l22
    g2, w2 = _gl(lo, hi)                       # (128, 128): row = g1 node
    m3 = l31 * g1[:, None] + l32 * g2
    inner = np.sum(w2 * _phi(g2) * (_tail((t - m3) / l33) + _tail((t + m3) / l33)), axis=1)
    p3 = float(np.sum(w1 * _phi(g1) * inner))
    return min(1.0, p1 + p2 + p3)


def correlation_from_differences(d: np.ndarray) -> np.ndarray:
    r"""Channel correlation of zero-mean noise from per-pixel differences d (N, C):
    :math:`\hat\rho_{cd} = \sum_p d_{pc} d_{pd} / \sqrt{\sum_p d_{pc}^2 \sum_p d_{pd}^2}`
    (uncentred: under the null every pixel difference has mean 0).  Channels with no
    variation get correlation 0 with the others."""
    C = d.shape[1]
    S = d.T @ d
    diag = np.sqrt(np.diag(S))
    with np.errstate(divide="ignore", invalid="ignore"):
        R = S / np.outer(diag, diag)
    R = np.where(np.isfinite(R), R, 0.0)
    R[np.diag_indices(C)] = 1.0
    # nearest valid correlation matrix (clip negative eigenvalues)
    lam, V = np.linalg.eigh(R)
    if lam.min() < 1e-9:
        lam = np.maximum(lam, 1e-9)
        R = (V * lam) @ V.T
        s = np.sqrt(np.diag(R))
        R = R / np.outer(s, s)
    return R
