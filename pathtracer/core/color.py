"""Colour constants shared by the tracer and the harness."""
from __future__ import annotations

import numpy as np

#: Relative luminance of linear sRGB (Rec. 709 primaries, D65 white): Y = LUMINANCE @ rgb.
#: The coefficients are those Mitsuba 3's ``luminance()`` uses for RGB, so that a texture's
#: or an environment map's luminance (its sampling weights) and the harness's headline bias
#: weigh the channels as Mitsuba does. They sum to 1: a grey value is its own luminance.
LUMINANCE = np.array([0.212671, 0.715160, 0.072169])
