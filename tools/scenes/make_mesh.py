"""Write ``mesh-bumpy-sphere.ply``, the triangle mesh of ``mesh.xml``.

The mesh is an icosphere (an icosahedron whose faces are split four ways
``LEVEL`` times, new vertices pushed back onto the unit sphere) displaced
along the radius by a smooth, deterministic pattern

.. math::

    r(\\mathbf{p}) = 1 + A \\sin(k p_x) \\sin(k p_y) \\sin(k p_z)
                     + B \\cos(m\\, \\operatorname{atan2}(p_z, p_x))\\, (1 - p_y^2)

(a product of sines gives bumps, the second term ribs around the y axis).
No random numbers are used, so running the script again writes the same
file on any machine with IEEE double arithmetic (only ``+ - * /``, ``sqrt``,
``sin``, ``cos``, ``atan2``; the output is rounded to float32).

The file is binary little-endian PLY with float32 positions and no vertex
normals: Mitsuba (and the renderer under test) then compute smooth,
angle-weighted vertex normals themselves. ``LEVEL = 6`` gives
20 * 4^6 = 81,920 triangles and 40,962 vertices (about 1.5 MB).

Usage: ``python make_mesh.py [output.ply]``.
"""

import sys
from pathlib import Path

import numpy as np

#: Where the built-in scenes live (the default output).
SCENES = Path(__file__).resolve().parents[2] / "pathtracer" / "data" / "scenes"

LEVEL = 6
BUMP_AMPLITUDE = 0.06
BUMP_FREQUENCY = 9.0
RIB_AMPLITUDE = 0.04
RIB_COUNT = 12


def icosahedron():
    """Return the 12 vertices (on the unit sphere) and 20 faces of an
    icosahedron, faces wound counter-clockwise seen from outside."""
    t = (1.0 + np.sqrt(5.0)) / 2.0
    v = np.array([
        [-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0],
        [0, -1, t], [0, 1, t], [0, -1, -t], [0, 1, -t],
        [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]], dtype=np.float64)
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    f = np.array([
        [0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11],
        [1, 5, 9], [5, 11, 4], [11, 10, 2], [10, 7, 6], [7, 1, 8],
        [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9],
        [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]],
        dtype=np.int64)
    return v, f


def subdivide(v, f):
    """Split every triangle into four; midpoints are shared between the two
    faces of an edge and projected onto the unit sphere."""
    edges = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    key = np.sort(edges, axis=1)
    uniq, inverse = np.unique(key, axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    mid = v[uniq[:, 0]] + v[uniq[:, 1]]
    mid /= np.linalg.norm(mid, axis=1, keepdims=True)
    base = len(v)
    n = len(f)
    m01 = base + inverse[:n]
    m12 = base + inverse[n:2 * n]
    m20 = base + inverse[2 * n:]
    a, b, c = f[:, 0], f[:, 1], f[:, 2]
    faces = np.concatenate([
        np.stack([a, m01, m20], 1), np.stack([b, m12, m01], 1),
        np.stack([c, m20, m12], 1), np.stack([m01, m12, m20], 1)])
    return np.concatenate([v, mid]), faces


def displace(v):
    """Move every unit-sphere vertex along its radius (see module doc)."""
    x, y, z = v[:, 0], v[:, 1], v[:, 2]
    k = BUMP_FREQUENCY
    r = (1.0 + BUMP_AMPLITUDE * np.sin(k * x) * np.sin(k * y) * np.sin(k * z)
         + RIB_AMPLITUDE * np.cos(RIB_COUNT * np.arctan2(z, x)) * (1.0 - y * y))
    return v * r[:, None]


def write_ply(path, vertices, faces):
    """Binary little-endian PLY: float32 x, y, z; uchar count + int32 indices."""
    header = (
        "ply\n"
        "format binary_little_endian 1.0\n"
        "comment bumpy icosphere written by pathtracer/scenes/make_mesh.py\n"
        f"element vertex {len(vertices)}\n"
        "property float x\nproperty float y\nproperty float z\n"
        f"element face {len(faces)}\n"
        "property list uchar int vertex_indices\n"
        "end_header\n").encode("ascii")
    face_rec = np.zeros(len(faces), dtype=[("n", "u1"), ("idx", "<i4", (3,))])
    face_rec["n"] = 3
    face_rec["idx"] = faces
    with open(path, "wb") as fh:
        fh.write(header)
        fh.write(np.ascontiguousarray(vertices, dtype="<f4").tobytes())
        fh.write(face_rec.tobytes())


def build(level=LEVEL):
    """Return (vertices float32 (V, 3), faces int32 (F, 3)) of the mesh."""
    v, f = icosahedron()
    for _ in range(level):
        v, f = subdivide(v, f)
    return displace(v).astype(np.float32), f.astype(np.int32)


def main(argv=None):
    """Write the bumpy-sphere PLY (to the path given, else into the built-in scenes)."""
    argv = sys.argv[1:] if argv is None else argv
    out = Path(argv[0]) if argv else SCENES / "mesh-bumpy-sphere.ply"
    vertices, faces = build()
    write_ply(out, vertices, faces)
    print(f"{out}: {len(vertices)} vertices, {len(faces)} triangles, "
          f"{out.stat().st_size} bytes")


if __name__ == "__main__":
    main()
