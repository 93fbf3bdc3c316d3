r"""Where Mitsuba's ``scalar_rgb`` renderer puts each camera sample of a one-sample render.

A filtered (tent, gaussian) reference needs every sample's film position, so that NumPy can
weight it with the exact filter (:mod:`mitsuba_refs.reference.filtered`); Mitsuba's scalar film would
use tabulated weights instead (:mod:`mitsuba_refs.reference.rfilter`). With **one** sample per pixel
the position is the first thing the sampler draws, before the scene is touched, so it is a
function of the seed and the pixel alone, and this module computes it as Mitsuba 3.9.1 does
(``src/render/integrator.cpp``, ``spiral.cpp``, ``sensors/batch.cpp``):

* the film is cut into ``B x B`` blocks (``B`` = :data:`BLOCK_SIZE`, set on the integrator)
  numbered in the order of Mitsuba's spiral (:func:`spiral_block_ids`); pixel ``i`` of a
  block (Morton order) gets the sampler seed
  ``seed * W * H + block_id * B^2 + i`` (mod 2^32, :func:`pixel_seeds`);
* the ``independent`` sampler seeds PCG32 with that value (default stream) and draws the
  offset ``u = (f_1, f_2)``, ``f = ((next_uint32 >> 9) | 0x3f800000) - 1`` read as float32
  (:func:`pcg32_first_2d`);
* ``p = float32(pixel + u)``, ``a = float32(p / (W, H))``; the ``batch`` sensor of ``k``
  copies then takes copy ``min(floor(k a_x), k - 1)`` at ``(k a_x - floor(k a_x), a_y)``.

All float32 steps are repeated in float32, so the position returned is the one the camera
traced, to float32 rounding (:func:`batch_positions`). :func:`check_positions` renders a
small probe with a Python integrator that records each ray (:func:`position_error`) and
refuses a Mitsuba whose samples land elsewhere (another version's sampler or render loop).
"""

import functools

import numpy as np

from .batch import batch_sensor

#: Block size given to the integrator (``block_size``), so that Mitsuba's choice of it
#: cannot depend on the number of threads.
BLOCK_SIZE = 32

_MULT = np.uint64(0x5851F42D4C957F2D)
#: Drjit's ``PCG32_DEFAULT_STREAM``, the sequence every scalar sampler uses.
DEFAULT_STREAM = 0xDA3E39CB94B95BDB


def _pcg32_step(state, inc):
    """One PCG32 step (XSH RR): ``(new_state, output)`` of uint64 states."""
    old = state
    state = old * _MULT + inc
    xorshifted = (((old >> np.uint64(18)) ^ old) >> np.uint64(27)).astype(np.uint32)
    rot = (old >> np.uint64(59)).astype(np.uint32)
    left = ((np.uint32(32) - rot) & np.uint32(31))
    return state, (xorshifted >> rot) | (xorshifted << left)


def pcg32_outputs(initstate, initseq=DEFAULT_STREAM, count=2):
    """The first ``count`` ``next_uint32`` of PCG32 ``seed(initstate, initseq)`` (arrays of
    ``initstate``): state 0 and ``inc = 2 initseq + 1``, one step, add the seed, one step."""
    inc = np.uint64(((int(initseq) << 1) | 1) & 0xFFFFFFFFFFFFFFFF)
    seeds = np.asarray(initstate, dtype=np.uint64)
    outputs = []
    with np.errstate(over="ignore"):
        state, _ = _pcg32_step(np.zeros_like(seeds), inc)
        state, _ = _pcg32_step(state + seeds, inc)
        for _ in range(count):
            state, out = _pcg32_step(state, inc)
            outputs.append(out)
    return outputs


def _unit_float32(bits):
    """Drjit's ``next_float32``: 23 random mantissa bits of a float in [1, 2), minus 1."""
    return ((bits >> np.uint32(9)) | np.uint32(0x3F800000)).view(np.float32) - np.float32(1)


def pcg32_first_2d(seeds):
    """First ``next_2d`` of Mitsuba's ``independent`` sampler seeded with ``seeds`` (scalar:
    PCG32 ``seed(seed, PCG32_DEFAULT_STREAM)``). Two float32 arrays in [0, 1)."""
    seeds = np.asarray(seeds, dtype=np.uint32).astype(np.uint64)
    first, second = pcg32_outputs(seeds)
    return _unit_float32(first), _unit_float32(second)


def morton_decode_2d(index):
    """``(x, y)`` of Morton codes ``index`` (x in the even bits, y in the odd ones)."""
    def compact(v):
        v = v & 0x55555555
        v = (v | (v >> 1)) & 0x33333333
        v = (v | (v >> 2)) & 0x0F0F0F0F
        v = (v | (v >> 4)) & 0x00FF00FF
        return (v | (v >> 8)) & 0x0000FFFF
    index = np.asarray(index, dtype=np.int64)
    return compact(index), compact(index >> 1)


@functools.lru_cache(maxsize=16)
def spiral_block_ids(width, height, block_size=BLOCK_SIZE):
    """(rows, columns) int array: the id Mitsuba's ``Spiral`` gives each block of the film.

    The spiral starts at block ``(bx // 2, by // 2)``, goes right, down, left, up, growing by
    one block every second turn, and skips positions outside the film.
    """
    blocks_x, blocks_y = -(-width // block_size), -(-height // block_size)
    ids = np.full((blocks_y, blocks_x), -1, dtype=np.int64)
    x, y = blocks_x // 2, blocks_y // 2
    direction, steps_left, spiral_size = 0, 1, 1      # 0 right, 1 down, 2 left, 3 up
    moves = ((1, 0), (0, 1), (-1, 0), (0, -1))
    count = blocks_x * blocks_y
    for block_id in range(count):
        ids[y, x] = block_id
        if block_id + 1 == count:
            break
        while True:
            x, y = x + moves[direction][0], y + moves[direction][1]
            steps_left -= 1
            if steps_left == 0:
                direction = (direction + 1) % 4
                if direction in (0, 2):
                    spiral_size += 1
                steps_left = spiral_size
            if 0 <= x < blocks_x and 0 <= y < blocks_y:
                break
    ids.setflags(write=False)
    return ids


def pixel_seeds(seed, width, height, block_size=BLOCK_SIZE, base_seed=0):
    """(H, W) uint32: the sampler seed of every pixel in a one-pass scalar render.

    ``base_seed`` is the sampler's ``seed`` property (0 for the batch sensor's default
    sampler).
    """
    ids = spiral_block_ids(width, height, block_size)
    index = np.arange(block_size * block_size, dtype=np.int64)
    mx, my = morton_decode_2d(index)
    start = (int(base_seed) + int(seed) * width * height) % 2**32
    seeds = np.zeros((height, width), dtype=np.int64)
    for (block_y, block_x), block_id in np.ndenumerate(ids):
        x, y = block_x * block_size + mx, block_y * block_size + my
        inside = (x < width) & (y < height)
        seeds[y[inside], x[inside]] = start + block_id * block_size * block_size + index[inside]
    return (seeds % 2**32).astype(np.uint32)


def batch_positions(seed, copies, width, height):
    """Where each pixel's ray of a 1-spp render of a ``batch`` sensor lands.

    Parameters
    ----------
    seed : int
        The seed given to ``mi.render``.
    copies, width, height : int
        ``k`` camera copies of a ``width x height`` film (the batch film is ``k * width``
        wide).

    Returns
    -------
    (x, y) : two (height, copies * width) float64 arrays
        For every pixel of the batch film, the film position (pixels of one copy's film,
        ``[0, width] x [0, height]``) of the ray the copy traced. Which copy traced it does
        not matter here: the copies are one camera.
    """
    total = copies * width
    u0, u1 = pcg32_first_2d(pixel_seeds(seed, total, height))
    px = np.arange(total, dtype=np.float32)[None, :] + u0           # float32 sums, as Mitsuba
    py = np.arange(height, dtype=np.float32)[:, None] + u1
    ax = px * (np.float32(1) / np.float32(total))
    ay = py * (np.float32(1) / np.float32(height))
    index_f = ax * np.float32(copies)
    index_u = index_f.astype(np.uint32)                                # truncation, as UInt32()
    local_x = index_f - index_u.astype(np.float32)
    return local_x.astype(np.float64) * width, ay.astype(np.float64) * height


# ------------------------------------------------------------------ the probe


class _RayProbe:
    """A Python integrator whose "radiance" is the camera ray's direction plus 2 (> 0)."""

    def __init__(self, props):
        import mitsuba as mi
        mi.SamplingIntegrator.__init__(self, props)

    def sample(self, scene, sampler, ray, medium=None, active=True):
        import mitsuba as mi
        return mi.Spectrum(ray.d) + 2.0, True, []

    def aov_names(self):
        return []

    def to_string(self):
        return "RayProbe[]"


#: (Mitsuba version, variant) -> None when the positions matched, else the reason
_checked = {}


def check_positions():
    """Raise ``ValueError`` unless a 1-spp render's rays go where :func:`batch_positions`
    says (:func:`position_error` of a 3-copy 24 x 40 batch, ~0.1 s); the result is kept for
    the process."""
    import mitsuba as mi
    key = (mi.__version__, mi.variant())
    if key not in _checked:
        worst = position_error(3, 24, 40, 977)
        _checked[key] = None if worst == 0 else (
            f"Mitsuba {mi.__version__} ({mi.variant()}) places its camera samples differently "
            f"from Mitsuba 3.9.1 (ray directions off by up to {worst:.2g}); a tent or gaussian "
            f"film's reference then needs llvm_ad_rgb (libLLVM >= 16)")
    if _checked[key] is not None:
        raise ValueError(_checked[key])


def position_error(copies, width, height, seed):
    """Largest difference between the rays of a 1-spp render and those at the positions
    :func:`batch_positions` predicts (0 when they are the same rays).

    Renders a ``copies``-copy batch of a pinhole camera (box film) with a Python integrator
    that outputs each ray's direction, and traces the camera's ray at each predicted
    position from Python (both per sample: ~0.1 s per 3000 samples).
    """
    import mitsuba as mi

    from .integrators._common import make_class  # Mitsuba's classes: a variant must be set
    mi.register_integrator("refs_ray_probe", lambda props, cls=make_class(_RayProbe): cls(props))
    sensor = mi.load_dict({
        "type": "perspective", "fov": 40,
        "to_world": mi.ScalarTransform4f().look_at([0.3, 0.2, 4], [0, 0, 0], [0, 1, 0]),
        "film": {"type": "hdrfilm", "width": width, "height": height,
                 "rfilter": {"type": "box"}}})
    integrator = mi.load_dict({"type": "refs_ray_probe", "block_size": BLOCK_SIZE})
    batch = batch_sensor(sensor, copies, width, height)
    with _quiet(mi):
        image = np.array(mi.render(mi.load_dict({"type": "scene"}), sensor=batch,
                                   integrator=integrator, spp=1, seed=seed))[..., :3]
    xs, ys = batch_positions(seed, copies, width, height)
    worst = 0.0
    for (row, col), x in np.ndenumerate(xs):
        ray, _ = sensor.sample_ray(0.0, 0.0, mi.Point2f(x / width, ys[row, col] / height),
                                   mi.Point2f(0.5, 0.5))
        expected = np.array(ray.d, dtype=np.float32) + np.float32(2)
        worst = max(worst, float(np.abs(expected - image[row, col]).max()))
    return worst


class _quiet:
    """Raise Mitsuba's log level to errors for a block (the probe warns about Python
    integrators in scalar variants)."""

    def __init__(self, mi):
        self.logger = mi.logger()
        self.level = None
        self.mi = mi

    def __enter__(self):
        self.level = self.logger.log_level()
        self.logger.set_log_level(self.mi.LogLevel.Error)

    def __exit__(self, *exc):
        self.logger.set_log_level(self.level)
