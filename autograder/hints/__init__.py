"""From the evidence of a failed check to its likely cause, in a student's words.

* :mod:`.explain`      -- :class:`~.explain.Evidence` and :func:`~.explain.explain`: the rules
  in order (camera, glass, sample independence, light tracing), on top of
  :mod:`mitsuba_refs.verdicts.explain`'s
* :mod:`.sweep`        -- rules on the per-bounce sweep: the first wrong max_depth and what its
  error follows
* :mod:`.geometry`     -- per-pixel geometry the direct-light rules compare the error with
* :mod:`.media`        -- rules of the ``media`` assignment (fog and clear pixels)
* :mod:`.evidence_io`  -- a failed check's evidence on disk, in full and compact
* :mod:`.accuracy`     -- ``python -m autograder.hints.accuracy``: how often the hints name the
  bug zoo's true causes

A rule never runs a test of its own; hints are explanations, never points. Nothing here is
imported by this file, so that :mod:`autograder.grading` can import :mod:`.explain` while
:mod:`.evidence_io` imports the grader.
"""
