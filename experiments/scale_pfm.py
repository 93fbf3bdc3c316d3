"""Scale a colour PFM by a factor (a stand-in for a renderer with a known bias).

    python scale_pfm.py IN.pfm OUT.pfm FACTOR

Standard library only, so that it adds milliseconds to a run
(experiments/check_calibration.py, ``--bias``).
"""
import struct
import sys


def main(source, target, factor):
    """Write ``target``: ``source``'s pixels times ``factor``, same header."""
    data = open(source, "rb").read()
    header_end = 0
    for _ in range(3):                     # "PF", "W H", scale: three lines
        header_end = data.index(b"\n", header_end) + 1
    header, pixels = data[:header_end], data[header_end:]
    endian = "<" if float(header.split()[3]) < 0 else ">"
    count = len(pixels) // 4
    values = struct.unpack(f"{endian}{count}f", pixels)
    with open(target, "wb") as out:
        out.write(header + struct.pack(f"{endian}{count}f", *(v * factor for v in values)))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], float(sys.argv[3]))
