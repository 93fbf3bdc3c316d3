"""Which (scene, integrator) pairs the statistical suites run, and with which settings.

Two pairs are left out of the Mitsuba comparisons, each for a measured reason
that a test of its own documents:

* ``furnace`` with ``path`` and ``direct``: Mitsuba 3.9.1's MIS estimators are
  biased there (+0.157 %, z = 40 / +0.123 %, z = 341 in the committed references; its float32
  sphere pdf switches between the
  cone and the area form for points on the sphere), so our unbiased images are
  checked against the closed form Le / (1 - rho) instead (test_analytic.py) and
  the reference's bias is asserted in test_mitsuba_known_bias.py (``recursive``
  and ``smallpt`` are compared with Mitsuba's unbiased path_nee / path_bsdf
  twins there, see mitsuba_refs.verdicts.estimators.CLOSEST_ESTIMATOR);
* ``point-light`` with ``smallpt``: BSDF sampling alone can never reach a Dirac
  light, so the image is black by construction (test_analytic.py asserts it).
"""
import os

from mitsuba_refs.reference.config import BUILTIN_SCENES, FEATURE_SCENES, LIGHT_SCENES, MEDIA_SCENES
from pathtracer import INTEGRATORS

#: A committed 8-bit texture (a coloured grid): what tests project, map and sample.
GRID_PNG = os.path.join(os.path.dirname(__file__), "..", "pathtracer", "data", "scenes",
                        "textured-grid.png")

#: The light tracer is compared with Mitsuba's ``ptracer`` where a reference is committed
#: (mitsuba_refs.reference.config.LIGHT_SCENES, and the ``caustics`` feature scene): 64 replicas of a
#: particle tracer cost 15-25 s of Mitsuba per scene and its test renders ~5 s each, and
#: several built-in scenes have lights it refuses (environment, directional).
LIGHT_EXCLUDED = {(scene, "light"): "no ptracer reference (mitsuba_refs.reference.config.LIGHT_SCENES)"
                  for scene in BUILTIN_SCENES if scene not in LIGHT_SCENES}

#: Bidirectional path tracing renders ~10x slower than ``path`` (every pair of subpath vertices
#: is joined by a shadow ray): its agreement with Mitsuba's ``path`` runs on the scene with
#: glass and a mirror (Dirac vertices on both subpaths) at 8 spp; the Cornell box is checked
#: strategy by strategy against the per-bounce references in test_bdpt.py.
BDPT_SCENES = ("cornell-caustics",)
BDPT_EXCLUDED = {(scene, "bdpt"): "bdpt is compared on BDPT_SCENES (time budget, see test_bdpt.py)"
                 for scene in BUILTIN_SCENES if scene not in BDPT_SCENES}

EXCLUDED = {**LIGHT_EXCLUDED, **BDPT_EXCLUDED,
    ("furnace", "path"): "Mitsuba's path is biased in the furnace (see test_mitsuba_known_bias.py)",
    ("furnace", "direct"): "Mitsuba's direct is biased in the furnace (see test_mitsuba_known_bias.py)",
    ("point-light", "smallpt"): "BSDF sampling cannot hit a point light (see test_analytic.py)",
}

#: Pairs whose images are black without noise on both sides (a point light is
#: invisible to BSDF sampling on Mitsuba too): the variance test has nothing to test.
NOISELESS = {("point-light", "path_bsdf")}

#: The surface integrators; the volumetric ones (volpath, volpath_phase) are checked on the
#: media scenes, at their own sample counts, in test_media.py.
SURFACE_INTEGRATORS = sorted(name for name, cls in INTEGRATORS.items()
                             if not cls.handles_media)

AGREEMENT_CASES = [(scene, integrator) for scene in BUILTIN_SCENES for integrator in SURFACE_INTEGRATORS
                   if (scene, integrator) not in EXCLUDED]

#: Feature scenes (mitsuba_refs.reference.config.FEATURE_SCENES) with each estimator they have a reference
#: for (the media scenes: test_media.py).
FEATURE_CASES = [(scene, integrator) for scene, (integrators, _, _) in FEATURE_SCENES.items()
                 for integrator in integrators if scene not in MEDIA_SCENES]


#: Small scenes that exist to test emitters (envmap, spot, directional). The convergence law
#: is a property of the integrators, checked on every other scene; here only ``path`` is
#: checked, as the ladder's heavy-tail doubling makes path_nee and recursive on ``envmap``
#: take 30-55 s each (measured on 2 shared cores), over the suite's time budget.
EMITTER_SCENES = ("envmap", "spot-directional")

#: ``recursive`` (N branches per vertex, the slowest estimator) is held to the law on the
#: Cornell box scenes only: the law is a property of an estimator's samples (independent, finite
#: variance), and on veach-mis, mesh, smallpt, furnace and glass-cube its ladder cost 15-110 s
#: of CPU each (measured 2026-11-30), a sixth of the suite's; the agreement tests still check
#: its mean and variance on every scene.
RECURSIVE_CONVERGENCE_SCENES = ("cornell-box", "cornell-caustics", "cornell-lights")

CONVERGENCE_CASES = [(scene, integrator) for scene, integrator in AGREEMENT_CASES
                     if (scene, integrator) not in NOISELESS
                     and (scene not in EMITTER_SCENES or integrator == "path")
                     and (integrator != "recursive" or scene in RECURSIVE_CONVERGENCE_SCENES)
                     and integrator != "bdpt"]     # its ladder would cost minutes (see BDPT_SCENES)


def spp_for(integrator: str) -> int:
    """Samples per pixel of a test render: 64 (the references have 64x more), 16 for recursive,
    8 for bdpt."""
    return {"recursive": 16, "bdpt": 8}.get(integrator, 64)


def integrator_options(integrator: str) -> dict:
    """Recursive ray tracing splits twice into 2 rays: 4x the rays, enough to test it."""
    return {"branches": 2, "branch_depth": 2} if integrator == "recursive" else {}


def medium_ball_on_floor(medium_id: str, radius: float, floor: float, light: str,
                         intensity: float, ambient: float) -> str:
    """Scene body of a null-bounded sphere of the medium ``medium_id`` resting on a diffuse
    floor (``floor`` wide), lit by a point light at ``light`` and a constant environment: the
    media tests' small live-Mitsuba scene."""
    return f"""
    <shape type="sphere"><float name="radius" value="{radius}"/><bsdf type="null"/>
        <ref id="{medium_id}" name="interior"/></shape>
    <shape type="rectangle">
        <transform name="to_world"><scale value="{floor}"/><rotate x="1" angle="-90"/>
            <translate value="0, {-radius}, 0"/></transform>
        <bsdf type="diffuse"/>
    </shape>
    <emitter type="point"><point name="position" value="{light}"/>
        <rgb name="intensity" value="{intensity}, {intensity}, {intensity}"/></emitter>
    <emitter type="constant"><rgb name="radiance" value="{ambient}, {ambient}, {ambient}"/></emitter>"""
