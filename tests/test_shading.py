"""World-space BSDF evaluation and sampling (pathtracer.shading): grouping hits by BSDF.

BSDFs that differ only in constant colours share one group (per-row colours); the
numbers must be exactly those of evaluating every BSDF on its own hits.
"""
from types import SimpleNamespace

import numpy as np

from pathtracer.bsdfs import Conductor, Dielectric, Diffuse
from pathtracer.bsdfs.shading import _groups, eval_bsdf, sample_bsdf
from pathtracer.core.vec import normalize, to_local, to_world


def _scene_and_hits(shape_ids, seed=3):
    rng = np.random.default_rng(seed)
    bsdfs = [Diffuse([0.7, 0.1, 0.1]), Diffuse([0.1, 0.7, 0.1]), Diffuse(0.75),
             Conductor(), Dielectric()]
    scene = SimpleNamespace(bsdfs=bsdfs, shape_bsdf=np.arange(len(bsdfs), dtype=np.int32))
    n = len(shape_ids)
    hit = SimpleNamespace(shape=np.asarray(shape_ids, np.int32),
                          sh_n=normalize(rng.normal(size=(n, 3))))
    wi, wo = normalize(rng.normal(size=(n, 3))), normalize(rng.normal(size=(n, 3)))
    return scene, hit, wi, wo, rng.random(n), rng.random((n, 2))


def _one_by_one(scene, hit, wi, wo, u1, u2):
    """Reference: every hit evaluated and sampled by its own BSDF object."""
    n = len(wi)
    value, pdf = np.zeros((n, 3)), np.zeros(n)
    wo_s, weight = np.zeros((n, 3)), np.zeros((n, 3))
    for b, bsdf in enumerate(scene.bsdfs):
        rows = np.flatnonzero(scene.shape_bsdf[hit.shape] == b)
        nrm = hit.sh_n[rows]
        wl, ol = to_local(wi[rows], nrm), to_local(wo[rows], nrm)
        value[rows], pdf[rows] = bsdf.eval(wl, ol), bsdf.pdf(wl, ol)
        bs = bsdf.sample(wl, u1[rows], u2[rows])
        wo_s[rows] = to_world(bs.wo, nrm)
        weight[rows] = np.where(bs.valid[:, None], bs.weight, 0.0)
    return value, pdf, wo_s, weight


def test_colour_only_differences_share_one_group():
    scene, hit, *_ = _scene_and_hits(np.arange(200) % 5)
    groups = list(_groups(scene, hit))
    assert len(groups) == 3   # the three diffuse colours, the mirror, the glass
    merged = [bsdf for bsdf, rows in groups if isinstance(bsdf, Diffuse)]
    assert len(merged) == 1 and merged[0].reflectance.shape == (120, 3)


def test_grouped_results_equal_per_bsdf_results_exactly():
    for shape_ids in (np.arange(300) % 5,              # several groups: scattered rows
                      np.arange(300) % 3):             # diffuse only: one group, every row
        scene, hit, wi, wo, u1, u2 = _scene_and_hits(shape_ids)
        value, pdf = eval_bsdf(scene, hit, wi, wo)
        bs = sample_bsdf(scene, hit, wi, u1, u2)
        ref_value, ref_pdf, ref_wo, ref_weight = _one_by_one(scene, hit, wi, wo, u1, u2)
        assert np.array_equal(value, ref_value) and np.array_equal(pdf, ref_pdf)
        assert np.array_equal(bs.wo, ref_wo) and np.array_equal(bs.weight, ref_weight)
        assert value.flags.writeable and bs.weight.flags.writeable


def test_merging_leaves_the_scene_bsdfs_unchanged():
    scene, hit, wi, wo, u1, u2 = _scene_and_hits(np.arange(90) % 3)
    sample_bsdf(scene, hit, wi, u1, u2)
    assert [b.reflectance.shape for b in scene.bsdfs[:3]] == [(3,)] * 3


class _Batch(SimpleNamespace):
    """A hit batch that takes weak references (as the tracer's Hit does)."""


def test_grouping_is_kept_for_the_same_batch_only():
    """The grouping of hits by BSDF is kept for the next call on the *same* batch object;
    another batch (here the same hits reversed) is grouped afresh: its results are its own."""
    scene, hit, wi, wo, u1, u2 = _scene_and_hits([0, 1, 2, 3, 4, 0, 2, 2, 1, 4, 3, 0] * 10)
    batch = _Batch(**vars(hit))
    first = eval_bsdf(scene, batch, wi, wo)
    assert _groups(scene, batch) is _groups(scene, batch)   # kept
    expected = _one_by_one(scene, hit, wi, wo, u1, u2)
    np.testing.assert_array_equal(first[0], expected[0])
    rows = np.arange(len(wi))[::-1]
    reversed_batch = _Batch(shape=batch.shape[rows], sh_n=batch.sh_n[rows])
    value, pdf = eval_bsdf(scene, reversed_batch, wi[rows], wo[rows])
    np.testing.assert_array_equal(value, expected[0][rows])
    np.testing.assert_array_equal(pdf, expected[1][rows])
    bs = sample_bsdf(scene, reversed_batch, wi[rows], u1[rows], u2[rows])
    np.testing.assert_array_equal(bs.wo, expected[2][rows])
