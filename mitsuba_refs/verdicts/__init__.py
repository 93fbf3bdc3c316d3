"""From renders to verdicts: the orchestration around the pure statistics of ``stats/``.

``compare`` (renders of both sides, the four verdicts, the first diverging bounce), ``detect``
(what a comparison could see, and the spp that sees enough), ``explain`` (evidence to likely
causes) and ``hooks`` (wrappers of the ``render=`` hook).
"""
