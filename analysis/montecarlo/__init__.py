"""Monte-Carlo robustness studies (``posfb montecarlo``).

One obvious place per job: ``config`` (the study YAML and its checks),
``sampling`` (one plant per ``(seed, index)``), ``coverage`` (inside or outside
the Assumption-1 bounds), ``worker`` (one sample: sample, identify, run every
controller), ``records`` (what a sample produces), ``store`` (SQLite),
``scheduler`` (local processes or Dask), ``provenance`` (code version),
``report`` (statistics, figures, Markdown).
"""
