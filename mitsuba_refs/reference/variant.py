"""Choose the Mitsuba variant that renders references.

``llvm_ad_rgb`` is preferred: it is 2-4x faster than ``scalar_rgb`` and runs
the Python integrators of :mod:`mitsuba_refs.reference.integrators` as one vectorised
kernel instead of one Python call per sample. It needs a libLLVM >= 16; with
an older one Dr.Jit *aborts the process* on the first kernel, so the probe
renders a tiny scene in a subprocess and only trusts a clean exit. The
result is cached for the life of the process.

Order of precedence: the ``variant`` argument (the CLI's ``--variant``),
then the environment variable ``MITSUBA_REFS_VARIANT``, then the probe.
"""

import os
import subprocess
import sys

from ..errors import RefsInputError
from . import mitsuba_log
from .config import ENV_VARIANT

PREFERRED = "llvm_ad_rgb"
FALLBACK = "scalar_rgb"

_PROBE = r"""
import drjit as dr, mitsuba as mi
mi.set_variant("llvm_ad_rgb")
scene = mi.load_dict({
    "type": "scene",
    "integrator": {"type": "path", "max_depth": 3},
    "sensor": {"type": "perspective",
               "film": {"type": "hdrfilm", "width": 4, "height": 4,
                        "rfilter": {"type": "box"}}},
    "shape": {"type": "sphere", "center": [0, 0, -3],
              "emitter": {"type": "area"}},
})
image = mi.render(scene, spp=4)
dr.eval(image)
version = getattr(dr.detail, "llvm_version", lambda: None)()
print("LLVM", ".".join(map(str, version)) if version else "unknown")
"""

_probe_cache = {}


def probe_llvm(timeout=120):
    """Render a 4x4 image with ``llvm_ad_rgb`` in a subprocess.

    Returns
    -------
    (ok, detail) : (bool, str)
        ``detail`` names the LLVM version on success, or says how it failed.
    """
    if "llvm" in _probe_cache:
        return _probe_cache["llvm"]
    try:
        proc = subprocess.run([sys.executable, "-c", _PROBE],
                              capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        result = (False, f"probe render timed out after {timeout} s")
    except OSError as exc:
        result = (False, f"could not start the probe: {exc}")
    else:
        if proc.returncode == 0:
            lines = [l for l in proc.stdout.splitlines() if l.startswith("LLVM")]
            version = lines[-1].split(None, 1)[1] if lines else "unknown"
            result = (True, f"libLLVM {version} works (probe render succeeded)")
        else:
            tail = (proc.stderr or proc.stdout).strip().splitlines()[-1:] or [""]
            result = (False, f"probe render failed (exit status "
                             f"{proc.returncode}: {tail[0][:200]})")
    _probe_cache["llvm"] = result
    return result


def choose_variant(variant=None):
    """Return ``(variant, reason)``.

    Parameters
    ----------
    variant : str, optional
        Explicit choice (e.g. from ``--variant``); wins over everything.
    """
    if variant:
        return variant, "requested explicitly (--variant / argument)"
    env = os.environ.get(ENV_VARIANT)
    if env:
        return env, f"set by ${ENV_VARIANT}"
    ok, detail = probe_llvm()
    if ok:
        return PREFERRED, detail
    return FALLBACK, f"{PREFERRED} unusable: {detail}"


def set_variant(variant=None):
    """Choose a variant, activate it in Mitsuba, register our integrators.

    Returns ``(variant, reason)``.
    """
    import mitsuba as mi  # Mitsuba: optional and heavy, imported where it renders
    chosen, reason = choose_variant(variant)
    if chosen not in mi.variants():
        raise RefsInputError(f"Mitsuba variant {chosen!r} ({reason}) is not available "
                             f"(have: {', '.join(mi.variants())})")
    if mi.variant() != chosen:
        mi.set_variant(chosen)
    mitsuba_log.install()       # plain lines, before our Python integrators are made
    # Mitsuba plugins: they import Mitsuba, and their classes need the variant set first.
    from . import integrators, moments
    integrators.register()
    moments.register()
    return chosen, reason
