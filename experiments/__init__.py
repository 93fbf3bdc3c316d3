"""Experiment scripts: error-vs-spp plots, the lecture's figures, estimator comparisons, sweeps.

Each module runs as ``python -m experiments.NAME --help`` and writes PNG + SVG
figures and the numbers behind them (CSV / JSON) into ``--out``. See
docs/experiments.md for how to read each figure.
"""
