"""The reference side: Mitsuba 3 renders the scene file, and what comes back is cached.

``render`` (variants, passes and their ``seeds``, the ``batch`` of single samples,
``filtered`` films with the sample ``positions`` that Mitsuba's scalar renderer uses, and the
reconstruction filter's effect in ``rfilter``), ``moments`` and ``integrators`` (the project's
own Mitsuba plugins), ``cache`` (references named by what they are, checked when read) with
``exr`` (their files), ``config`` (the constants of this side) and ``conductor_presets``.
"""
