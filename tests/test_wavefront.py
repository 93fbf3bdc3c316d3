"""Paths: what add_radiance gathers reaches the camera rays' rows of L exactly once."""
from types import SimpleNamespace

import numpy as np

from pathtracer.core.rng import RandomStream
from pathtracer.integrators.wavefront import Paths
from pathtracer.sensors.perspective import Rays


def _paths(n=6):
    rays = Rays(np.zeros((n, 3)), np.tile([0.0, 0.0, 1.0], (n, 1)), np.full(n, np.inf))
    hit = SimpleNamespace(p=np.arange(3.0 * n).reshape(n, 3), valid=np.ones(n, bool))
    return Paths(rays, RandomStream(np.arange(n, dtype=np.uint64)), hit)


def test_radiance_reaches_L_through_keep_split_and_reads():
    paths = _paths()
    expected = np.zeros((6, 3))
    paths.add_radiance(np.ones((6, 3)))                      # every path: 1
    expected += 1.0
    paths.keep(np.array([True, False, True, True, False, True]))   # 1 and 4 end
    np.testing.assert_array_equal(paths.L, expected)         # a read delivers the live paths too
    paths.add_radiance(np.full((2, 3), 2.0), rows=[0, 3])    # rays 0 and 5: + 2
    expected[[0, 5]] += 2.0
    paths.split(2, rows=np.array([1, 2]))                    # rays 2 and 3 split in two
    np.testing.assert_array_equal(paths.row, [0, 5, 2, 2, 3, 3])
    paths.add_radiance(np.arange(6.0)[:, None] * np.ones(3))  # each child adds its own index
    expected[[0, 5, 2, 3]] += [[0.0] * 3, [1.0] * 3, [2.0 + 3.0] * 3, [4.0 + 5.0] * 3]
    paths.keep(np.zeros(6, bool))                             # all end
    np.testing.assert_array_equal(paths.L, expected)
    np.testing.assert_array_equal(paths.L, expected)          # reading twice adds nothing


def test_L_can_still_be_assigned():
    """Code written when L was a plain attribute may assign it (L = L + ...)."""
    paths = _paths()
    paths.add_radiance(np.ones((6, 3)))
    paths.L = paths.L + 2.0
    paths.add_radiance(np.ones((6, 3)))
    np.testing.assert_array_equal(paths.L, np.full((6, 3), 4.0))

