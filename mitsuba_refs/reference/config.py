"""The constants of the reference side, in one place.

Test resolution
    ``TEST_WIDTH x TEST_HEIGHT`` = 64 x 64 for square scenes, 64 x 48 for the
    4:3 scenes (``smallpt``, ``veach-mis``, ``quad-light``, ``point-light``,
    ``cornell-lights``), 32 x 32 for the small emitter scenes (``envmap``,
    ``spot-directional``), which keep the agreement tests of the extra
    emitters cheap.
    48 is not a multiple of 32: in ``scalar_rgb`` Mitsuba seeds 32 x 32
    blocks from ``seed * W * H``, so :mod:`mitsuba_refs.reference.render` spaces pass
    seeds far enough apart for the padded block count (see
    :func:`mitsuba_refs.reference.seeds.pass_seeds`). EXR files stay ~20-50 KB.

Samples
    ``TEST_MAX_SPP`` = 64 is the most samples per pixel any test renders at
    the test resolution. A committed reference has ``REF_SPP`` =
    ``REF_SPP_FACTOR * TEST_MAX_SPP`` = 64 * 64 = 4096 spp, so the
    reference's own variance is 1/64 of the test's (the error-vs-spp slope
    stays within ~1 % of -1/2).

Passes
    A reference is rendered in passes of at most ``PASS_SPP`` = 1024 spp; pass
    ``k`` of a reference with seed ``s`` uses Mitsuba seed
    ``((s * 2^20 + stream) * SEED_STRIDE + k) * spacing`` mod 2^32, where
    ``stream`` is a 20-bit hash of (integrator, params) so references of
    different estimators are independent, ``SEED_STRIDE`` = 4096 passes at
    most, and ``spacing`` >= 1 covers scalar mode's block seeding.

Per-bounce references
    ``PER_BOUNCE_DEPTHS`` = (1, 2, 3): ``path`` references with
    ``max_depth`` = 1 (emitters seen directly), 2 (direct lighting),
    3 (one indirect bounce).
"""
from pathtracer.scene.load import builtin_scene_names

TEST_WIDTH = 64
TEST_HEIGHT = 64
TEST_HEIGHT_4_3 = 48
TEST_SIZE_SMALL = 32

#: Scenes whose test film is 64 x 48 (4:3 aspect) instead of 64 x 64.
WIDE_SCENES = ("smallpt", "veach-mis", "quad-light", "point-light", "cornell-lights")
#: Scenes whose test film is 32 x 32.
SMALL_SCENES = ("envmap", "spot-directional")

TEST_MAX_SPP = 64
REF_SPP_FACTOR = 64
REF_SPP = REF_SPP_FACTOR * TEST_MAX_SPP  # 4096

PASS_SPP = 1024
#: Independent renders of a particle-tracer (``light``) reference: 64 of 64 spp.
REF_REPLICAS = 64
SEED_STRIDE = 4096
REF_SEED = 1

#: The lecture's participating-media sequence ("A Simple Example Scene", steps 1-4: a medium
#: behind a null boundary, + a dielectric boundary eta = 1.00001, + glossy materials, + a
#: light facing the ceiling), with ``volpath`` references (``volpath_phase`` shares them).
MEDIA_SCENES = tuple(f"lecture-media-{step}" for step in (1, 2, 3, 4))

#: Built-in scenes that exercise one feature (e.g. the BSDFs of users' scenes), with
#: references for a few estimators at a small film so that their own agreement tests
#: take seconds. They are not in BUILTIN_SCENES, whose every suite runs every integrator.
#: name -> (our integrators with a reference, width, height)
FEATURE_SCENES = {
    "materials": (("path", "path_bsdf", "path_nee"), 32, 32),
    "principled": (("path",), 32, 32),
    "caustics": (("path", "light"), 32, 32),
    **{scene: (("volpath",), 32, 32) for scene in MEDIA_SCENES},
}
#: Built-in scenes with a committed ``light`` (Mitsuba ``ptracer``) reference besides
#: REF_INTEGRATORS' (a particle tracer cannot start on environment or directional lights).
LIGHT_SCENES = ("cornell-box",)

#: Built-in scenes with agreement tests of their own (tests/test_agreement.py) and the
#: references those need, built by hand: ``textured`` (``path`` at 32 x 32) and
#: ``quad-light-filtered`` (``path`` on a tent and a gaussian film), and the autograder's
#: ``media-box`` (``volpath`` at its own 32 x 32, and at max_depth 1, 2, 3: the ``media``
#: checks, tests/test_autograder.py) and ``glass-lamp`` (``light`` at 64 x 48: the
#: ``light-tracing`` check), ``lights-cameras`` (``path`` at its own 32 x 24: thin lens,
#: mesh attributes, textured area lights, projectors) and ``hetero-smoke`` (``volpath`` at
#: its own 32 x 32: tests/test_heterogeneous.py). Not in BUILTIN_SCENES.
OWN_TEST_SCENES = ("textured", "quad-light-filtered", "media-box", "glass-lamp", "lights-cameras",
                   "hetero-smoke")

#: Built-in scenes only the autograder renders, each a variant of a built-in scene (name ->
#: that scene) with larger, dimmer lights of the same power, where BSDF sampling alone
#: (``path_bsdf``) finds a light often enough for its checks' power (docs/autograder.md,
#: "Power"). Test film size as the scene they vary; committed references for the graded
#: estimator and the per-bounce ``path`` ones only. Not in BUILTIN_SCENES.
GRADING_SCENES = {"cornell-box-large-light": "cornell-box",
                  "cornell-caustics-large-light": "cornell-caustics",
                  "cornell-lights-large": "cornell-lights"}

#: The built-in scenes (``pathtracer/data/scenes/*.xml``) that every suite renders with every
#: integrator: all but FEATURE_SCENES, OWN_TEST_SCENES and GRADING_SCENES. A scene file added
#: there joins them and needs its committed references (``mitsuba-refs build``).
BUILTIN_SCENES = tuple(name for name in builtin_scene_names()
                       if name not in FEATURE_SCENES and name not in OWN_TEST_SCENES
                       and name not in GRADING_SCENES)

#: Our integrator names for which references are built by default.
REF_INTEGRATORS = ("path", "path_bsdf", "path_nee", "direct")

PER_BOUNCE_DEPTHS = (1, 2, 3)

#: spp ladder of ``compare``'s convergence test (4x steps: RMSE should halve) and the
#: independent replicas at its top level; lower levels get more
#: (:func:`mitsuba_refs.verdicts.convergence.level_replicas`).
CONVERGENCE_LADDER = (1, 4, 16, 64)
CONVERGENCE_REPLICAS = 2
#: The convergence test's replicas double (at every level) while rare bright paths carry the
#: mean MSE (stats.rare_errors_dominate), up to this many times the first count.
CONVERGENCE_MAX_GROWTH = 16
#: Seconds one run of an external renderer (``check --command``) may take by default.
DEFAULT_TIMEOUT = 600.0

#: Environment variables.
ENV_VARIANT = "MITSUBA_REFS_VARIANT"
ENV_CACHE = "MITSUBA_REFS_CACHE"


def test_resolution(scene_name):
    """Return ``(width, height)`` of the test film for a built-in scene."""
    if scene_name in GRADING_SCENES:
        return test_resolution(GRADING_SCENES[scene_name])
    if scene_name in FEATURE_SCENES:
        return FEATURE_SCENES[scene_name][1:]
    if scene_name in WIDE_SCENES:
        return TEST_WIDTH, TEST_HEIGHT_4_3
    if scene_name in SMALL_SCENES:
        return TEST_SIZE_SMALL, TEST_SIZE_SMALL
    return TEST_WIDTH, TEST_HEIGHT
