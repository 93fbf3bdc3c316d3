"""``pathtracer render`` with one bug-zoo mutant's integrators in the registry.

A renderer that is wrong in a known way, run as an external command (``mitsuba-refs check
--command``), so that a failing comparison, its bounce localisation and its hints are part of
the golden set (tools/golden/record.py)::

    python tools/golden/mutant_render.py extra_inv_pi cornell-box --spp 4 -o out.exr
"""
import sys
from pathlib import Path

ZOO = Path(__file__).resolve().parents[2] / "tests" / "bugzoo"


def main():
    """Run ``pathtracer render ARGS`` with the mutant ``argv[1]``'s integrators registered."""
    mutant_name, args = sys.argv[1], sys.argv[2:]
    sys.path.insert(0, str(ZOO))
    mutant = __import__(mutant_name)
    from pathtracer.cli import main as pathtracer_main
    from pathtracer.scene import registry
    table = registry._FACTORIES["integrator"]  # the one table the command reads
    for name, cls in mutant.INTEGRATORS.items():
        table[name] = cls
    sys.argv = ["pathtracer", "render", *args]
    return pathtracer_main()


if __name__ == "__main__":
    sys.exit(main())
