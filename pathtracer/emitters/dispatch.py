"""``pathtracer.emitters.dispatch`` is now :mod:`pathtracer.emitters.scene_emitters`.

Kept for the modules still importing the old name (the integrators and
:mod:`pathtracer.render.driver`, until they import the new one): this module *is* the new one (the same
object, so patching either patches both).
"""
import sys

from . import scene_emitters

sys.modules[__name__] = scene_emitters
