"""The grader's side of the student process (:mod:`autograder.sandbox` is the child's side).

* :mod:`.process`      -- :class:`~.process.StudentProcess`: one test's submission in a
  sandboxed child, the conversation with it, its limits and failures
* :mod:`.environment`  -- where and as whom the child runs, and the audit that the student
  user can read nothing private
* :mod:`.runtime`      -- the student runtime the child runs from: the tracer without the
  reference solution, and the sandbox's code
"""
