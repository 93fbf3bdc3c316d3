"""A stand-in renderer for the fault tests of ``mitsuba-refs check``: it writes a colour PFM of
one value (``nan``, ``inf`` and negative values included) and can misbehave on request.

    python constant_renderer.py --width W --height H --value V --out FILE [--seed S]
                                [--noise A [--pixel-streams]] [--exit CODE] [--sleep SECONDS]

``--noise A`` adds A times a pseudo-random number of ``--seed`` to every pixel (independent
images per seed; with ``--pixel-streams`` pixel ``i`` draws from the stream of seed ``seed + i``,
so that seed ``s + 1`` replays seed ``s`` one pixel further on); ``--exit`` ends with that
status after a line on stderr; ``--sleep`` waits first (and starts a child that sleeps as long,
to test that the whole group is killed).
Standard library only, so that a run starts in milliseconds.
"""
import argparse
import random
import struct
import subprocess
import sys
import time


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--width", type=int, required=True)
    parser.add_argument("--height", type=int, required=True)
    parser.add_argument("--value", type=float, default=0.5)
    parser.add_argument("--out", required=True)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--noise", type=float, default=0.0)
    parser.add_argument("--exit", type=int, default=0)
    parser.add_argument("--sleep", type=float, default=0.0)
    parser.add_argument("--pixel-streams", action="store_true")
    args = parser.parse_args()
    if args.sleep:
        subprocess.Popen([sys.executable, "-c", f"import time; time.sleep({args.sleep})"])
        time.sleep(args.sleep)
    if args.exit:
        print("constant_renderer: failing on purpose", file=sys.stderr)
        sys.exit(args.exit)
    count = args.width * args.height * 3
    if args.pixel_streams:      # pixel i draws from stream seed + i, as Mitsuba's command line
        values = [args.value + args.noise * value for i in range(args.width * args.height)
                  for value in _three(random.Random(args.seed + i))]
    else:
        rng = random.Random(args.seed)
        values = [args.value + args.noise * rng.random() for _ in range(count)]
    with open(args.out, "wb") as out:
        out.write(f"PF\n{args.width} {args.height}\n-1.0\n".encode())
        out.write(struct.pack(f"<{count}f", *values))


def _three(rng):
    return [rng.random() for _ in range(3)]


if __name__ == "__main__":
    main()
