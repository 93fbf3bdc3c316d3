"""Course autograder: grade a student's integrators against Mitsuba 3 references.

The modules here are the grader's pipeline, in order:

* :mod:`autograder.contract`  -- what a student implements and how ``--impl`` finds it
* :mod:`autograder.skeleton`  -- ``python -m autograder.skeleton OUT_DIR``: the student skeleton
* :mod:`autograder.solution`  -- the reference solution in the contract (graded by default)
* :mod:`autograder.grading`   -- the checks (scene x integrator), their parts, points and
  statistical budget
* :mod:`autograder.replicas`  -- the scored render, its variance from replicas the grader seeds
* :mod:`autograder.results`   -- Gradescope ``results.json``, written atomically after every test
* :mod:`autograder.plugin`    -- the pytest plugin (``--impl``, ``--gradescope``, markers)
* :mod:`autograder.package`   -- ``python -m autograder.package OUT.zip``: the Gradescope zip
* :mod:`autograder.calibrate` -- ``python -m autograder.calibrate``: the false-failure sweep
* :mod:`autograder.power`     -- ``python -m autograder.power``: the smallest bias each check detects

and the folders:

* :mod:`autograder.isolation` -- the grader's side of the student process: the sandboxed child
  and the conversation with it (``process``), where and as whom it runs and the audit that
  the student user can read nothing private (``environment``), the student runtime: the
  tracer without the reference solution (``runtime``)
* :mod:`autograder.sandbox`   -- the child's side: request loop, wire format, seccomp allowlist,
  Landlock, capabilities
* :mod:`autograder.hints`     -- from the evidence of a failed check to a likely cause, in a
  student's words, and how often the hints are right
* ``autograder/tests_for_students/`` -- the graded tests Gradescope runs

See docs/autograder.md.
"""
