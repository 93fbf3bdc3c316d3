"""The camera side: the perspective sensor's rays, its importance (for paths that end at the
camera), the film's reconstruction filters and the samplers."""
# Each module registers its plugins when imported: the sensor, the film and its filters,
# the samplers.
from . import film, perspective_sensor, orthographic, thinlens, sampler  # noqa: F401  # isort: skip
