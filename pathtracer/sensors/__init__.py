"""The camera side: the perspective sensor's rays, its importance (for paths that end at the
camera) and the film's reconstruction filters."""
