"""The reproduction of the paper's Sec. 4 (``posfb reproduce``): ``experiment`` (the cases'
runs and their entries in ``results.json``), ``reproduce`` (every run, table, figure and
the report), ``report`` (``report.md``), ``diagnostics`` (the explanations of its
differences from the paper) and the scripts ``nominal_experiment`` and
``payload_experiment`` (one case each)."""
