"""Monte-Carlo robustness studies (``posfb montecarlo``) over the sampled plants of
``analysis.uncertainty``.

One obvious place per job: ``worker`` (one sample: sample, identify, spectral radii,
run every controller), ``records`` (what a sample produces), ``store``
(SQLite), ``scheduler`` (local processes or Dask; the code version it stores is
``analysis.common.provenance``'s), ``cost`` (the ``--dry-run`` model), ``table`` (the tidy export),
``replay`` (one stored sample again), ``results`` (a store as arrays), and the report:
``report`` with its sections ``stability``, ``sensitivity`` and
``convergence``.
"""
