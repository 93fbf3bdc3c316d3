"""Judging renderers that are not ours: their runs, their images and the checks on them."""
