"""The "How far from hardware?" study (issue 21): which drive-train and electronics
non-idealities, over ranges from the literature, move each controller's simulated
errors toward the paper's hardware measurements (Tables 3-4), one effect at a time
and combined, and whether the paper's ranking of the controllers survives them.

``spec`` reads the study file (``analysis/studies/realism/paper_table3.yaml``: the shared settings,
each effect's range and source) and makes one Monte-Carlo study per effect;
``findings`` reads their stores into the numbers the report states; ``report``
writes ``report.md`` and its figure. ``posfb realism`` runs all three.
"""
