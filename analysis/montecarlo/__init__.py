"""Monte-Carlo robustness studies (``posfb montecarlo``).

One obvious place per job: ``config`` (the study YAML, its distributions with
Drake's names, its checks), ``sampling`` (one plant per ``(study, index)``:
random streams or a QMC/Saltelli design), ``coverage`` (inside or outside the
Assumption-1 bounds), ``worker`` (one sample: sample, identify, spectral radii,
run every controller), ``records`` (what a sample produces), ``store``
(SQLite), ``scheduler`` (local processes or Dask), ``provenance`` (code
version), ``cost`` (the ``--dry-run`` model), ``table`` (the tidy export),
``replay`` (one stored sample again), ``statistics`` (intervals, rankings,
Sobol' indices), ``results`` (a store as arrays), and the report:
``report`` with its sections ``stability``, ``sensitivity`` and
``convergence``.
"""
