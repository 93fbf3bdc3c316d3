"""``normalmap`` and ``bumpmap``: the nested BSDF in a perturbed shading frame.

Values, densities and samples are compared with Mitsuba 3's plugins for one shading point
set up identically on both sides (identity shading frame, given geometric normal,
``dp_du``, ``dp_dv`` and ``uv``), at many directions and texture coordinates; a
chi-square test checks sampling against the density. Also: the surface derivatives the
frames are built from, against Mitsuba's intersections.
"""
from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from pathtracer.bsdfs import BumpMap, Diffuse, NormalMap, RoughConductor, RoughPlastic
from pathtracer.io.bitmap import read_bitmap
from pathtracer.shapes.tangents import LocalGeometry
from pathtracer.textures import BitmapTexture
from tests.chi2 import chi2_sphere
from tests.test_bsdfs import _assert_close, _f32, direction, random_directions, tile

statistical = pytest.mark.statistical(assertions=1)
N_GEO = np.array([0.15, -0.1, 1.0]) / np.linalg.norm([0.15, -0.1, 1.0])
DP_DU, DP_DV = np.array([1.3, 0.2, 0.1]), np.array([-0.1, 0.9, -0.2])


@pytest.fixture(scope="module")
def maps(tmp_path_factory):
    """A smooth random normal map (z dominant) and height map, written as 8-bit PNGs."""
    folder = tmp_path_factory.mktemp("maps")
    rng = np.random.default_rng(900)
    y, x = np.mgrid[0:16, 0:16] / 16.0
    nx, ny = 0.5 + 0.35 * np.sin(2 * np.pi * (x + rng.random())), 0.5 + 0.35 * np.cos(2 * np.pi * y)
    normal = np.stack((nx, ny, np.full_like(nx, 0.9)), axis=2)
    height = 0.5 + 0.4 * np.sin(2 * np.pi * (x + 2 * y))
    paths = {}
    for name, data in (("normal", normal), ("height", height)):
        paths[name] = str(folder / f"{name}.png")
        Image.fromarray(np.round(255 * data).astype(np.uint8)).save(paths[name])
    return paths


def _ours(name, maps):
    normal = BitmapTexture(read_bitmap(maps["normal"], raw=True))
    height = BitmapTexture(read_bitmap(maps["height"], raw=True))
    red = [0.8, 0.3, 0.2]
    return {
        "normalmap_diffuse": NormalMap(Diffuse(red), normal),
        "normalmap_anisotropic": NormalMap(RoughConductor("ggx", 0.3, 0.05, red), normal),
        "bumpmap_roughplastic": BumpMap(RoughPlastic("beckmann", 0.2, red), height, 0.3),
        "bumpmap_anisotropic": BumpMap(RoughConductor("beckmann", 0.05, 0.3, red), height, 0.2,
                                       use_shadowing_function=False),
    }[name]


def _theirs(name, maps):
    red = {"type": "rgb", "value": [0.8, 0.3, 0.2]}
    normal = {"type": "bitmap", "filename": maps["normal"], "raw": True}
    height = {"type": "bitmap", "filename": maps["height"], "raw": True}
    return {
        "normalmap_diffuse": {"type": "normalmap", "normalmap": normal,
                              "bsdf": {"type": "diffuse", "reflectance": red}},
        "normalmap_anisotropic": {"type": "normalmap", "normalmap": normal,
                                  "bsdf": {"type": "roughconductor", "distribution": "ggx",
                                           "alpha_u": 0.3, "alpha_v": 0.05,
                                           "specular_reflectance": red}},
        "bumpmap_roughplastic": {"type": "bumpmap", "scale": 0.3, "h": height,
                                 "bsdf": {"type": "roughplastic", "distribution": "beckmann",
                                          "alpha": 0.2, "diffuse_reflectance": red}},
        "bumpmap_anisotropic": {"type": "bumpmap", "scale": 0.2, "h": height,
                                "use_shadowing_function": False,
                                "bsdf": {"type": "roughconductor", "distribution": "beckmann",
                                         "alpha_u": 0.05, "alpha_v": 0.3,
                                         "specular_reflectance": red}},
    }[name]


CASES = ["normalmap_diffuse", "normalmap_anisotropic", "bumpmap_roughplastic", "bumpmap_anisotropic"]


def _geometry(n: int) -> LocalGeometry:
    """The shading point of both sides: identity shading frame (so local = world)."""
    rows = np.ones((n, 1))
    return LocalGeometry(N_GEO * rows, DP_DU * rows, DP_DV * rows,
                         np.array([1.0, 0.0, 0.0]) * rows, DP_DU * rows)


class _MitsubaPoint:
    def __init__(self, mi, spec):
        self.mi, self.bsdf, self.ctx = mi, mi.load_dict(spec), mi.BSDFContext()
        si = mi.SurfaceInteraction3f()
        si.sh_frame = mi.Frame3f(mi.Vector3f(1, 0, 0), mi.Vector3f(0, 1, 0), mi.Vector3f(0, 0, 1))
        si.n = mi.Normal3f(*N_GEO)
        si.dp_du, si.dp_dv = mi.Vector3f(*DP_DU), mi.Vector3f(*DP_DV)
        self.si = si

    def eval_pdf(self, wi, wo, uv):
        values, pdfs = [], []
        for a, b, c in zip(wi, wo, uv):
            self.si.wi, self.si.uv = self.mi.Vector3f(*a), self.mi.Point2f(*c)
            v = self.bsdf.eval(self.ctx, self.si, self.mi.Vector3f(*b))
            values.append([v[0], v[1], v[2]])
            pdfs.append(self.bsdf.pdf(self.ctx, self.si, self.mi.Vector3f(*b)))
        return np.array(values), np.array(pdfs)

    def sample(self, wi, u1, u2, uv):
        wo, weight, pdf = [], [], []
        for a, s1, s2, c in zip(wi, u1, u2, uv):
            self.si.wi, self.si.uv = self.mi.Vector3f(*a), self.mi.Point2f(*c)
            bs, w = self.bsdf.sample(self.ctx, self.si, float(s1), self.mi.Point2f(*s2))
            wo.append([bs.wo[0], bs.wo[1], bs.wo[2]])
            weight.append([w[0], w[1], w[2]])
            pdf.append(bs.pdf)
        return np.array(wo), np.array(weight), np.array(pdf)


@pytest.mark.mitsuba
@pytest.mark.parametrize("name", CASES)
def test_mitsuba_eval_pdf_sample(name, maps, mi):
    ours, theirs = _ours(name, maps), _MitsubaPoint(mi, _theirs(name, maps))
    n, rng = 300, np.random.default_rng(910)
    uv = _f32(rng.random((n, 2)))
    bound = ours.at(uv, _geometry(n))
    wi = _f32(random_directions(n, 911, True))
    u1, u2 = _f32(rng.random(n)), _f32(np.clip(rng.random((n, 2)), 1e-6, 1 - 1e-6))
    wo = _f32(np.concatenate((random_directions(n // 2, 912),
                              bound.sample(wi, u1, u2).wo[n // 2:])))
    value, pdf = theirs.eval_pdf(wi, wo, uv)
    assert np.count_nonzero(pdf) > n // 3
    _assert_close(bound.eval(wi, wo), value, rtol=2e-3, floor=1e-4, what=f"{name} eval")
    _assert_close(bound.pdf(wi, wo), pdf, rtol=2e-3, floor=1e-4, what=f"{name} pdf")
    ref_wo, ref_weight, ref_pdf = theirs.sample(wi, u1, u2, uv)
    bs = bound.sample(wi, u1, u2)
    their_valid = np.any(ref_weight > 0, axis=1)
    ours_valid = bs.valid & np.any(bs.weight > 0, axis=1)
    close = np.linalg.norm(bs.wo - ref_wo, axis=1) < 1e-3
    same = (ours_valid == their_valid) & (close | ~ours_valid)
    assert same.mean() > 0.97, same.mean()
    both = same & ours_valid
    assert both.mean() > 0.3
    _assert_close(bs.weight[both], ref_weight[both], rtol=3e-3, what=f"{name} sample weight")
    _assert_close(bs.pdf[both], ref_pdf[both], rtol=3e-3, floor=1e-4, what=f"{name} sample pdf")


@statistical
@pytest.mark.parametrize("name, theta", [("normalmap_anisotropic", 30.0), ("bumpmap_roughplastic", 60.0)])
def test_chi2(name, theta, maps):
    """Directions sampled in the perturbed frame follow pdf() (rejected ones: the null cell)."""
    ours, wi, uv = _ours(name, maps), direction(theta), np.array([[0.3, 0.6]])

    def sample(u):
        bound = ours.at(np.repeat(uv, len(u), 0), _geometry(len(u)))
        bs = bound.sample(tile(wi, len(u)), u[:, 0], u[:, 1:])
        return bs.wo, bs.valid

    def pdf(wo):
        return ours.at(np.repeat(uv, len(wo), 0), _geometry(len(wo))).pdf(tile(wi, len(wo)), wo)

    result = chi2_sphere(sample, pdf, n_samples=60_000, seed=920 + int(theta))
    assert result.passed, result.message


@pytest.mark.mitsuba
def test_mitsuba_surface_derivatives(tmp_path, mi):
    """dp/du, dp/dv of every shape kind as Mitsuba's intersections report them."""
    from pathtracer import load_scene
    from pathtracer.shapes.intersect import intersect
    from pathtracer.shapes.tangents import surface_derivatives
    from tests.test_scene_plugins import _rays, _write
    body = """
<shape type="sphere"><point name="center" value="0.8, 0.3, 0.5"/><float name="radius" value="0.5"/>
  <transform name="to_world"><rotate x="1" angle="30"/></transform></shape>
<shape type="disk"><transform name="to_world"><scale value="0.7"/><rotate y="1" angle="20"/>
  <translate x="-1" z="0.2"/></transform></shape>
<shape type="cylinder"><float name="radius" value="0.3"/><transform name="to_world">
  <translate x="-0.2" y="1"/></transform></shape>
<shape type="rectangle"><transform name="to_world"><scale x="2" y="0.8"/><rotate x="1" angle="-80"/>
  <translate y="1.6"/></transform></shape>
<shape type="cube"><transform name="to_world"><scale value="0.3"/><rotate z="1" angle="35"/>
  <translate x="0.2" y="-0.6" z="1.2"/></transform></shape>"""
    path = _write(tmp_path, body)
    scene, mi_scene = load_scene(path), mi.load_file(path)
    o, d = _rays(2000, 930)
    hit = intersect(scene, o, d)
    rows = np.flatnonzero(hit.valid)
    dp_du, dp_dv = surface_derivatives(scene, hit, rows)
    kinds = set()
    for k, r in enumerate(rows):
        si = mi_scene.ray_intersect(mi.Ray3f(mi.Point3f(*o[r]), mi.Vector3f(*d[r])))
        if not si.is_valid() or abs(si.t - hit.t[r]) > 1e-4 * (1 + hit.t[r]):
            continue
        kinds.add(scene.shape_kind[hit.shape[r]])
        scale = 1e-3 * (1 + np.linalg.norm(dp_du[k]) + np.linalg.norm(dp_dv[k]))
        np.testing.assert_allclose(dp_du[k], np.array(si.dp_du), atol=scale)
        np.testing.assert_allclose(dp_dv[k], np.array(si.dp_dv), atol=scale)
    assert kinds == {"sphere", "disk", "cylinder", "mesh"}


@pytest.mark.mitsuba
def test_mitsuba_bsdfs_at_hits(tmp_path, maps, mi):
    """BSDF values at real hits, world directions: anisotropic roughness follows Mitsuba's
    tangent (dp/du), and normal / bump maps perturb the frames Mitsuba perturbs."""
    from pathtracer import load_scene
    from pathtracer.bsdfs.shading import eval_bsdf
    from pathtracer.shapes.intersect import intersect
    from tests.test_scene_plugins import _rays, _write
    aniso = '<bsdf type="roughconductor"><float name="alpha_u" value="0.4"/><float name="alpha_v" value="0.05"/>' \
            '<string name="distribution" value="ggx"/></bsdf>'
    nmap = f'<bsdf type="normalmap"><texture type="bitmap" name="normalmap"><boolean name="raw" value="true"/>' \
           f'<string name="filename" value="{maps["normal"]}"/></texture><bsdf type="diffuse"/></bsdf>'
    bump = f'<bsdf type="bumpmap"><float name="scale" value="0.3"/><texture type="bitmap" name="h">' \
           f'<boolean name="raw" value="true"/><string name="filename" value="{maps["height"]}"/></texture>' \
           f'<bsdf type="roughplastic"/></bsdf>'
    body = f"""
<shape type="sphere"><point name="center" value="0.8, 0.3, 0.5"/><float name="radius" value="0.5"/>
  <transform name="to_world"><rotate x="1" angle="30"/></transform>{aniso}</shape>
<shape type="rectangle"><transform name="to_world"><scale x="2" y="0.8"/><rotate x="1" angle="-80"/>
  <rotate z="1" angle="20"/><translate y="1.6"/></transform>{aniso}</shape>
<shape type="cube"><transform name="to_world"><scale value="0.3"/><rotate z="1" angle="35"/>
  <translate x="0.2" y="-0.6" z="1.2"/></transform>{nmap}</shape>
<shape type="cylinder"><float name="radius" value="0.3"/><transform name="to_world">
  <translate x="-0.8" y="0.5"/></transform>{bump}</shape>
<shape type="disk"><transform name="to_world"><scale value="0.7"/><rotate y="1" angle="20"/>
  <translate x="-1" z="1.4"/></transform>{nmap}</shape>"""
    path = _write(tmp_path, body)
    scene, mi_scene = load_scene(path), mi.load_file(path)
    o, d = _rays(1500, 940)
    hit = intersect(scene, o, d)
    rows = np.flatnonzero(hit.valid)
    wo = random_directions(len(rows), 941)
    # Directions near the sampled lobe too, so that the narrow anisotropic lobe is seen.
    wo[::2] = (-d[rows] + 2 * np.einsum("ij,ij->i", d[rows], hit.sh_n[rows])[:, None] * (-hit.sh_n[rows]))[::2]
    wo[::2] = wo[::2] + 0.15 * random_directions(len(rows), 942)[::2]
    wo = wo / np.linalg.norm(wo, axis=1)[:, None]
    sub = type(hit)(**{k: v[rows] for k, v in vars(hit).items()})
    value, pdf = eval_bsdf(scene, sub, -d[rows], wo)
    ctx, kinds, compared = mi.BSDFContext(), set(), 0
    for k, r in enumerate(rows):
        si = mi_scene.ray_intersect(mi.Ray3f(mi.Point3f(*o[r]), mi.Vector3f(*d[r])))
        if not si.is_valid() or abs(si.t - hit.t[r]) > 1e-5 * (1 + hit.t[r]):
            continue
        local = si.to_local(mi.Vector3f(*wo[k]))
        theirs = si.bsdf().eval(ctx, si, local)
        their_pdf = si.bsdf().pdf(ctx, si, local)
        scale = 1e-3 * (1.0 + abs(theirs[0]))
        assert abs(value[k, 0] - theirs[0]) < max(scale, 2e-3 * abs(theirs[0])), (k, value[k], theirs)
        assert abs(pdf[k] - their_pdf) < max(1e-3 * (1 + abs(their_pdf)), 2e-3 * abs(their_pdf)), (k, pdf[k], their_pdf)
        kinds.add(scene.shape_kind[hit.shape[r]])
        compared += 1
    assert kinds == {"sphere", "mesh", "cylinder", "disk"} and compared > 300
