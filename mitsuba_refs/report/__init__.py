"""Machine-readable results of comparisons, and the reports people and CI read.

* :mod:`.results`: a :class:`~mitsuba_refs.verdicts.compare.Comparison` as a JSON record (schema
  ``mitsuba-refs/result/1``) with its images saved as EXR beside it; results files
  (``mitsuba-refs/results/1``) written and read back.
* :mod:`.verdicts`: each verdict of a comparison as a JSON entry.
* :mod:`.encoding`: numbers and arrays as strict JSON, and back.
* :mod:`.junit`: JUnit XML, one test case per verdict.
* :mod:`.html` and :mod:`.figures`: a self-contained static HTML page.
* :mod:`.outputs`: ``--json``, ``--junit``, ``--html`` of the commands that compare.
* :mod:`.cli`: ``mitsuba-refs report``.

The package imports nothing here, so that registering its command costs no start-up time.
"""
