"""``python -m autograder.batch``: :func:`autograder.batch.main`."""
from . import main

raise SystemExit(main())
