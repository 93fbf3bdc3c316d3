"""Course autograder: grade a student's integrators against Mitsuba 3 references.

* :mod:`autograder.contract`  -- what a student implements and how ``--impl`` finds it
* :mod:`autograder.isolation` -- the student's code in a sandboxed child process (own user,
  no capabilities, Landlock, a seccomp allowlist, limits), plain-data replies
* :mod:`autograder.environment` -- where and as whom it runs, and the audit that the student user
  can read nothing private
* :mod:`autograder.runtime`   -- the student runtime: the tracer without the reference solution
* :mod:`autograder.sandbox`   -- the child's side: request loop, wire format, seccomp allowlist,
  Landlock, capabilities
* :mod:`autograder.power`     -- ``python -m autograder.power``: the smallest bias each check detects
* :mod:`autograder.calibrate` -- ``python -m autograder.calibrate``: the false-failure sweep
* :mod:`autograder.grading`   -- the checks (scene x integrator), their parts, points and
  statistical budget
* :mod:`autograder.hints`     -- from the evidence to a likely cause, in a student's words
* :mod:`autograder.results`   -- Gradescope ``results.json``, written atomically after every test
* :mod:`autograder.plugin`    -- the pytest plugin (``--impl``, ``--gradescope``, markers)
* :mod:`autograder.skeleton`  -- ``python -m autograder.skeleton OUT_DIR``: the student skeleton
* :mod:`autograder.package`   -- ``python -m autograder.package OUT.zip``: the Gradescope zip

See docs/autograder.md.
"""
