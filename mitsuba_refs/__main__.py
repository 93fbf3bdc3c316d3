"""``python -m mitsuba_refs``: the ``mitsuba-refs`` command (:mod:`mitsuba_refs.cli.main`)."""
import sys

from .cli.main import main

if __name__ == "__main__":
    sys.exit(main())
