"""The seeds of an external renderer's runs (``mitsuba_refs.external.seeding``) and the search
for noise two replicas share at a pixel offset (``mitsuba_refs.stats.replicas``).

The seed rule is tested against models of the ways renderers turn a seed into random streams:
seed + pixel index (Mitsuba 3's command line: the sampler's seed plus a block-local index over
32 x 32 blocks, padding included), seed x pixel count + block offset (Mitsuba 3's scalar
``render(seed=)``, 32-bit arithmetic that wraps), seed + sample index, and hashed seeds. The
seeds of a check must give every run streams of its own under each of them.
"""
import numpy as np
import pytest

from mitsuba_refs.errors import RefsInputError
from mitsuba_refs.external.renders import check_independent, shared_noise_limit, shares_noise
from mitsuba_refs.external.seeding import SEED_LIMIT, WRAP, SeedSpaceError, padded_pixels, seed_rule
from mitsuba_refs.stats.replicas import offset_shared_noise

FILMS = [(1, 1), (1, 1024), (1024, 1), (17, 5), (48, 40), (64, 64), (100, 75), (333, 1024),
         (640, 480), (1000, 1000), (1024, 1024), (1920, 1080)]
SPPS = (1, 64, 4096)
RUNS = 300


# ---- models of stream schemes: each gives, per seed, the interval of stream ids it uses ----

def pixel_offset_streams(seeds, width, height, spp):
    """seed + pixel index over padded 32 x 32 blocks (Mitsuba 3's command line, row-major)."""
    return np.asarray(seeds, dtype=np.uint64), padded_pixels(width, height)


def multiplied_streams(seeds, width, height, spp):
    """seed * W * H + 1024 * block + index in block, modulo 2^32 (Mitsuba 3's render(seed=))."""
    starts = (np.asarray(seeds, dtype=np.uint64) * np.uint64(width * height)) % np.uint64(WRAP)
    return starts, padded_pixels(width, height)


def sample_streams(seeds, width, height, spp):
    """seed + sample index, shared by the pixels."""
    return np.asarray(seeds, dtype=np.uint64), spp


SCHEMES = {"seed + pixel": pixel_offset_streams, "seed * pixels + block": multiplied_streams,
           "seed + sample": sample_streams}


def disjoint_on_circle(starts, length) -> bool:
    """Whether the intervals [start, start + length) modulo 2^32 overlap nowhere."""
    order = np.sort(np.asarray(starts, dtype=np.int64))
    gaps = np.diff(np.concatenate([order, [order[0] + WRAP]]))
    return bool(np.all(gaps >= length))


def hashed_streams(seeds, width, height):
    """A 64-bit hash of (seed, pixel), as JIT renderers do: the stream of every pixel of every run."""
    seed = np.asarray(seeds, dtype=np.uint64)[:, None]
    pixel = np.arange(width * height, dtype=np.uint64)[None, :]
    with np.errstate(over="ignore"):
        x = (seed << np.uint64(32)) ^ pixel
        for shift, factor in ((30, 0xBF58476D1CE4E5B9), (27, 0x94D049BB133111EB)):
            x = (x ^ (x >> np.uint64(shift))) * np.uint64(factor)
        return x ^ (x >> np.uint64(31))


# ---- the seed rule -----------------------------------------------------------------------

@pytest.mark.parametrize("width, height", FILMS)
def test_seeds_of_a_check_give_every_run_streams_of_its_own_under_every_scheme(width, height):
    for spp in SPPS:
        rule = seed_rule(width, height, spp, RUNS)
        assert rule.stride >= max(padded_pixels(width, height), spp)
        for offset in (0, 1, 7, rule.rounds, rule.rounds + 3, 123_456):
            seeds = rule.seeds(RUNS, offset)
            assert len(set(seeds)) == RUNS
            assert 0 < min(seeds) and max(seeds) < SEED_LIMIT, (width, height, spp, offset)
            for name, scheme in SCHEMES.items():
                starts, length = scheme(seeds, width, height, spp)
                assert disjoint_on_circle(starts, length), (name, width, height, spp, offset)


def test_consecutive_seeds_and_plain_multiples_fail_the_models_the_rule_passes():
    """The models see what went wrong before: consecutive seeds overlap as seed + pixel, and
    multiples of 2^20 collapse to one stream range on a 1024 x 1024 film (2^40 = 0 mod 2^32)."""
    starts, length = pixel_offset_streams(range(1, 9), 64, 64, 1)
    assert not disjoint_on_circle(starts, length)
    starts, length = multiplied_streams([k << 20 for k in range(1, 9)], 1024, 1024, 1)
    assert not disjoint_on_circle(starts, length)
    rule = seed_rule(1024, 1024, 64, 8)
    assert rule.stride == (1 << 20) + 1
    starts, length = multiplied_streams(rule.seeds(8), 1024, 1024, 1)
    assert disjoint_on_circle(starts, length)


def test_hashed_streams_of_the_seeds_are_all_distinct():
    seeds = seed_rule(64, 64, 64, RUNS).seeds(RUNS, 5)
    streams = hashed_streams(seeds, 64, 64)
    assert np.unique(streams).size == streams.size


def test_repeated_checks_get_fresh_seeds():
    rule = seed_rule(64, 64, 64, RUNS)
    firsts = {rule.seed(0, offset) for offset in range(0, 3 * rule.rounds)}
    assert len(firsts) == 3 * rule.rounds
    # Within the disjoint ranges, no seed of one check is a seed of another.
    a, b = set(rule.seeds(RUNS, 0)), set(rule.seeds(RUNS, 1))
    assert not a & b


def test_a_check_too_large_for_its_film_is_refused_and_fit_shrinks_it():
    with pytest.raises(SeedSpaceError, match="leaves room for at most"):
        seed_rule(1024, 1024, 64, 3000)
    rule = seed_rule(1024, 1024, 64, 3000, fit=True)
    assert 1000 < rule.slots < 3000 and rule.stride * (rule.slots + 1) < SEED_LIMIT
    with pytest.raises(SeedSpaceError):
        rule.seed(rule.slots)
    # A 4096 x 4096 film leaves room for 126 runs; fit takes them, apart under every scheme.
    rule = seed_rule(4096, 4096, 64, 8, fit=True)
    assert rule.slots == 126
    for scheme in SCHEMES.values():
        assert disjoint_on_circle(*scheme(rule.seeds(rule.slots, 3), 4096, 4096, 64))


def test_a_check_of_the_default_settings_fits_its_runs():
    from mitsuba_refs.external.check import run_seeds
    from mitsuba_refs.settings import Settings
    rule = run_seeds(Settings(), (64, 64), per_bounce=True)
    # 8 replicas x (mean + 3 depths) + the ladder 1, 4, 16, 64 grown to 32 top replicas.
    assert rule.slots >= 8 * 4 + 32 * (64 + 16 + 4 + 1)
    assert rule.stride >= 4096


# ---- noise shared at a pixel offset -------------------------------------------------------

def shifted_stack(rng, shift, count=8, size=(40, 48), copies=(2, 5), share=1.0):
    """Independent Gaussian replicas, of which ``copies[1]`` repeats ``copies[0]``'s noise
    ``shift`` = (dx, dy) pixels further on (a fraction ``share`` of it)."""
    height, width = size
    stack = rng.normal(size=(count, height, width, 3))
    field = rng.normal(size=(height + 20, width + 20, 3))
    dx, dy = shift
    stack[copies[0]] = field[10:10 + height, 10:10 + width]
    moved = field[10 + dy:10 + dy + height, 10 + dx:10 + dx + width]
    stack[copies[1]] = share * moved + np.sqrt(1 - share ** 2) * stack[copies[1]]
    return stack


@pytest.mark.parametrize("shift", [(1, 0), (0, -1), (-3, 2), (7, 5), (0, 0)])
def test_noise_shared_at_an_offset_is_found_there(shift):
    found = offset_shared_noise(shifted_stack(np.random.default_rng(3), shift))
    assert (found.first, found.second) == (2, 5)
    # Replica 5 at (x + dx, y + dy) repeats replica 2 at (x, y).
    assert (found.dx, found.dy) == (-shift[0], -shift[1])
    assert found.correlation > 0.7 and shares_noise(found)


def test_half_the_noise_shared_at_an_offset_is_found():
    """Mitsuba's consecutive seeds move half the pixels of a block by one pixel."""
    found = offset_shared_noise(shifted_stack(np.random.default_rng(4), (1, 0), share=0.5))
    assert (found.dx, found.dy) == (-1, 0) and shares_noise(found)


def test_independent_replicas_pass_at_every_offset():
    """Fixed seeds: Gaussian, 1-spp-like sparse and neighbour-correlated replicas (the
    calibration of docs/external.md ran 5000 such stacks; none came near the limit)."""
    rng = np.random.default_rng(11)
    gaussian = rng.normal(size=(8, 64, 64, 3))
    sparse = (rng.random((8, 48, 40, 3)) < 0.05) * rng.exponential(size=(8, 48, 40, 3))
    blurred = rng.normal(size=(8, 66, 66, 3))
    blurred = sum(blurred[:, i:i + 64, j:j + 64] for i in range(3) for j in range(3)) / 9
    for stack in (gaussian, sparse, blurred):
        found = offset_shared_noise(stack)
        assert found.z < shared_noise_limit(found.tests) - 1, found
        check_independent(stack)


def test_images_sharing_noise_at_an_offset_are_refused_naming_it():
    stack = shifted_stack(np.random.default_rng(5), (2, 1))
    names = [f"r{k}.exr" for k in range(8)]
    with pytest.raises(RefsInputError, match=r"r2.exr and r5.exr are not independent: .* at pixel "
                                             r"offset \(dx, dy\) = \(-2, -1\).*use these"):
        check_independent(stack, names=names, advice="use these")


def test_fewer_than_three_replicas_or_no_noise_give_no_answer():
    assert offset_shared_noise(np.ones((8, 16, 16, 3))) is None
    assert offset_shared_noise(np.random.default_rng(0).random((2, 16, 16, 3))) is None


# ---- what the command line prints and what {defines} carries ---------------------------

def test_seeds_for_prints_multiples_of_the_films_stride(capsys):
    from mitsuba_refs.cli.main import main
    assert main(["check", "cornell-box", "--seeds-for", "3", "--resolution", "48x40",
                 "--spp", "64"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == "# seeds for 3 images of a 48x40 film up to 64 spp: multiples of 4096"
    assert lines[1:] == ["4096", "8192", "12288"]
    assert main(["check", "cornell-box", "--seeds-for", "0"]) == 2
    assert "mitsuba-refs check: error: --seeds-for must be >= 1" in capsys.readouterr().err


def test_defines_carry_the_requested_film_size():
    from mitsuba_refs.external.check import film_defines
    params = {"width": 64, "height": 64, "max_depth": 3}
    assert film_defines("cornell-box", params, (48, 40)) == {"width": 48, "height": 40,
                                                             "max_depth": 3}
    assert film_defines("cornell-box", params, None) == params


# ---- end to end: a renderer seeding pixel i with seed + i ---------------------------------

def test_a_renderer_with_pixel_streams_gets_seeds_apart_and_consecutive_ones_are_refused(capsys):
    """The stand-in renderer draws pixel i from stream seed + i. At the harness's seeds its
    replicas are independent (the check goes on to its verdicts: a constant image disagrees,
    exit 1); told consecutive seeds ({seed} / stride), they share noise one pixel apart."""
    from mitsuba_refs.cli.main import main
    from tests.test_external_check import FAKE

    def run(seed):
        command = (f"{FAKE} --width {{width}} --height {{height}} --seed {seed} --noise 1 "
                   "--pixel-streams --out {out} # {spp}")
        code = main(["check", "cornell-box", "--no-convergence", "--bounces", "never",
                     "--out", "out/test-seeding", "--jobs", "2", "--command", command])
        return code, capsys.readouterr().err
    code, err = run("{seed}")
    assert code == 1, err
    code, err = run("$(( {seed} / 4096 ))")
    assert code == 2, err
    assert "are not independent" in err and "at pixel offset (dx, dy) = (" in err, err
