"""Running the reference side on a Dask cluster (``--dask ADDRESS``, docs/cluster.md)."""
