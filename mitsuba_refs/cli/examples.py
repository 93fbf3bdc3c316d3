"""The examples that end every ``mitsuba-refs`` help page (``mitsuba-refs --help``, and each
command's), kept here so that the commands' modules hold only their options."""

#: ``mitsuba-refs --help``.
TOP = """\
examples:
  mitsuba-refs compare cornell-box --integrator path_nee
  mitsuba-refs check cornell-box --command './render {scene} --spp {spp} --seed {seed} -o {out}'
  mitsuba-refs check cornell-box --images 'renders/*.exr' --spp 64
  mitsuba-refs build cornell-box --integrators path --resolution 32x32
  mitsuba-refs report out/compare/*.json --html out/report

A SCENE is a Mitsuba 3 XML file or a built-in scene name (`pathtracer scenes` lists them).
`mitsuba-refs COMMAND --help` says more about each command."""

#: command -> its examples.
EXAMPLES = {
    "build": """\
examples:
  mitsuba-refs build                                   # every missing or stale built-in reference
  mitsuba-refs build cornell-box --integrators path path_nee
  mitsuba-refs build my_scene.xml --resolution 64x48 --spp 4096
  mitsuba-refs build cornell-box --variant llvm_ad_rgb --force""",
    "compare": """\
examples:
  mitsuba-refs compare cornell-box --integrator path_nee
  mitsuba-refs compare cornell-box --integrator path --resolution 32x32 --no-convergence
  mitsuba-refs compare my_scene.xml -D width=64 -D height=48 --spp 256 --json out/cmp.json
  mitsuba-refs compare veach-mis --detect 2% --max-time 120""",
    "check": """\
examples:
  mitsuba-refs check cornell-box --command './smallpt --width {width} --height {height} \\
      --spp {spp} --seed {seed} --max-depth {max_depth} --out {out}'
  mitsuba-refs check cornell-box --images 'renders/cbox_*.exr' --spp 64
  mitsuba-refs check cornell-box --seeds-for 8 --spp 1024""",
    "report": """\
examples:
  mitsuba-refs report out/compare/results.json --html out/report
  mitsuba-refs report run1.json run2.json --junit junit.xml""",
}
