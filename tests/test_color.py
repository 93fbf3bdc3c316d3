"""The one luminance of the project (pathtracer.core.color.LUMINANCE): Mitsuba's weights."""
import numpy as np
import pytest

from pathtracer.core.color import LUMINANCE

RGB = [(1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0), (0.25, 0.5, 0.75), (3.0, 0.125, 1e-3)]


def test_the_weights_sum_to_one():
    """A grey value is its own luminance."""
    assert abs(float(LUMINANCE.sum()) - 1.0) < 1e-6


@pytest.mark.mitsuba
def test_the_weights_are_mitsubas(mi):
    for rgb in RGB:
        theirs = float(np.ravel(np.array(mi.luminance(mi.Color3f(*rgb))))[0])
        assert theirs == pytest.approx(float(LUMINANCE @ np.array(rgb)), rel=1e-6, abs=1e-9)
