"""Course autograder: grade a student's integrators against Mitsuba 3 references.

* :mod:`autograder.contract`  -- what a student implements and how ``--impl`` finds it
* :mod:`autograder.isolation` -- the student's code in a child process with time, memory and
  output limits
* :mod:`autograder.grading`   -- the checks (scene x integrator), their parts, points and
  statistical budget
* :mod:`autograder.hints`     -- from the evidence to a likely cause, in a student's words
* :mod:`autograder.results`   -- Gradescope ``results.json``, written atomically after every test
* :mod:`autograder.plugin`    -- the pytest plugin (``--impl``, ``--gradescope``, markers)
* :mod:`autograder.skeleton`  -- ``python -m autograder.skeleton OUT_DIR``: the student skeleton
* :mod:`autograder.package`   -- ``python -m autograder.package OUT.zip``: the Gradescope zip

See docs/autograder.md.
"""
