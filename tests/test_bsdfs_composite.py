"""BSDF plugins of users' Mitsuba scenes built from others: textured plastic and roughness
parameters, ``blendbsdf``, ``mask`` and ``twosided`` with a BSDF per side.

Chi-square of sample() against pdf() (the suite's per-test alpha), then eval, pdf and
sample against Mitsuba 3's own plugins at varying texture coordinates (scalar_rgb,
marked ``mitsuba``).
"""
from __future__ import annotations

import numpy as np
import pytest

from pathtracer.bsdfs import (
    BlendBSDF,
    Conductor,
    Diffuse,
    MaskBSDF,
    Plastic,
    RoughConductor,
    RoughDielectric,
    RoughPlastic,
    TwoSided,
)
from pathtracer.io.bitmap import read_bitmap
from pathtracer.textures import BitmapTexture, Checkerboard
from tests.chi2 import chi2_sphere
from tests.scenes import GRID_PNG
from tests.test_bsdfs import _assert_close, _f32, direction, random_directions, tile

statistical = pytest.mark.statistical(assertions=1)
SCALE_UV = np.diag([4.0, 3.0, 1.0, 1.0])   # the loader's to_uv of <scale x="4" y="3"/>


def _checker(c0, c1):
    return Checkerboard(c0, c1, to_uv=SCALE_UV)


def _checker_spec(c0, c1):
    def value(c):
        return {"type": "rgb", "value": list(c)} if np.ndim(c) else float(c)
    return {"type": "checkerboard", "color0": value(c0), "color1": value(c1),
            "to_uv": _mi_scale()}


def _mi_scale():
    import mitsuba as mi
    return mi.ScalarTransform4f().scale([4.0, 3.0, 1.0])


# Each case: (name, our BSDF, Mitsuba's dict) built lazily (Mitsuba's dict needs mitsuba).
def _cases():
    red, blue = [0.8, 0.2, 0.1], [0.1, 0.3, 0.9]
    gold = {"eta": [0.2, 0.5, 1.4], "k": [3.5, 2.4, 1.8]}
    mi_gold = {"type": "conductor", "eta": {"type": "rgb", "value": gold["eta"]},
               "k": {"type": "rgb", "value": gold["k"]}}
    rough = {"type": "roughconductor", "distribution": "ggx", "alpha": 0.3,
             "specular_reflectance": {"type": "rgb", "value": blue}}
    diffuse = {"type": "diffuse", "reflectance": {"type": "rgb", "value": red}}
    return {
        "plastic": (Plastic(_checker(red, blue), _checker(1.0, 0.6), 1.5, 1.0),
                    lambda: {"type": "plastic", "int_ior": 1.5, "ext_ior": 1.0,
                             "diffuse_reflectance": _checker_spec(red, blue),
                             "specular_reflectance": _checker_spec(1.0, 0.6)}),
        "roughplastic": (RoughPlastic("beckmann", 0.2, _checker(red, 0.3), 1.0, 1.5, 1.0, True),
                         lambda: {"type": "roughplastic", "distribution": "beckmann", "alpha": 0.2,
                                  "int_ior": 1.5, "ext_ior": 1.0, "nonlinear": True,
                                  "diffuse_reflectance": _checker_spec(red, 0.3)}),
        "roughconductor": (RoughConductor("beckmann", _checker(0.05, 0.3), _checker(0.3, 0.05),
                                          red, gold["eta"], gold["k"]),
                           lambda: {"type": "roughconductor", "distribution": "beckmann",
                                    "alpha_u": _checker_spec(0.05, 0.3),
                                    "alpha_v": _checker_spec(0.3, 0.05),
                                    "specular_reflectance": {"type": "rgb", "value": red},
                                    "eta": {"type": "rgb", "value": gold["eta"]},
                                    "k": {"type": "rgb", "value": gold["k"]}}),
        "roughdielectric": (RoughDielectric("ggx", _checker(0.0, 0.4), None, 1.5, 1.0),
                            lambda: {"type": "roughdielectric", "distribution": "ggx",
                                     "alpha": _checker_spec(0.0, 0.4), "int_ior": 1.5,
                                     "ext_ior": 1.0}),
        "blend": (BlendBSDF(Diffuse(red), RoughConductor("ggx", 0.3, None, blue),
                            _checker(0.2, [0.9, 0.5, 0.7])),
                  lambda: {"type": "blendbsdf", "weight": _checker_spec(0.2, [0.9, 0.5, 0.7]),
                           "a": diffuse, "b": rough}),
        "blend_delta": (BlendBSDF(Conductor(1.0, gold["eta"], gold["k"]), Diffuse(red), 0.35),
                        lambda: {"type": "blendbsdf", "weight": 0.35, "a": mi_gold, "b": diffuse}),
        "mask": (MaskBSDF(RoughConductor("ggx", 0.3, None, blue), _checker(0.25, 0.9)),
                 lambda: {"type": "mask", "opacity": _checker_spec(0.25, 0.9), "m": rough}),
        "twosided_two": (TwoSided(Diffuse(red), RoughConductor("ggx", 0.3, None, blue)),
                         lambda: {"type": "twosided", "a": diffuse, "b": rough}),
    }


CASES = _cases()


class _MitsubaAt:
    """Mitsuba's scalar BSDF calls, identity shading frame, at given texture coordinates."""

    def __init__(self, mi, spec: dict):
        self.mi, self.bsdf, self.ctx = mi, mi.load_dict(spec), mi.BSDFContext()
        self.si = mi.SurfaceInteraction3f()
        self.si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))

    def _at(self, wi, uv):
        self.si.wi, self.si.uv = self.mi.Vector3f(*wi), self.mi.Point2f(*uv)

    def eval_pdf(self, wi, wo, uv):
        values, pdfs = [], []
        for a, b, c in zip(wi, wo, uv):
            self._at(a, c)
            v = self.bsdf.eval(self.ctx, self.si, self.mi.Vector3f(*b))
            values.append([v[0], v[1], v[2]])
            pdfs.append(self.bsdf.pdf(self.ctx, self.si, self.mi.Vector3f(*b)))
        return np.array(values), np.array(pdfs)

    def sample(self, wi, u1, u2, uv):
        out = {"wo": [], "weight": [], "pdf": []}
        for a, s1, s2, c in zip(wi, u1, u2, uv):
            self._at(a, c)
            bs, w = self.bsdf.sample(self.ctx, self.si, float(s1), self.mi.Point2f(*s2))
            out["wo"].append([bs.wo[0], bs.wo[1], bs.wo[2]])
            out["weight"].append([w[0], w[1], w[2]])
            out["pdf"].append(bs.pdf)
        return {k: np.array(v) for k, v in out.items()}


def _queries(ours, n: int, seed: int):
    """wi, wo, uv rounded to float32: wo random for half the rows, sampled for the rest."""
    rng = np.random.default_rng(seed)
    uv = _f32(rng.random((2 * n, 2)))
    wi = _f32(np.concatenate((random_directions(n, seed + 1), random_directions(n, seed + 2, True))))
    bound = ours.at(uv) if ours.textured else ours
    sampled = bound.sample(wi, rng.random(2 * n), rng.random((2 * n, 2))).wo
    wo = _f32(np.concatenate((random_directions(n, seed + 3), sampled[n:])))
    return wi, wo, uv


@pytest.mark.mitsuba
@pytest.mark.parametrize("name", sorted(CASES))
def test_mitsuba_eval_pdf(name, mi):
    ours, spec = CASES[name]
    theirs = _MitsubaAt(mi, spec())
    wi, wo, uv = _queries(ours, 150, 700)
    value, pdf = theirs.eval_pdf(wi, wo, uv)
    bound = ours.at(uv) if ours.textured else ours
    assert np.count_nonzero(pdf) > 100
    _assert_close(bound.eval(wi, wo), value, rtol=1e-3, floor=1e-5, what=f"{name} eval")
    _assert_close(bound.pdf(wi, wo), pdf, rtol=1e-3, floor=1e-5, what=f"{name} pdf")


@pytest.mark.mitsuba
@pytest.mark.parametrize("name", sorted(CASES))
def test_mitsuba_sample(name, mi):
    """Same uniforms: same direction, weight and pdf (lobe choices may differ only at ties)."""
    ours, spec = CASES[name]
    theirs = _MitsubaAt(mi, spec())
    n, rng = 300, np.random.default_rng(710)
    wi = _f32(random_directions(n, 711))
    uv, u1 = _f32(rng.random((n, 2))), _f32(rng.random(n))
    u2 = _f32(np.clip(rng.random((n, 2)), 1e-6, 1 - 1e-6))
    ref = theirs.sample(wi, u1, u2, uv)
    bs = (ours.at(uv) if ours.textured else ours).sample(wi, u1, u2)
    their_valid = np.any(ref["weight"] > 0, axis=1)
    our_valid = bs.valid & np.any(bs.weight > 0, axis=1)
    close = np.linalg.norm(bs.wo - ref["wo"], axis=1) < 1e-3
    same = (our_valid == their_valid) & (close | ~our_valid)
    assert same.mean() > 0.97, same.mean()
    # Where the lobe is narrower than float32's resolution of directions (roughness
    # clamped to 1e-4: pdf ~ 1e5 and more) Mitsuba's own pdf carries its rounding.
    both = same & our_valid & (ref["pdf"] < 1e4)
    assert both.mean() > 0.3
    _assert_close(bs.weight[both], ref["weight"][both], rtol=2e-3, what=f"{name} sample weight")
    _assert_close(bs.pdf[both], ref["pdf"][both], rtol=2e-3, floor=1e-4, what=f"{name} sample pdf")


@pytest.mark.mitsuba
def test_mitsuba_texture_means(mi):
    """The numbers plastic picks lobes by: a bitmap's mean luminance, a checkerboard's mean."""
    theirs = mi.load_dict({"type": "bitmap", "filename": GRID_PNG})
    ours = BitmapTexture(read_bitmap(GRID_PNG))
    assert ours.mean() == pytest.approx(theirs.mean(), rel=1e-5)
    spec = _checker_spec([0.8, 0.2, 0.1], 0.3)
    assert _checker([0.8, 0.2, 0.1], 0.3).mean() == pytest.approx(mi.load_dict(spec).mean(), rel=1e-6)


def _sampler_at(bsdf, wi, uv, smooth_only=False):
    """chi2 callback at one texture coordinate; Dirac samples go to the null cell if asked."""
    def sample(u):
        n = u.shape[0]
        bound = bsdf.at(np.tile(uv, (n, 1))) if bsdf.textured else bsdf
        bs = bound.sample(tile(wi, n), u[:, 0], u[:, 1:])
        return bs.wo, bs.valid & ~(bs.delta if smooth_only else False)
    return sample


def _density_at(bsdf, wi, uv):
    def pdf(wo):
        bound = bsdf.at(np.tile(uv, (len(wo), 1))) if bsdf.textured else bsdf
        return bound.pdf(tile(wi, len(wo)), wo)
    return pdf


@statistical
@pytest.mark.parametrize("name, theta, uv", [("blend", 40.0, (0.1, 0.1)), ("blend", 70.0, (0.2, 0.1)),
                                             ("mask", 50.0, (0.1, 0.1)),
                                             ("twosided_two", 140.0, (0.5, 0.5))])
def test_chi2(name, theta, uv):
    """Sampled directions follow pdf(); the mask's pass-through is its null cell (1 - opacity)."""
    bsdf = CASES[name][0]
    wi = direction(theta)
    result = chi2_sphere(_sampler_at(bsdf, wi, np.array(uv), smooth_only=name == "mask"),
                         _density_at(bsdf, wi, np.array(uv)), n_samples=60_000, seed=720 + int(theta))
    assert result.passed, result.message


def test_mask_passes_light_straight_through():
    bsdf = MaskBSDF(Diffuse(0.5), 0.3)
    wi = tile(direction(30.0), 2000)
    bs = bsdf.sample(wi, np.random.default_rng(1).random(2000), np.full((2000, 2), 0.5))
    through = bs.delta
    assert abs(through.mean() - 0.7) < 0.05
    np.testing.assert_allclose(bs.wo[through], -wi[through])
    np.testing.assert_allclose(bs.weight[through], 1.0)
    np.testing.assert_allclose(bs.pdf[through], 0.7)
