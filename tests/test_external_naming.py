"""The name a report gives an external renderer (:mod:`mitsuba_refs.external.naming`)."""
import pytest

from mitsuba_refs.errors import RefsInputError
from mitsuba_refs.external.naming import checked_name, short_name


@pytest.mark.parametrize("command, name", [
    ("./smallpt --spp {spp} --seed {seed} --out {out}", "smallpt"),
    ("nice -n 10 ./bin/smallpt --spp {spp}", "smallpt"),
    ("OMP_NUM_THREADS=2 timeout 60 mitsuba -m scalar_rgb -o {out} {scene}", "mitsuba"),
    ("env -u DISPLAY FOO=1 /opt/pbrt/pbrt --spp {spp}", "pbrt"),
    ("timeout -s KILL 60 ./r {out}", "r"),
    ("taskset -c 0,1 ionice -c 3 -n 7 ./tracer {out}", "tracer"),
    ("/usr/bin/python3 -m pathtracer.cli render {scene}", "pathtracer"),
    ("python3 examples/cycles/render.py {scene} -o {out}", "cycles-render"),
    ("python -u tracer.py {out}", "tracer"),
    ("sh -c './a.out {out}'", "a.out"),
    ("python -c 'print(1)' {out}", "python"),
    ("", "renderer"),
    ("./unbalanced 'quote {out}", "unbalanced"),
])
def test_short_name_skips_wrappers_and_names_scripts(command, name):
    assert short_name(command) == name


def test_long_program_names_are_clipped():
    assert short_name("./" + "x" * 100 + " {out}") == "x" * 39 + "\u2026"


@pytest.mark.parametrize("bad", ["", "  ", "two\nlines", "x" * 41])
def test_a_name_that_cannot_head_a_report_is_refused_in_one_line(bad):
    with pytest.raises(RefsInputError, match="--name"):
        checked_name(bad)


def test_a_name_keeps_its_words():
    assert checked_name(" my renderer v2 ") == "my renderer v2"
