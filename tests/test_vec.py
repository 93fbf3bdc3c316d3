"""The per-component helpers of pathtracer.vec give exactly NumPy's broadcasting results."""
import numpy as np
import pytest

from pathtracer.core.vec import dot, max_component, put_rows, scale, select, unscale


@pytest.fixture
def arrays():
    rng = np.random.default_rng(2)
    a = rng.normal(size=(257, 3))
    a[5] = [np.inf, np.nan, -0.0]   # non-finite rows must come out as NumPy's would
    return a, rng.normal(size=257), rng.random(257) < 0.6, rng.normal(size=3)


def test_scale_unscale_select_equal_broadcasting(arrays):
    a, s, mask, row = arrays
    with np.errstate(invalid="ignore"):
        np.testing.assert_array_equal(scale(a, s), a * s[:, None])
        np.testing.assert_array_equal(unscale(a, s), a / s[:, None])
        np.testing.assert_array_equal(scale(row, s), row * s[:, None])   # one row for all
        np.testing.assert_array_equal(unscale(row, s), row / s[:, None])
    np.testing.assert_array_equal(select(mask, a), np.where(mask[:, None], a, 0.0))
    np.testing.assert_array_equal(select(mask, row, 1.5), np.where(mask[:, None], row, 1.5))
    assert scale(a[:, :2], s).shape == (257, 2)


def test_dot_and_max_component(arrays):
    a, s, _, _ = arrays
    b = np.roll(a, 1, axis=0)
    with np.errstate(invalid="ignore"):
        in_order = a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1] + a[:, 2] * b[:, 2]
        np.testing.assert_array_equal(dot(a, b), in_order)
        np.testing.assert_allclose(dot(a, b), np.einsum("ij,ij->i", a, b), atol=1e-15)
    finite = np.isfinite(a).all(axis=1)
    np.testing.assert_array_equal(max_component(a)[finite], a[finite].max(axis=1))


def test_put_rows_equals_fancy_assignment(arrays):
    a, _, mask, _ = arrays
    rng = np.random.default_rng(4)
    for rows in (np.flatnonzero(mask), mask, rng.permutation(257)[:40], slice(10, 30)):
        values = rng.normal(size=(len(np.arange(257)[rows]), 3))
        for target, source in ((a.copy(), values), (a.astype(np.float32), values),
                               (a.copy(), values.astype(np.float32)), (a.copy(), values[:, ::1].T.copy().T)):
            expected = target.copy()
            expected[rows] = source
            put_rows(target, rows, source)
            np.testing.assert_array_equal(target, expected)
    target = np.zeros((6, 3))
    put_rows(target, [1, 4], np.array([1.0, 2.0, 3.0]))   # one row for all: plain assignment
    np.testing.assert_array_equal(target[[1, 4]], [[1, 2, 3], [1, 2, 3]])
