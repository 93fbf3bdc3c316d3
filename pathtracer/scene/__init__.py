"""The scene description: Mitsuba 3 XML read into plugin elements (:mod:`.xml`), typed
properties with refusals (:mod:`.properties`), one registry of plugins per kind
(:mod:`.registry`), spectra, transforms and the assembled :class:`~.types.Scene`.

Loading a file is :func:`pathtracer.scene.load.load_scene` (``pathtracer.load_scene``).
This package imports nothing, so that a plugin module can register itself without
starting the loader that imports every plugin.
"""
