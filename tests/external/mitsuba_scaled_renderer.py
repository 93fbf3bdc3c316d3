"""Mitsuba 3 itself as an external renderer whose lights are in other units: it renders a scene
file with ``scalar_rgb`` and writes the image times a factor as a colour PFM (the tests of
differences of convention, tests/test_conventions.py).

    python mitsuba_scaled_renderer.py SCENE --spp N --seed S --max-depth D --width W
                                      --height H --factor F --out FILE
"""
import argparse

import mitsuba as mi
import numpy as np


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("scene")
    for name in ("--spp", "--seed", "--max-depth", "--width", "--height"):
        parser.add_argument(name, type=int, required=True)
    parser.add_argument("--factor", type=float, default=1.0)
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    mi.set_variant("scalar_rgb")
    scene = mi.load_file(args.scene, width=args.width, height=args.height,
                         max_depth=args.max_depth, spp=args.spp)
    image = np.array(mi.render(scene, seed=args.seed, spp=args.spp), dtype="<f4") * args.factor
    with open(args.out, "wb") as out:      # PFM: bottom row first, little-endian
        out.write(f"PF\n{args.width} {args.height}\n-1.0\n".encode())
        out.write(np.ascontiguousarray(image[::-1], dtype="<f4").tobytes())


if __name__ == "__main__":
    main()
