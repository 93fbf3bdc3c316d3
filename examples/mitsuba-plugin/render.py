"""Render a Mitsuba scene file with an integrator of your own, as ``mitsuba-refs check`` runs it.

A Mitsuba plugin written in Python (``mi.register_integrator``) has no command line of its
own; this script is one::

    python examples/mitsuba-plugin/render.py SCENE.xml --plugin my_integrators.py \\
        --integrator my_path --spp 64 --seed 1 -o out.exr [-D name=value ...]

``--plugin`` is a Python file or an importable module. Importing it must register the
integrator, or it defines ``register()``, which is called. ``--integrator`` replaces the
scene file's ``<integrator>`` (its ``max_depth`` from ``--max-depth``); without it the file's
own is used. The image is the film's, written as OpenEXR with linear ``R G B``.

Exit status: 0 written, 2 bad arguments or a scene/plugin that does not load (one line on
stderr).
"""
from __future__ import annotations

import argparse
import importlib
import importlib.util
import sys
from pathlib import Path


def arguments(argv=None) -> argparse.Namespace:
    """The command line (module docstring)."""
    parser = argparse.ArgumentParser(prog="render.py", description=__doc__.split("\n\n")[0])
    parser.add_argument("scene", help="Mitsuba XML scene file")
    parser.add_argument("--plugin", required=True, help="Python file or module that registers it")
    parser.add_argument("--integrator", default=None, help="the plugin's integrator type")
    parser.add_argument("--spp", type=int, required=True)
    parser.add_argument("--seed", type=int, required=True)
    parser.add_argument("--max-depth", type=int, default=None)
    parser.add_argument("--variant", default="scalar_rgb")
    parser.add_argument("-D", dest="defines", action="append", default=[], metavar="NAME=VALUE")
    parser.add_argument("-o", "--out", required=True)
    args = parser.parse_args(argv)
    if args.spp < 1 or not 0 <= args.seed < 2 ** 32:
        parser.error("--spp must be >= 1 and --seed in [0, 2^32)")
    if any("=" not in define for define in args.defines):
        parser.error("-D takes NAME=VALUE")
    return args


def load_plugin(plugin: str) -> None:
    """Import ``plugin`` (a file or a module) and call its ``register()`` if it has one."""
    if plugin.endswith(".py"):
        spec = importlib.util.spec_from_file_location(Path(plugin).stem, plugin)
        if spec is None or not Path(plugin).is_file():
            raise FileNotFoundError(f"--plugin {plugin}: no such file")
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
    else:
        module = importlib.import_module(plugin)
    if callable(getattr(module, "register", None)):
        module.register()


def main(argv=None) -> int:
    """Render as the arguments say; the exit status (module docstring)."""
    args = arguments(argv)
    import mitsuba as mi  # after the arguments: --help needs no Mitsuba
    mi.set_variant(args.variant)
    try:
        load_plugin(args.plugin)
        defines = dict(define.split("=", 1) for define in args.defines)
        scene = mi.load_file(args.scene, **defines)
        integrator = None
        if args.integrator is not None:
            spec = {"type": args.integrator}
            if args.max_depth is not None:
                spec["max_depth"] = args.max_depth
            integrator = mi.load_dict(spec)
    except Exception as error:     # a scene or plugin that does not load: one line, exit 2
        message = str(error).strip().splitlines()
        print(f"render.py: {message[-1] if message else type(error).__name__}", file=sys.stderr)
        return 2
    image = mi.render(scene, integrator=integrator, spp=args.spp, seed=args.seed)
    mi.Bitmap(image, channel_names=["R", "G", "B"]).write(args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
