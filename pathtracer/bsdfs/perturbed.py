r"""Shading-normal perturbation: Mitsuba's ``normalmap`` and ``bumpmap`` plugins.

Both evaluate a nested BSDF in a perturbed frame :math:`(s', t', n')` given in the local
shading frame of the hit. ``wi`` and ``wo`` are expressed in it, the nested BSDF is
queried there, and, as in Mitsuba 3.9.1:

* a pair counts only where ``wo`` lies on the same side of the unperturbed and of the
  perturbed surface (:math:`\cos\theta_o\,\cos\theta'_o > 0`); a sampled direction is
  mapped back and checked the same way;
* ``flip_invalid_normals`` (default true): where ``wi`` sees the perturbed normal from
  behind (:math:`\cos\theta_i\,(w_i\cdot n') \le 0`) the normal is mirrored about the
  unperturbed one, :math:`(n'_x, n'_y, n'_z) \to (-n'_x, -n'_y, n'_z)`;
* ``use_shadowing_function`` (default true): values and sample weights (not densities) are
  multiplied by Estevez et al.'s terminator term
  :math:`2 / (1 + \sqrt{1 + \alpha^2 \tan^2\theta_o})`, :math:`\alpha^2 = \min(\tan^2\theta_{n'} / 8, 1)`.

**normalmap**: :math:`n' = \mathrm{normalize}(2\,\mathrm{rgb} - 1)` of the ``normalmap``
texture, in Mitsuba's shading frame (tangent :math:`\partial p/\partial u`, see
:mod:`pathtracer.shapes.tangents`); :math:`s'` is that tangent made orthogonal to :math:`n'`.

**bumpmap**: with :math:`g = \text{scale}\cdot\nabla_{uv} h` of the height texture
(``eval_1_grad``), :math:`\partial p/\partial u' = \partial p/\partial u + (g_u - n\cdot
\partial p/\partial u)\,n` (likewise for :math:`v`), :math:`n' = \mathrm{normalize}(\partial
p/\partial u' \times \partial p/\partial v')`, turned to the geometric normal's side.
Mitsuba 3.9.1 then takes :math:`s'` from :math:`\partial p/\partial u` in *world*
coordinates orthogonalised against :math:`n'` in *local* ones; the tracer reproduces that
(it only turns the frame about :math:`n'`, which matters for anisotropic BSDFs alone).
"""
from __future__ import annotations

import copy

import numpy as np

from ..core.vec import dot_einsum
from ..scene.properties import Props, build_texture, children
from ..scene.registry import register
from ..textures.base import Texture
from ..textures.bitmap import BitmapTexture
from .base import BSDF, BSDFSample, make_sample
from .parameters import build_bsdf


def _normalize(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=1)[:, None]


def _gram_schmidt(v: np.ndarray, n: np.ndarray) -> np.ndarray:
    """``v`` made orthogonal to the unit vectors ``n`` and normalised (rows)."""
    return _normalize(v - dot_einsum(v, n)[:, None] * n)


def _tan_theta_2(v: np.ndarray) -> np.ndarray:
    z2 = v[:, 2] ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.maximum(1.0 - z2, 0.0) / z2


def shadow_terminator(n_perturbed: np.ndarray, wo: np.ndarray) -> np.ndarray:
    """Estevez et al.'s shadowing of a perturbed normal (both in the unperturbed frame) -> (n,)."""
    alpha_2 = np.minimum(0.125 * _tan_theta_2(n_perturbed), 1.0)
    with np.errstate(invalid="ignore"):
        g = 2.0 / (1.0 + np.sqrt(1.0 + alpha_2 * _tan_theta_2(wo)))
    return np.where(np.isfinite(g), g, 0.0)


class PerturbedNormal(BSDF):
    """Common part of :class:`NormalMap` and :class:`BumpMap`: ``nested`` evaluated in a
    frame whose normal ``self.normal`` (n, 3) and tangent hint are set by :meth:`at`."""

    needs_geometry = True

    def __init__(self, nested: BSDF, flip_invalid_normals: bool = True,
                 use_shadowing_function: bool = True):
        self.nested = nested
        self.flip_invalid_normals = bool(flip_invalid_normals)
        self.use_shadowing_function = bool(use_shadowing_function)
        self.has_smooth = nested.has_smooth
        self.is_delta = nested.is_delta
        self.refracts, self.eta = nested.refracts, getattr(nested, "eta", 1.0)
        self.normal = None      # (n, 3) perturbed normal, local frame, after at()
        self._geometry = None   # the hits' LocalGeometry, after at()

    @property
    def textured(self) -> bool:
        """Always evaluated per hit: the frame depends on the surface."""
        return True

    def at(self, uv: np.ndarray, geometry=None) -> "PerturbedNormal":
        """The BSDF with its perturbed normals at the hits (``geometry``:
        :class:`pathtracer.shapes.tangents.LocalGeometry` of the same rows)."""
        if geometry is None:
            raise ValueError(f"{type(self).__name__} needs the hits' differential geometry")
        bound = copy.copy(self)
        bound.nested = self.nested.at(uv, geometry) if self.nested.textured else self.nested
        bound.normal, bound._geometry = self._normal(uv, geometry), geometry
        return bound

    def _normal(self, uv, geometry) -> np.ndarray:
        raise NotImplementedError

    def _tangent(self, normal: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def _frame(self, wi: np.ndarray):
        """(s', t', n') rows for the query directions ``wi`` (after the flip of invalid normals)."""
        n = self.normal
        if self.flip_invalid_normals:
            flip = wi[:, 2] * dot_einsum(wi, n) <= 0.0
            n = np.where(flip[:, None], n * np.array([-1.0, -1.0, 1.0]), n)
        n = _normalize(n)
        s = self._tangent(n)
        return s, np.cross(n, s), n

    @staticmethod
    def _into(v, frame):
        s, t, n = frame
        return np.stack([dot_einsum(v, a) for a in (s, t, n)], axis=1)

    @staticmethod
    def _out_of(v, frame):
        s, t, n = frame
        return v[:, 0, None] * s + v[:, 1, None] * t + v[:, 2, None] * n

    def _terminator(self, n, wo):
        if not self.use_shadowing_function:
            return np.ones(len(wo))
        return shadow_terminator(n, wo)

    def eval(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """Nested value in the perturbed frame, times the terminator term -> (n, 3)."""
        frame = self._frame(wi)
        wo_p = self._into(wo, frame)
        active = wo[:, 2] * wo_p[:, 2] > 0.0
        value = self.nested.eval(self._into(wi, frame), wo_p) * self._terminator(frame[2], wo)[:, None]
        return np.where(active[:, None], value, 0.0)

    def pdf(self, wi: np.ndarray, wo: np.ndarray) -> np.ndarray:
        """Nested density in the perturbed frame -> (n,)."""
        frame = self._frame(wi)
        wo_p = self._into(wo, frame)
        active = wo[:, 2] * wo_p[:, 2] > 0.0
        return np.where(active, self.nested.pdf(self._into(wi, frame), wo_p), 0.0)

    def sample(self, wi: np.ndarray, u1: np.ndarray, u2: np.ndarray) -> BSDFSample:
        """Sample the nested BSDF in the perturbed frame and map the direction back."""
        frame = self._frame(wi)
        bs = self.nested.sample(self._into(wi, frame), u1, u2)
        wo = self._out_of(bs.wo, frame)
        valid = bs.valid & np.any(bs.weight != 0.0, axis=1) & (bs.wo[:, 2] * wo[:, 2] > 0.0)
        weight = bs.weight * self._terminator(frame[2], wo)[:, None]
        return make_sample(wo, weight, bs.pdf, bs.delta, bs.eta, valid)


class NormalMap(PerturbedNormal):
    """Mitsuba's ``normalmap``: the shading normal read from an RGB texture."""

    def __init__(self, nested: BSDF, normalmap: Texture, **flags):
        super().__init__(nested, **flags)
        self.normalmap = normalmap

    def _normal(self, uv, geometry) -> np.ndarray:
        n_mitsuba = 2.0 * self.normalmap.eval(uv) - 1.0     # in Mitsuba's (s, t, n)
        s = geometry.tangent
        t = np.cross(np.array([0.0, 0.0, 1.0]), s)
        normal = n_mitsuba[:, 0, None] * s + n_mitsuba[:, 1, None] * t
        normal[:, 2] += n_mitsuba[:, 2]
        return normal

    def _tangent(self, normal: np.ndarray) -> np.ndarray:
        # Mitsuba: normalize((1, 0, 0) - n n_x) in its frame, i.e. its tangent made
        # orthogonal to n'.
        return _gram_schmidt(self._geometry.tangent, normal)


class BumpMap(PerturbedNormal):
    """Mitsuba's ``bumpmap``: the shading normal of a surface displaced by a height texture."""

    def __init__(self, nested: BSDF, height: Texture, scale: float = 1.0, **flags):
        super().__init__(nested, **flags)
        self.height, self.scale = height, float(scale)

    def _normal(self, uv, geometry) -> np.ndarray:
        grad = self.scale * self.height.eval_1_grad(uv)
        up = np.array([0.0, 0.0, 1.0])   # the shading normal, local frame
        dp_du = geometry.dp_du + (grad[:, 0] - geometry.dp_du[:, 2])[:, None] * up
        dp_dv = geometry.dp_dv + (grad[:, 1] - geometry.dp_dv[:, 2])[:, None] * up
        n = _normalize(np.cross(dp_du, dp_dv))
        return np.where((dot_einsum(geometry.n_geo, n) < 0.0)[:, None], -n, n)

    def _tangent(self, normal: np.ndarray) -> np.ndarray:
        # Mitsuba 3.9.1 orthogonalises the world dp/du against the local n' and reads the
        # result in its local frame; we do the same in its frame and rotate into ours.
        s_m = self._geometry.tangent
        c, d = s_m[:, 0], s_m[:, 1]
        to_m = np.stack((c * normal[:, 0] + d * normal[:, 1], -d * normal[:, 0] + c * normal[:, 1],
                         normal[:, 2]), axis=1)
        s = _gram_schmidt(self._geometry.dp_du_world, to_m)
        return np.stack((c * s[:, 0] - d * s[:, 1], d * s[:, 0] + c * s[:, 1], s[:, 2]), axis=1)


def _nested_and_flags(props: Props) -> tuple[dict, BSDF, dict]:
    """What ``normalmap`` and ``bumpmap`` share: the nested elements, the one BSDF built,
    and ``flip_invalid_normals`` and ``use_shadowing_function`` (true), as in Mitsuba."""
    plugin = props.plugin
    kids = children(plugin, {"bsdf": 1, "texture": 1})
    if not kids["bsdf"]:
        raise plugin.error(f"{plugin.type} needs exactly one nested <bsdf>")
    nested = build_bsdf(kids["bsdf"][0], props.folders, props.texture_cache)
    flags = dict(flip_invalid_normals=props.bool("flip_invalid_normals", True),
                 use_shadowing_function=props.bool("use_shadowing_function", True))
    return kids, nested, flags


@register("bsdf", "bumpmap")
def create_bumpmap(props: Props) -> BumpMap:
    """One nested BSDF, one height texture of any name (a bitmap), ``scale`` (1)."""
    kids, nested, flags = _nested_and_flags(props)
    if not kids["texture"]:
        raise props.plugin.error("bumpmap needs one nested <texture> (the height)")
    name = next(iter(props.textures))
    props.used.add(name)
    texture = build_texture(props.textures[name], props.folders, props.texture_cache)
    if not isinstance(texture, BitmapTexture):
        raise props.textures[name].error(
            f"a bumpmap's height must be a bitmap: Mitsuba differentiates only bitmaps "
            f"(eval_1_grad), not \"{props.textures[name].type}\"")
    return BumpMap(nested, texture, props.float("scale", 1.0), **flags)


@register("bsdf", "normalmap")
def create_normalmap(props: Props) -> NormalMap:
    """One nested BSDF and an RGB texture named ``normalmap``."""
    _, nested, flags = _nested_and_flags(props)
    if "normalmap" not in props.textures:
        raise props.plugin.error("normalmap needs a <texture name=\"normalmap\">")
    props.used.add("normalmap")
    texture = build_texture(props.textures["normalmap"], props.folders, props.texture_cache)
    return NormalMap(nested, texture, **flags)
