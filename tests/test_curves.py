"""Curve shapes (pathtracer.curves): file format, exact hits on a straight tube, the
pieces' error bound, the loader's errors, and hits / normals / uv against Mitsuba's own
``bsplinecurve`` and ``linearcurve`` plugins (scalar_rgb ``ray_intersect``)."""
import numpy as np
import pytest

from pathtracer.scene.errors import SceneError
from pathtracer.scene.load import load_scene
from pathtracer.shapes.curves import CurveFileError, CurveShape, bspline, chord_error, read_control_points

# A zigzag (the control points of Mitsuba's documentation curve) and a closed loop.
ZIGZAG = "-1 0 -1 0.1\n-0.5 0 1 0.1\n-0.25 0 -1 0.1\n0 0 1 0.1\n0.25 0 -1 0.1\n0.5 0 1 0.1\n1 0 -1 0.1\n"


def _loop(n=24, radius=0.5, tube=0.02):
    a = 2 * np.pi * np.arange(n + 3) / n       # 3 points repeated: the spline closes
    return "\n".join(f"{radius * np.cos(t)} {radius * np.sin(t)} {0.3 * np.sin(2 * t)} {tube}"
                     for t in a) + "\n"


def _write(tmp_path, text, name="curve.txt"):
    path = tmp_path / name
    path.write_text(text)
    return str(path)


def test_file_format_blank_lines_start_curves(tmp_path):
    path = _write(tmp_path, ZIGZAG + "\n\n" + "0 0 0 1\n1 0 0 1\n2 0 0 1\n3 0 0 2\n")
    curves = read_control_points(path, 4)
    assert [c.shape for c in curves] == [(7, 4), (4, 4)]
    assert curves[1][3].tolist() == [3, 0, 0, 2]
    with pytest.raises(CurveFileError, match="line 1: a curve needs at least 4"):
        read_control_points(_write(tmp_path, "0 0 0 1\n1 0 0 1\n"), 4)
    with pytest.raises(CurveFileError, match="line 2: expected four numbers"):
        read_control_points(_write(tmp_path, "0 0 0 1\n1 0 x 1\n"), 2)


def test_straight_bspline_is_an_open_cylinder_and_culls_back_faces():
    """Collinear points along x, radius 0.5: hits from the side at distance 1.5 with
    normal -d; a ray from inside, and one down the open end, pass through (no caps, no
    back faces); the linear curve of the same points has round caps."""
    pts = np.array([[x, 0.0, 0.0, 0.5] for x in range(6)])
    tube = CurveShape([pts], "bspline", 0)
    o = np.array([[2.5, 0, 2.0], [2.5, 0, 0.0], [-5, 0, 0]])
    d = np.array([[0, 0, -1.0], [0, 0, 1.0], [1.0, 0, 0]])
    t, piece, s, _ = tube.intersect(o, d, None)
    assert t[0] == pytest.approx(1.5, abs=1e-12) and np.isinf(t[1]) and np.isinf(t[2])
    normal, uv = tube.surface(o[:1] + t[0] * d[:1], piece[:1], s[:1])
    np.testing.assert_allclose(normal[0], [0, 0, 1], atol=1e-9)
    # c(v) runs from x = 1 to 4 over 3 segments: x = 2.5 is v = 0.5 of the whole file.
    assert uv[0, 1] == pytest.approx(0.5, abs=1e-9)
    capped = CurveShape([pts], "linear", 0)
    t, *_ = capped.intersect(o[2:], d[2:], None)
    assert t[0] == pytest.approx(4.5, abs=1e-12)          # the sphere of radius 0.5 at x = 0


def test_pieces_stay_within_the_stated_error_bound(tmp_path):
    """The polyline of each segment's pieces is within chord_error of the centre line
    (checked at 50 points per piece of the zigzag)."""
    pts = read_control_points(_write(tmp_path, ZIGZAG), 4)[0]
    tube = CurveShape([pts], "bspline", 0)
    seg, v0, v1 = tube.piece_segment, tube.piece_v0, tube.piece_v1
    s = np.linspace(0, 1, 50)
    v = (v0[:, None] + s * (v1 - v0)[:, None]).ravel()
    sid = np.repeat(seg, len(s))
    c, *_ = bspline(tube.segments[sid], v)
    a, *_ = bspline(tube.segments[seg], v0)
    b, *_ = bspline(tube.segments[seg], v1)
    chord = np.repeat(a, len(s), 0) + np.tile(s, len(seg))[:, None] * np.repeat(b - a, len(s), 0)
    gap = np.linalg.norm(c - chord, axis=1).reshape(len(seg), -1).max(axis=1)
    counts = np.bincount(seg)
    assert np.all(gap <= chord_error(tube.segments[seg], counts[seg]) * (1 + 1e-9))
    diagonal = np.linalg.norm(pts[:, :3].max(0) - pts[:, :3].min(0))   # control points' box
    assert tube.max_chord_error <= 1e-5 * diagonal


def _scene_xml(tmp_path, shape):
    return _write(tmp_path, f"""<scene version="3.0.0">
  <sensor type="perspective"><film type="hdrfilm"><integer name="width" value="8"/>
    <integer name="height" value="8"/><rfilter type="box"/></film></sensor>
  {shape}
</scene>""", "scene.xml")


def test_loader_reads_curves_and_refuses_what_it_cannot_render(tmp_path):
    _write(tmp_path, ZIGZAG)
    scene = load_scene(_scene_xml(tmp_path, '<shape type="linearcurve"><string name="filename" '
                                            'value="curve.txt"/></shape>'))
    assert scene.shape_kind == ["curve"] and len(scene.curves[0].segments) == 6
    with pytest.raises(SceneError, match="area emitter on a curve"):
        load_scene(_scene_xml(tmp_path, '<shape type="bsplinecurve"><string name="filename" '
                                        'value="curve.txt"/><emitter type="area"/></shape>'))
    _write(tmp_path, "0 0 0 1\n1 0 0 1\n", "short.txt")
    with pytest.raises(SceneError, match=r"scene.xml:5: .*short.txt: line 1: a curve needs"):
        load_scene(_scene_xml(tmp_path, '<shape type="bsplinecurve">\n<string name="filename" '
                                        'value="short.txt"/></shape>'))


def _rays(lo, hi, n, seed):
    rng = np.random.default_rng(seed)
    centre, size = (lo + hi) / 2, np.linalg.norm(hi - lo)
    o = rng.normal(size=(n, 3))
    o = centre + 2 * size * o / np.linalg.norm(o, axis=1, keepdims=True)
    d = lo + rng.random((n, 3)) * (hi - lo) - o
    return o, d / np.linalg.norm(d, axis=1, keepdims=True)


CASES = [  # (file, kind, to_world): the closed loop, and the documentation scenes' zigzags
    ("loop", "bspline", np.eye(4)),
    ("zigzag", "bspline", np.diag([4.0, 1, 1, 1]) @ np.array(
        [[-0.7071, 0.7071, 0, 0], [-0.7071, -0.7071, 0, 0], [0, 0, 1, 1], [0, 0, 0, 1]])),
    ("zigzag", "linear", np.diag([2.0, 1, 0.5, 1]) @ np.array(
        [[-0.7071, 0.7071, 0, 0], [-0.7071, -0.7071, 0, 0], [0, 0, 1, 2], [0, 0, 0, 1]])),
]


@pytest.mark.mitsuba
@pytest.mark.parametrize("name,kind,to_world", CASES, ids=["loop-bspline", "zigzag-bspline",
                                                           "zigzag-linear"])
def test_hits_normals_uv_match_mitsuba(tmp_path, name, kind, to_world, mi):
    """300 rays through the bounding box: the same rays hit (at most one grazing ray may
    differ), t within 1e-4 of the scene size (the pieces' 1e-5 plus Mitsuba's float32),
    normals within 0.25 degrees, uv within 1e-3."""
    from pathtracer.scene import transform
    path = _write(tmp_path, _loop() if name == "loop" else ZIGZAG)
    curves = [np.column_stack([transform.apply_points(to_world, c[:, :3]), c[:, 3]])
              for c in read_control_points(path, 4 if kind == "bspline" else 2)]
    ours = CurveShape(curves, kind, 0)
    theirs = mi.load_dict({"type": "scene", "c": {
        "type": f"{kind}curve", "filename": path, "to_world": mi.ScalarTransform4f(to_world.tolist())}})
    lo, hi = ours.bounds()
    o, d = _rays(lo, hi, 300, seed=3)
    t, piece, s, _ = ours.intersect(o, d, None)
    ref_t, ref_n, ref_uv = np.full(len(o), np.inf), np.zeros((len(o), 3)), np.zeros((len(o), 2))
    for i in range(len(o)):
        si = theirs.ray_intersect(mi.Ray3f(o[i].tolist(), d[i].tolist()))
        if si.is_valid():
            ref_t[i], ref_n[i], ref_uv[i] = si.t, np.array(si.n), np.array(si.uv)
    hit, ref_hit = np.isfinite(t), np.isfinite(ref_t)
    assert ref_hit.sum() > 20 and (hit != ref_hit).sum() <= 1
    both = np.flatnonzero(hit & ref_hit)
    normal, uv = ours.surface(o[both] + t[both, None] * d[both], piece[both], s[both])
    size = np.linalg.norm(hi - lo)
    assert np.max(np.abs(t[both] - ref_t[both])) < 1e-4 * size
    angle = np.degrees(np.arccos(np.clip(np.sum(normal * ref_n[both], axis=1), -1, 1)))
    assert angle.max() < 0.25
    du = np.abs(uv - ref_uv[both])
    du[:, 0] = np.minimum(du[:, 0], 1 - du[:, 0])      # u wraps around
    assert du.max() < 1e-3
