"""Acceleration structures for triangle soups: the BVH (:mod:`.bvh`), the all-pairs test of
small meshes and the split of a big mesh from a room's few triangles (:mod:`.small_mesh`),
and the one-thread BLAS that the all-pairs test wants (:mod:`.blas`)."""
