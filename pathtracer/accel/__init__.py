"""Acceleration structures for triangle soups: the BVH and the small-mesh fast paths."""
