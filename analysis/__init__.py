"""Metrics, experiments, Monte Carlo, plots, reports and the ``posfb`` command line."""
